"""Tests of the geometry parameters and their validation."""

from __future__ import annotations

import dataclasses
import math

import pytest

from fishtail_kinematics.engine.errors import ParameterError
from fishtail_kinematics.engine.geometry import (
    GEOMETRY_PARAMETERS,
    OscillatoryGeometry,
    UndulatoryGeometry,
)
from fishtail_kinematics.engine.parameters import (
    changes_text,
    check_parameter,
    geometry_changes,
    geometry_from_parameters,
    geometry_parameters_in,
    parameters_of,
)

# The spec's values (the report's, RS the exact symmetric rocker, SU = SW/2).
SPEC_DEFAULTS = {
    "ring_radius_m": 0.1, "crank_link_m": 0.1, "rocker_link_m": 0.233926, "pivot_offset_m": 0.2,
    "phase_rad": 0.0, "tail_link_m": 0.15, "swing_arm_m": 0.16, "slotted_link_m": 0.24,
    "fin_link_m": 0.2, "fin_joint_offset_m": 0.06, "pin_offset_m": 0.08,
}  # fmt: skip


def test_defaults_are_the_dataclass_defaults():
    """No values: the dataclass defaults, which are the spec's values."""
    assert geometry_from_parameters({}) == OscillatoryGeometry()
    assert geometry_from_parameters({"mechanism": "undulatory"}) == UndulatoryGeometry()
    for spec in GEOMETRY_PARAMETERS:
        assert spec.default == pytest.approx(SPEC_DEFAULTS[spec.name], abs=5e-7), spec.name
        for geometry in (OscillatoryGeometry(), UndulatoryGeometry()):
            if spec.name in {f.name for f in dataclasses.fields(geometry)}:
                assert getattr(geometry, spec.name) == spec.default, spec.name
    assert {spec.name for spec in GEOMETRY_PARAMETERS} == set(SPEC_DEFAULTS)


def test_mechanism_switch():
    """The mechanism picks the dataclass; the other mechanism's names are accepted and ignored."""
    values = {"tail_link_m": 0.3, "swing_arm_m": 0.2, "pivot_offset_m": 0.18}
    oscillatory = geometry_from_parameters(values)
    assert type(oscillatory) is OscillatoryGeometry
    assert (oscillatory.tail_link_m, oscillatory.pivot_offset_m) == (0.3, 0.18)
    undulatory = geometry_from_parameters({**values, "mechanism": "undulatory"})
    assert type(undulatory) is UndulatoryGeometry
    assert (undulatory.swing_arm_m, undulatory.pivot_offset_m) == (0.2, 0.18)
    assert type(geometry_from_parameters({"mechanism": "oscillatory"})) is OscillatoryGeometry


@pytest.mark.parametrize("mechanism", ["wavy", "", None, 1, "Oscillatory"])
def test_unknown_mechanism(mechanism):
    """An unknown mechanism raises ParameterError naming the parameter."""
    with pytest.raises(ParameterError, match="mechanism"):
        geometry_from_parameters({"mechanism": mechanism})


def test_integers_are_numbers():
    """Integer values are accepted as floats."""
    geometry = geometry_from_parameters({"ring_radius_m": 1, "phase_rad": -3})
    assert geometry.ring_radius_m == 1.0 and isinstance(geometry.ring_radius_m, float)
    assert geometry.phase_rad == -3.0


@pytest.mark.parametrize("value", ["0.1", None, [0.1], {"x": 0.1}, True, False, b"0.1"])
@pytest.mark.parametrize("name", ["ring_radius_m", "pin_offset_m", "phase_rad"])
def test_wrong_types(name, value):
    """Non-numbers (and booleans) raise ParameterError naming the parameter."""
    with pytest.raises(ParameterError, match=name):
        geometry_from_parameters({name: value})
    with pytest.raises(ParameterError, match=name):
        check_parameter(name, value)


@pytest.mark.parametrize(
    ("name", "value"),
    [("ring_radius_m", math.nan), ("ring_radius_m", math.inf), ("ring_radius_m", 0.0),
     ("crank_link_m", -0.1), ("rocker_link_m", 5e-5), ("tail_link_m", 10.5),
     ("swing_arm_m", -math.inf), ("phase_rad", 3.2), ("phase_rad", -3.2), ("phase_rad", math.nan)],
)  # fmt: skip
def test_out_of_range(name, value):
    """NaN, infinities and values outside the documented range raise, naming the parameter."""
    with pytest.raises(ParameterError, match=name):
        geometry_from_parameters({name: value})


@pytest.mark.parametrize(
    ("name", "value"),
    [("ring_radius_m", 1e-4), ("ring_radius_m", 10.0), ("phase_rad", math.pi),
     ("phase_rad", -math.pi)],
)  # fmt: skip
def test_range_ends_are_inclusive(name, value):
    """The documented ends themselves are accepted."""
    assert check_parameter(name, value) == value


def test_unknown_name():
    """An unknown name raises ParameterError naming it."""
    with pytest.raises(ParameterError, match="ring_radius"):
        geometry_from_parameters({"ring_radius": 0.1})
    with pytest.raises(ParameterError, match="motor_speed"):
        check_parameter("motor_speed", 1.0)


@pytest.mark.parametrize(
    "geometry",
    [
        OscillatoryGeometry(pivot_offset_m=0.25),
        UndulatoryGeometry(pin_offset_m=0.05, phase_rad=1.0),
    ],
)
def test_parameters_round_trip(geometry):
    """parameters_of inverts geometry_from_parameters."""
    assert geometry_from_parameters(parameters_of(geometry)) == geometry


def test_geometry_parameters_in():
    """Only the mechanism and the geometry names are kept."""
    values = {"mechanism": "undulatory", "pin_offset_m": 0.05, "serial_port": "/dev/ttyUSB0"}
    assert geometry_parameters_in(values) == {"mechanism": "undulatory", "pin_offset_m": 0.05}


def test_geometry_changes_are_only_what_differs():
    """Setting the same values again is no change; other parameters are not geometry."""
    current = {"mechanism": "oscillatory", "pivot_offset_m": 0.2, "phase_rad": 0.0}
    assert geometry_changes(current, dict(current)) == {}
    assert geometry_changes(current, {"markers_rate_hz": 10.0, "frame_id": "x"}) == {}
    changes = geometry_changes(current, {**current, "phase_rad": 0.3})
    assert changes == {"phase_rad": (0.0, 0.3)}
    assert changes_text(changes) == "phase_rad 0.0 -> 0.3"
    assert geometry_changes(current, {"mechanism": "undulatory"}) == {
        "mechanism": ("oscillatory", "undulatory")
    }
