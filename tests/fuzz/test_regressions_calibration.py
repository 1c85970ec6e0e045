"""Regressions of the fuzzing campaign in calibration and the compare/fit apps: one test per reproducer.

Each test asserts the exact named error class and a fragment of its message, with every warning
turned into an error (no numpy ComplexWarning or RuntimeWarning may leak), under
:func:`tests.helpers.time_limit`. The command line runs in-process: it must end with its exit
status and a message, never a traceback.

1. ``ImpactTable(theta, columns=None)`` (or a list, a string, a number) raised dict()'s bare errors;
2. a complex ``theta_deg`` (or column, or speed) leaked numpy's ComplexWarning;
3. ``mbimpact fit DATA --law newton --seed -1`` ended in numpy's ValueError (a traceback);
4. ``apps.compare.approach_velocity`` raised numpy's LinAlgError on a singular mass matrix.

Further bugs found on the way (a path that is not one, a file that is not UTF-8, a repeated column;
``fit(max_nfev=1.5)`` looping without end; ``fit``'s other options of the wrong kind) have a test each
after the four.
"""

from __future__ import annotations

import io
import warnings
from collections.abc import Iterator
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path
from typing import Any
from unittest import mock

import numpy as np
import pytest

import mbimpact as mbi
from mbimpact.apps import compare
from mbimpact.apps.cli import main as cli_main
from mbimpact.calibration import Ball, FitError, ImpactTable, TableError, predict
from tests.helpers import time_limit

LIMIT = 60.0  # seconds per test: a small fit takes well under one on a busy 2-core machine
THETA = np.array([0.0, 30.0, 60.0])
KAPPA = np.array([0.8, 0.7, 0.6])
TABLE = "theta_deg,kappa\n0,0.8\n30,0.7\n60,0.6\n"

#: A pendulum whose arm has no mass: A(q) = [[0]] is singular.
MASSLESS = """<?xml version="1.0"?>
<robot name="massless">
  <link name="base"/>
  <link name="arm"/>
  <joint name="hinge" type="revolute"><parent link="base"/><child link="arm"/><origin xyz="0 0 1"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="10" velocity="10"/></joint>
  <link name="tip"/>
  <joint name="tip_joint" type="fixed"><parent link="arm"/><child link="tip"/><origin xyz="0 0 -1"/></joint>
</robot>
"""


@pytest.fixture(autouse=True)
def strict() -> Iterator[None]:
    """Every test runs under a time limit, with every warning an error."""
    with time_limit(LIMIT), warnings.catch_warnings():
        warnings.simplefilter("error")
        yield


def table() -> ImpactTable:
    return ImpactTable(THETA, {"kappa": KAPPA})


def run_cli(argv: list[str]) -> tuple[int, str, str]:
    """``mbimpact argv`` in-process: (exit code, stdout, stderr); argparse's exits are caught."""
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        try:
            code = cli_main(argv)
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else 2
    return code, out.getvalue(), err.getvalue()


# ---------------------------------------------------------------- 1. columns that are not a mapping

@pytest.mark.parametrize("columns", [None, [1, 2, 3], [("kappa", KAPPA)], "kappa", 3, KAPPA])
def test_table_columns_must_be_a_mapping(columns: Any) -> None:
    with pytest.raises(TableError, match="columns must be a mapping of quantity name to values"):
        ImpactTable(THETA, columns)
    # meta and name, the table's other containers, are named too
    with pytest.raises(TableError, match="meta must be a mapping of str to str"):
        ImpactTable(THETA, {"kappa": KAPPA}, meta=columns)
    if not isinstance(columns, str):  # a str is a valid name
        with pytest.raises(TableError, match="name must be a str"):
            ImpactTable(THETA, {"kappa": KAPPA}, name=columns)
    with pytest.raises(TableError, match="meta must be a mapping of str to str"):
        ImpactTable(THETA, {"kappa": KAPPA}, meta={"body": 3})


# ---------------------------------------------------------------- 2. complex arrays

@pytest.mark.parametrize("where", ["theta_deg", "kappa", "speed"])
@pytest.mark.parametrize("values", [THETA + 1j, [np.complex64(1j), 10.0, 20.0], [1j, None, 2.0]],
                         ids=["complex128", "complex64 in objects", "complex with a gap"])
def test_table_refuses_complex_arrays(where: str, values: Any) -> None:
    args: dict[str, Any] = {"theta_deg": THETA, "columns": {"kappa": KAPPA}, "speed": np.ones(3)}
    if where == "kappa":
        args["columns"] = {"kappa": values}
    else:
        args[where] = values
    with pytest.raises(TableError, match=f"column {where} must hold real numbers"):
        ImpactTable(**args)
    # and the valid forms still work: None and NaN are gaps of a quantity
    assert np.isnan(ImpactTable(THETA, {"kappa": [0.8, None, np.nan]}).values("kappa")[1:]).all()


# ---------------------------------------------------------------- 3. a negative seed

@pytest.mark.parametrize("seed", [-1, 1.5, "x", True, np.float64(2.0)])
def test_fit_seed_must_be_a_non_negative_integer(seed: Any, tmp_path: Path) -> None:
    with pytest.raises(FitError, match="seed must be an integer ≥ 0"):
        mbi.fit(table(), "newton", seed=seed)
    for valid in (0, 2**70, np.int64(3), None):  # numpy takes any integer ≥ 0; None draws fresh entropy
        assert mbi.fit(table(), "newton", seed=valid, starts=2).starts == 2
    path = tmp_path / "table.csv"
    path.write_text(TABLE)
    for bad in ("-1", "1.5", "x", ""):
        code, out, err = run_cli(["fit", str(path), "--law", "newton", "--seed", bad])
        assert code == 2 and "argument --seed" in err and "Traceback" not in err + out, (bad, err)
    code, out, err = run_cli(["fit", str(path), "--law", "newton", "--seed", str(2**70)])
    assert code == 0 and "newton" in out and "Traceback" not in err


# ---------------------------------------------------------------- 4. a singular mass matrix

@pytest.fixture(scope="module")
def massless(tmp_path_factory: pytest.TempPathFactory) -> mbi.Mechanism:
    path = tmp_path_factory.mktemp("massless") / "massless.urdf"
    path.write_text(MASSLESS)
    return mbi.Mechanism.from_urdf(path)


def test_approach_velocity_names_a_singular_mass_matrix(massless: mbi.Mechanism) -> None:
    contact = mbi.PointContact("tip")
    q = np.array([0.3])
    with pytest.raises(mbi.NotPositiveDefiniteError, match="mass matrix of massless.*massless links"):
        compare.approach_velocity(massless, q, contact, 0.3)
    with pytest.raises(mbi.NotPositiveDefiniteError, match="mass matrix of massless"):
        compare.compare_laws(massless, q, contact, {"Newton": mbi.NewtonLaw(0.5)}, [10.0, 20.0])
    # a mechanism whose A(q) is singular with a non-zero diagonal (a mock standing in for romeo's massless links)
    mech = mock.MagicMock(spec=mbi.Mechanism)
    mech.name = "mock"
    mech.mass_matrix.return_value = np.array([[1.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    mech.point_jacobian.return_value = np.eye(3)
    with pytest.raises(mbi.NotPositiveDefiniteError, match="mass matrix of mock"):
        compare.approach_velocity(mech, np.zeros(3), contact, 0.3)
    # the other arguments are named errors too (before: numpy's warnings and bare errors)
    with pytest.raises(mbi.ShapeError, match="q must be real"):
        compare.approach_velocity(massless, q + 0j, contact, 0.3)
    with pytest.raises(mbi.ParameterError, match="speed"):
        compare.approach_velocity(massless, q, contact, 0.3, -1.0)
    with pytest.raises(mbi.ParameterError, match="mech must be an mbimpact.Mechanism"):
        compare.approach_velocity(None, q, contact, 0.3)
    with pytest.raises(mbi.ParameterError, match="laws must be a mapping"):
        compare.compare_laws(massless, q, contact, [mbi.NewtonLaw(0.5)], [10.0])
    with pytest.raises(mbi.ShapeError, match="betas_deg must be real"):
        compare.compare_laws(massless, q, contact, {"Newton": mbi.NewtonLaw(0.5)}, [10j])
    with pytest.raises(mbi.ParameterError, match="rows must be a list of CompareRow"):
        compare.format_table(None)  # type: ignore[arg-type]
    with pytest.raises(mbi.ParameterError, match="path must be a file path"):
        compare.write_csv([], None)  # type: ignore[arg-type]


# ---------------------------------------------------------------- found on the way

@pytest.mark.parametrize("content,match", [
    (b"theta_deg,kappa\n10,\xff\xfe\n", "is not UTF-8 text"),
    (b"theta_deg,theta_deg,kappa\n10,10,0.5\n", "'theta_deg' appear more than once"),
])
def test_table_files_that_cannot_be_read_are_named(tmp_path: Path, content: bytes, match: str) -> None:
    path = tmp_path / "bad.csv"
    path.write_bytes(content)
    with pytest.raises(TableError, match=match):
        ImpactTable.from_csv(path)
    code, out, err = run_cli(["fit", str(path), "--law", "newton"])
    assert code == 2 and "Traceback" not in err + out
    for bad in (None, 3, b"table.csv"):
        with pytest.raises(TableError, match="path must be a file path"):
            ImpactTable.from_csv(bad)  # type: ignore[arg-type]


@pytest.mark.parametrize("kwargs,match", [
    ({"max_nfev": 1.5}, "max_nfev must be an integer"),  # least_squares looped without end
    ({"max_nfev": 0}, "max_nfev must be an integer"),
    ({"tol": 0.0}, "tol must be a number"),  # least_squares warned
    ({"starts": True}, "starts must be an integer"),
    ({"starts": 10**9}, "starts must be an integer"),
    ({"weights": [1.0]}, "weights must be a mapping"),
    ({"weights": {"kappa": "x"}}, "weights must be finite numbers"),
    ({"fixed": [1.0]}, "fixed must be a mapping"),
    ({"bounds": [1.0]}, "bounds must be a mapping"),
    ({"bounds": {"e": (0.1, np.inf)}}, "must be finite with lower < upper"),
    ({"free": 3}, "free must be a name or a tuple of names"),
    ({"quantities": 3}, "quantities must be a name or a tuple of names"),
])
def test_fit_options_of_the_wrong_kind_are_named(kwargs: dict[str, Any], match: str) -> None:
    with pytest.raises(FitError, match=match):
        mbi.fit(table(), "newton", **kwargs)


def test_predict_and_bodies_name_bad_inputs() -> None:
    law = mbi.NewtonLaw(0.8)
    with pytest.raises(FitError, match="theta_deg must be real numbers"):
        predict(law, THETA + 1j)
    with pytest.raises(FitError, match="speed must be real numbers"):
        predict(law, [10.0, 20.0], speed=1j)
    with pytest.raises(FitError, match="law must be an impact law"):
        predict(None, [10.0])  # type: ignore[arg-type]
    with pytest.raises(mbi.ParameterError, match="inertia 2/5 m R²"):
        Ball(1e200, 1e200)  # the default inertia overflowed with a bare OverflowError
    assert ImpactTable(THETA, {"kappa": KAPPA}, meta={"body": "  "}).body() is None  # was an IndexError
