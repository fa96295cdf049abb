"""drive_pose, mechanism 1's scalar formula, against the engine's array path."""

import math

import numpy as np
import pytest

from fishtail_kinematics.engine.geometry import OscillatoryGeometry, OscillatoryState
from fishtail_kinematics.engine.mechanisms import OscillatoryTail
from fishtail_kinematics.engine.oscillatory_tail import (
    DRIVE_POSE_FIELDS,
    drive_coefficients,
    drive_pose,
)

TAILS = [
    OscillatoryTail(OscillatoryGeometry()),
    OscillatoryTail(OscillatoryGeometry(0.05, 0.06, 0.16, 0.2, 0.15, phase_rad=0.4)),
    OscillatoryTail(OscillatoryGeometry(0.1, 0.15, 0.1, 0.15, 0.2)),  # theta2 not monotone
    OscillatoryTail(OscillatoryGeometry()).with_pivot_shift(0.02),  # fin angle != theta3
]


def _pose(tail: OscillatoryTail, phi: float, phi_dot: float) -> tuple[float, ...]:
    c = tail.constants
    carrier = phi + c.phase_rad
    coefficients = (float(value) for value in drive_coefficients(c))
    return drive_pose(math.cos(carrier), math.sin(carrier), phi_dot, *coefficients)


#: What the formula gives besides the state's fields: the tail link's direction, and the
#: arguments of asin and of theta1's atan2.
EXTRA = ("cos_fin", "sin_fin", "sin_beta", "cos_theta1", "sin_theta1")


def test_its_fields_are_the_states_and_the_arguments_of_its_inverse_functions():
    shared = [name for name in DRIVE_POSE_FIELDS if name in OscillatoryState._fields]
    assert shared == [name for name in DRIVE_POSE_FIELDS if name not in EXTRA]
    tail = TAILS[1]
    pose = dict(zip(DRIVE_POSE_FIELDS, _pose(tail, 0.8, 3.0), strict=True))
    alpha = math.atan2(tail.geometry.pivot_offset_m, pose["slider_position"])
    assert pose["theta2"] == alpha + math.asin(pose["sin_beta"])
    assert pose["theta1"] == math.atan2(pose["sin_theta1"], pose["cos_theta1"])
    assert math.hypot(pose["cos_theta1"], pose["sin_theta1"]) == pytest.approx(1.0, abs=1e-14)


@pytest.mark.parametrize("tail", TAILS, ids=["report", "phase", "non-monotone", "shifted"])
def test_the_formula_gives_the_array_paths_numbers(tail):
    angles = np.linspace(-3.0, 9.0, 301)
    state, cos_fin, sin_fin = tail.solve_array_with_tail_trig(angles, np.full(angles.size, 2.5))
    arrays = {**state._asdict(), "cos_fin": cos_fin, "sin_fin": sin_fin}
    for index, phi in enumerate(angles):
        pose = _pose(tail, float(phi), 2.5)
        for name, value in zip(DRIVE_POSE_FIELDS, pose, strict=True):
            if name not in arrays:
                continue
            # The same operations in the same order: equal but for numpy's and libm's last bits.
            assert value == pytest.approx(float(arrays[name][index]), rel=1e-14, abs=1e-15), name


def test_the_float_path_is_the_formula():
    tail = TAILS[3]
    state = tail.solve(1.3, -4.0)
    pose = _pose(tail, 1.3, -4.0)
    for name, value in zip(DRIVE_POSE_FIELDS, pose, strict=True):
        if name in OscillatoryState._fields:
            assert getattr(state, name) == value, name
    assert state.theta3_dot == state.fin_angle_dot == pose[DRIVE_POSE_FIELDS.index("theta2_dot")]
