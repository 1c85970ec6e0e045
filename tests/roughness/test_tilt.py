"""The facet tilt α of Sawtooth and Cone: 0 ≤ α < π/2 rad, the open bound said as such."""

import math

import pytest

import mbimpact as mbi


@pytest.mark.parametrize("measure", [mbi.Cone, mbi.Sawtooth])
@pytest.mark.parametrize("alpha", [1.6, math.pi / 2, -0.1])
def test_the_tilt_message_gives_the_open_bound_and_the_unit(measure, alpha):
    with pytest.raises(mbi.ParameterError) as info:
        measure(alpha)
    assert str(info.value) == f"alpha must satisfy 0 ≤ alpha < π/2 rad (1.5708); got {alpha:g} rad"


def test_tilts_inside_the_range_are_kept():
    assert mbi.Cone(0.0).alpha == 0.0 and mbi.Sawtooth(math.pi / 2 - 1e-9).alpha < math.pi / 2


def test_a_scene_file_with_too_steep_a_tilt_names_the_key(tmp_path):
    path = tmp_path / "steep.toml"
    path.write_text('[mechanism]\nmodel = "point_mass_3d"\n[initial]\nq = [0.0, 0.0, 1.0]\n'
                    '[[contacts]]\nframe = "mass"\ne = 0.5\nroughness = { kind = "cone", alpha = 1.6 }\n')
    with pytest.raises(mbi.SceneError, match=r"contacts\[0\]\.roughness.*alpha must satisfy 0 ≤ alpha < π/2 rad "
                                             r"\(1.5708\); got 1.6 rad"):
        mbi.load_scene(path)
