"""Every documented error: a named subclass of mbi.ImpactError with a useful message."""

import math

import numpy as np
import pytest

import mbimpact as mbi

I2, I3 = np.eye(2), np.eye(3)
V2 = np.array([0.3, -1.0])
LAW2 = mbi.RoughLaw(mbi.Sawtooth(0.3), 0.5)


def test_tree_is_rooted_in_value_error():
    classes = [getattr(mbi.errors, name) for name in mbi.errors.__all__ if isinstance(getattr(mbi.errors, name), type)]
    assert len(classes) >= 15
    for cls in classes:
        assert getattr(mbi, cls.__name__) is cls
        assert issubclass(cls, mbi.ImpactError) and issubclass(cls, ValueError)
    # the warnings are in the tree too, and are real warnings
    for cls in (mbi.ImpactWarning, mbi.AccuracyWarning, mbi.NoSeparationWarning):
        assert issubclass(cls, Warning) and issubclass(cls, mbi.ImpactError)


@pytest.mark.parametrize(
    "A, J, v, frame, match",
    [
        (np.eye(2, 3), I2, V2, [0, 1], "square"),
        (I2, np.eye(2, 3), V2, [0, 1], r"shape \(d, 2\)"),
        (I2, np.eye(4, 2), V2, [0, 1], "d = 2 or 3"),
        (I2, I2, [0.3, -1.0, 0.0], [0, 1], "v has shape"),
        (I2, I2, V2, [0, 0, 1], "frame must be"),
        (np.ones(2), I2, V2, [0, 1], "2 dimension"),
        (I2, I2, [[0.3, -1.0]], [0, 1], "1 dimension"),
    ],
)
def test_wrong_shapes(A, J, v, frame, match):
    with pytest.raises(mbi.ShapeError, match=match):
        LAW2.apply(A, J, v, frame)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
@pytest.mark.parametrize("where", ["A", "J", "v", "frame"])
def test_non_finite_anywhere(bad, where):
    args = {"A": I2.copy(), "J": I2.copy(), "v": V2.copy(), "frame": np.array([0.0, 1.0])}
    args[where].flat[0] = bad
    with pytest.raises(mbi.NonFiniteError, match=where):
        LAW2.apply(**args)


def test_not_symmetric():
    with pytest.raises(mbi.NotPositiveDefiniteError, match="not symmetric"):
        LAW2.apply([[1.0, 0.5], [0.0, 1.0]], I2, V2, [0, 1])


@pytest.mark.parametrize("A, lam", [([[1.0, 2.0], [2.0, 1.0]], "-1"), ([[0.0, 0.0], [0.0, 1.0]], "0")])
def test_not_positive_definite_reports_smallest_eigenvalue(A, lam):
    with pytest.raises(mbi.NotPositiveDefiniteError, match=f"smallest eigenvalue {lam}"):
        LAW2.apply(A, I2, V2, [0, 1])


@pytest.mark.parametrize("e", [-0.1, 1.0001, math.nan, "x"])
def test_e_out_of_range(e):
    with pytest.raises(mbi.ImpactError, match="e"):
        mbi.RoughLaw(mbi.Smooth(), e)
    with pytest.raises(mbi.ImpactError):
        mbi.NewtonLaw(e)


@pytest.mark.parametrize("k", [-0.1, 1.5, math.inf])
def test_k_out_of_range(k):
    with pytest.raises(mbi.ImpactError, match="k"):
        mbi.RoughLaw(mbi.Smooth(), k=k)
    with pytest.raises(mbi.ImpactError):
        mbi.e_from_k(k)


def test_k_equal_one_is_the_limit_e_zero():
    assert mbi.RoughLaw(mbi.Smooth(), k=1.0).e == 0.0


def test_both_or_neither_e_and_k():
    with pytest.raises(mbi.ParameterError, match="exactly one"):
        mbi.RoughLaw(mbi.Smooth(), 0.5, k=0.1)
    with pytest.raises(mbi.ParameterError, match="exactly one"):
        mbi.RoughLaw(mbi.Smooth())
    with pytest.raises(mbi.ParameterError, match="exactly one"):
        mbi.NewtonLaw()


@pytest.mark.parametrize("alpha", [-0.01, math.pi / 2, 2.0, math.nan])
@pytest.mark.parametrize("cls", [mbi.Sawtooth, mbi.Cone])
def test_alpha_out_of_range(cls, alpha):
    with pytest.raises(mbi.ImpactError, match="alpha"):
        cls(alpha)


def test_facet_weights():
    m = np.array([[0.0, 1.0], [math.sin(0.2), math.cos(0.2)]])
    with pytest.raises(mbi.RoughnessError, match="non-negative"):
        mbi.Facets(m, [1.0, -0.5])
    with pytest.raises(mbi.RoughnessError, match="all zero"):
        mbi.Facets(m, [0.0, 0.0])
    with pytest.raises(mbi.ShapeError, match="weights"):
        mbi.Facets(m, [1.0, 1.0, 1.0])


def test_facet_normals():
    with pytest.raises(mbi.RoughnessError, match="unit"):
        mbi.Facets([[0.0, 1.1]])
    with pytest.raises(mbi.RoughnessError, match="d = 2 or 3"):
        mbi.Facets([[0.0, 0.0, 0.0, 1.0]])
    with pytest.raises(mbi.RoughnessError, match="last component"):
        mbi.Facets([[1.0, 0.0]])
    with pytest.raises(mbi.NonFiniteError):
        mbi.Facets([[math.nan, 1.0]])


def test_roughness_of_wrong_dimension():
    with pytest.raises(mbi.RoughnessError, match="3-D contact space but J has 2 rows"):
        mbi.RoughLaw(mbi.Cone(0.2), 0.5).apply(I2, I2, V2, [0, 1])
    with pytest.raises(mbi.RoughnessError, match="2-D"):
        LAW2.apply(I3, I3, [0.1, 0.0, -1.0], [0, 0, 1])
    with pytest.raises(mbi.RoughnessError, match="2-D"):
        mbi.RoughLaw(mbi.Facets([[0.0, 1.0]]), 0.5).apply(I3, I3, [0.1, 0.0, -1.0], [0, 0, 1])
    with pytest.raises(mbi.RoughnessError, match="Roughness measure"):
        mbi.RoughLaw(0.3, 0.5)


def test_zero_normal():
    with pytest.raises(mbi.ShapeError, match="zero vector"):
        LAW2.apply(I2, I2, V2, [0.0, 0.0])
    with pytest.raises(mbi.ShapeError, match="zero vector"):
        mbi.PointContact("tool0", normal=(0, 0, 0))


def test_frame_not_a_rotation():
    with pytest.raises(mbi.ShapeError, match="rotation"):
        LAW2.apply(I2, I2, V2, [[1.0, 0.0], [0.5, 1.0]])


def test_unknown_robot_lists_close_matches():
    with pytest.raises(mbi.RobotNotFoundError, match="close matches: ur5"):
        mbi.Mechanism.from_robot("ur55")
    with pytest.raises(mbi.RobotNotFoundError, match="not found"):
        mbi.Mechanism.from_urdf("/no/such/file.urdf")
    with pytest.raises(mbi.RobotNotFoundError, match="close matches: .*point_mass_2d"):
        mbi.Mechanism.from_model("point_mass")


def test_unknown_frame_lists_close_matches():
    mech = mbi.Mechanism.from_robot("ur5")
    with pytest.raises(mbi.FrameNotFoundError, match="frames with 'tool'.*tool0"):
        mbi.impact(mech, mech.neutral(), np.ones(6), mbi.PointContact("tool"), mbi.NewtonLaw(0.5))


@pytest.mark.parametrize("v", [[0.3, 1.0], [1.0, 0.0], [0.0, 0.0]])
def test_velocity_not_approaching(v):
    with pytest.raises(mbi.NoImpactError, match="does not approach"):
        LAW2.apply(I2, I2, v, [0, 1])
    with pytest.raises(mbi.NoImpactError):
        mbi.NewtonLaw(0.5).apply(I2, I2, v, [0, 1])


def test_contact_point_that_cannot_move_along_the_normal():
    J = np.array([[1.0, 0.0], [0.0, 1e-300]])
    with pytest.raises(mbi.NoImpactError, match="cannot move"):
        mbi.NewtonLaw(0.5).apply(I2, J, [0.0, -1.0], [0, 1])


def test_no_facet_faces_the_velocity():
    one = mbi.Facets([[math.sin(0.5), math.cos(0.5)]])  # a single tooth facing +x
    with pytest.raises(mbi.NoFacingFacetError, match="G\\*"):
        mbi.RoughLaw(one, 0.5).apply(I2, I2, [5.0, -1.0], [0, 1])


def test_degenerate_facets_never_produce_nan():
    """A facet with mᵀWm = 0 (Jᵀm = 0, rank-deficient J) carries no flux and is skipped."""
    a = 0.4
    m = np.array([0.0, math.sin(a), math.cos(a)])
    J = np.array([[1.0, 0.0], [0.0, math.cos(a)], [0.0, -math.sin(a)]])
    assert np.allclose(J.T @ m, 0)
    law = mbi.RoughLaw(mbi.Facets([m, [0.0, 0.0, 1.0]]), 0.5)
    res = law.apply(I2, J, [0.3, 1.0], [0, 0, 1])
    assert np.all(np.isfinite(res.v_plus))
    np.testing.assert_allclose(res.v_plus, mbi.NewtonLaw(0.5).apply(I2, J, [0.3, 1.0], [0, 0, 1]).v_plus)
    # only degenerate facets facing: a named error, not NaN
    with pytest.raises(mbi.ImpactError):
        mbi.RoughLaw(mbi.Facets([m]), 0.5).apply(I2, J, [0.3, 1.0], [0, 0, 1])


def test_bad_flux_and_rtol():
    with pytest.raises(mbi.ParameterError, match="flux"):
        mbi.RoughLaw(mbi.Smooth(), 0.5, flux="area")
    with pytest.raises(mbi.ParameterError, match="rtol"):
        mbi.RoughLaw(mbi.Cone(0.1), 0.5, rtol=-1)
    with pytest.raises(mbi.ParameterError, match="max_nodes"):
        mbi.RoughLaw(mbi.Cone(0.1), 0.5, max_nodes=2)


def test_unreachable_rtol_warns():
    law = mbi.RoughLaw(mbi.Cone(0.8), 0.5, rtol=1e-15, max_nodes=32)
    with pytest.warns(mbi.AccuracyWarning, match="rtol"):
        res = law.apply(np.diag([1.0, 30.0, 1.0]), I3, [2.0, 0.5, -1.0], [0, 0, 1])
    assert res.nodes == 32 and res.error_estimate > 1e-15


def test_mechanism_needs_a_pinocchio_model():
    with pytest.raises(mbi.ParameterError, match="pinocchio.Model"):
        mbi.Mechanism("not a model")


def test_bad_state_shapes():
    mech = mbi.Mechanism.from_robot("ur5")
    with pytest.raises(mbi.ShapeError, match="q has shape"):
        mbi.impact(mech, np.zeros(5), np.ones(6), mbi.PointContact("tool0"), mbi.NewtonLaw(0.5))
    with pytest.raises(mbi.NonFiniteError, match="v"):
        mbi.impact(mech, np.zeros(6), np.full(6, math.nan), mbi.PointContact("tool0"), mbi.NewtonLaw(0.5))


def _a_foot_that_keeps_approaching() -> dict:
    """A Solo12 foot pressed on the ground: the cone's impact leaves it approaching (NoSeparationWarning).
    The names a user's code would hold, as a namespace to run such code in."""
    solo = mbi.Mechanism.from_robot("solo12")
    q = solo.neutral()
    q[2] = 0.336
    v = np.zeros(solo.nv)
    v[[0, 2]] = 0.3, -1.0
    return {"mbi": mbi, "solo": solo, "q": q, "v": v, "contact": mbi.PointContact("FL_FOOT"),
            "law": mbi.RoughLaw(mbi.Cone(0.3), 0.5)}


def test_warnings_name_the_users_line_however_deep_the_package_warns():
    # a Solo12 foot pressed on the ground keeps approaching after the cone's impact: NoSeparationWarning,
    # issued several calls deep in the package (impact → the law → its result) and named at the caller
    import inspect
    import warnings

    namespace = _a_foot_that_keeps_approaching()
    solo, q, v, contact, law = (namespace[k] for k in ("solo", "q", "v", "contact", "law"))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for _ in range(3):  # the same code objects again: what is decided once per code object holds
            line = inspect.currentframe().f_lineno + 1
            mbi.impact(solo, q, v, contact, law)
            assert (caught[-1].category, caught[-1].filename, caught[-1].lineno) == (
                mbi.NoSeparationWarning, __file__, line)
        exec(compile("\n\nmbi.impact(solo, q, v, contact, law)\n", "<user code>", "exec"), namespace)
        assert (caught[-1].filename, caught[-1].lineno) == ("<user code>", 3)


def test_a_filter_on_the_callers_module_and_its_registry_are_those_warnings_warn_would_use():
    # mbimpact.errors.warn hands the warning to warnings.warn_explicit with the caller's frame in hand: the
    # module a filter matches is the caller's __name__, and the warning is recorded in the caller's
    # __warningregistry__ (the default filter's once per line), as warnings.warn(stacklevel=...) would do
    import re
    import warnings

    namespace = _a_foot_that_keeps_approaching()
    solo, q, v, contact, law = (namespace[k] for k in ("solo", "q", "v", "contact", "law"))
    code = compile("mbi.impact(solo, q, v, contact, law)\n", "<user code>", "exec")
    namespace["__name__"] = "a_users_module"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        warnings.filterwarnings("ignore", category=mbi.NoSeparationWarning, module=re.escape(__name__))
        mbi.impact(solo, q, v, contact, law)
        assert not caught  # this module's filter
        exec(code, namespace)
        assert len(caught) == 1 and caught[0].category is mbi.NoSeparationWarning  # another module
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("default")
        for _ in range(2):
            exec(code, namespace)
        assert len(caught) == 1
        assert any(key[1] is mbi.NoSeparationWarning for key in namespace["__warningregistry__"] if key != "version")


def test_a_warning_from_code_without_line_numbers_names_line_minus_one():
    # warnings.warn reports line −1 where the caller's code has no line table; so does mbimpact.errors.warn
    import warnings

    namespace = _a_foot_that_keeps_approaching()
    code = compile("mbi.impact(solo, q, v, contact, law)\n", "<no lines>", "exec").replace(co_linetable=b"")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        exec(code, namespace)
    assert [(w.category, w.filename, w.lineno) for w in caught] == [(mbi.NoSeparationWarning, "<no lines>", -1)]



def test_a_category_the_filters_drop_whatever_its_origin_is_ignored_without_a_walk_of_the_stack():
    # mbimpact.errors.ignored decides only what warn_explicit would decide for any text and frame: the first
    # filter matching the category is "ignore" and asks nothing else; otherwise warn_explicit decides
    import re
    import warnings

    from mbimpact.errors import ignored

    namespace = _a_foot_that_keeps_approaching()
    solo, q, v, contact, law = (namespace[k] for k in ("solo", "q", "v", "contact", "law"))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert not ignored(mbi.NoSeparationWarning)
        warnings.simplefilter("ignore", mbi.ImpactWarning)  # a parent class
        assert ignored(mbi.NoSeparationWarning) and ignored(mbi.AccuracyWarning) and not ignored(UserWarning)
        mbi.impact(solo, q, v, contact, law)
        assert not caught and "__warningregistry__" not in namespace
        # a filter on the text, the module or the line before it: not decided here, and warn_explicit honours it
        for first in ({"message": "no such text"}, {"module": re.escape("nowhere")}, {"lineno": 7}):
            with warnings.catch_warnings():
                warnings.filterwarnings("always", category=mbi.NoSeparationWarning, **first)
                assert not ignored(mbi.NoSeparationWarning)
                mbi.impact(solo, q, v, contact, law)
        assert not caught  # none of those matched this warning: the "ignore" behind them did
        warnings.simplefilter("error", mbi.NoSeparationWarning)
        assert not ignored(mbi.NoSeparationWarning)
        with pytest.raises(mbi.NoSeparationWarning):
            mbi.impact(solo, q, v, contact, law)
    with warnings.catch_warnings():
        warnings.resetwarnings()  # no filter at all: Python's default action shows it
        assert not ignored(mbi.NoSeparationWarning)
