import numpy as np
import pytest

from fishtail_design.errors import ProblemFileError
from fishtail_design.variables import DesignSpace, symmetric_rocker_link
from fishtail_kinematics.engine import design


def _space(**changes: object) -> DesignSpace:
    settings = {
        "ring_radius_m": (0.05, 0.1), "crank_link_m": (0.05, 0.15), "tail_link_m": 0.15,
        "pivot_offset_m": (0.1, 0.2), "gear_ratio": (10.0, 50.0),
        "carrier_speed_rad_s": (5.0, 20.0),
    }  # fmt: skip
    arguments: dict[str, object] = {"symmetric_rocker": True}
    arguments.update(changes)
    return DesignSpace("oscillatory", settings, **arguments)  # type: ignore[arg-type]


def test_the_free_variables_are_the_columns_and_the_fixed_ones_are_filled_in():
    space = _space()
    assert space.names == ("ring_radius_m", "crank_link_m", "pivot_offset_m", "gear_ratio",
                           "carrier_speed_rad_s")  # fmt: skip
    rows = np.array([[0.08, 0.1, 0.15, 20.0, 7.0], [0.06, 0.12, 0.18, 40.0, 12.0]])
    designs = space.decode(rows)
    assert designs["tail_link_m"].tolist() == [0.15, 0.15]
    assert designs["carrier_speed_rad_s"].tolist() == [7.0, 12.0]
    assert space.encode({name: float(designs[name][1]) for name in space.names}) == pytest.approx(
        rows[1]
    )


def test_the_symmetric_rocker_is_the_engine_design_helper_s():
    radius, crank, offset = np.array([0.1, 0.07]), np.array([0.1, 0.12]), np.array([0.2, 0.15])
    batch = symmetric_rocker_link(radius, crank, offset)
    for index in range(2):
        expected = design.symmetric_rocker_link(radius[index], crank[index], offset[index])
        assert batch[index] == pytest.approx(expected, rel=1e-15)


def test_a_catalogue_ratio_is_chosen_by_a_floored_column_each_ratio_an_equal_share():
    settings = dict(_space().settings)
    del settings["gear_ratio"]
    space = DesignSpace("oscillatory", settings, True, (10.0, 30.0, 50.0), (0.8, 0.76, 0.7))
    assert space.names[-1] == "gear_index"
    assert (space.lower[-1], space.upper[-1]) == (0.0, 3.0)
    rows = np.tile(space.lower, (4, 1))
    rows[:, -1] = [0.0, 1.99, 2.5, 3.0]  # the upper bound itself is the last ratio
    designs = space.decode(rows)
    assert designs["gear_ratio"].tolist() == [10.0, 30.0, 50.0, 50.0]
    assert designs["gearbox_efficiency"].tolist() == [0.8, 0.76, 0.7, 0.7]


@pytest.mark.parametrize(
    ("settings", "message"),
    [
        ({"ring_radius_m": (0.1, 0.05)}, "ring_radius_m: bounds must be"),
        ({"ring_radius_m": (-0.1, 0.05)}, "ring_radius_m: bounds must be"),
        ({"fin_link_m": 0.1}, "fin_link_m is not a variable"),
    ],
)
def test_bad_settings_are_refused_with_the_variable_named(settings, message):
    base = dict(_space().settings)
    base.update(settings)
    with pytest.raises(ProblemFileError, match=message):
        DesignSpace("oscillatory", base, symmetric_rocker=True)


def test_a_missing_variable_is_named():
    base = dict(_space().settings)
    del base["tail_link_m"]
    with pytest.raises(ProblemFileError, match="tail_link_m is not set"):
        DesignSpace("oscillatory", base, symmetric_rocker=True)
