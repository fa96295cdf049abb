"""The continuation of mechanism 2's second loop over SW's angle, and the shift-limit search."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fishtail_kinematics.engine.arm_sweep import SWEEP_STEP_RAD, ArmSweep, last_working_shift
from fishtail_kinematics.engine.errors import AssemblyError


def quadratic_branch(angle: float, guess: float) -> float:
    """A made-up branch AS = 0.1 + angle^2 that ends (like a toggle) beyond 0.3 rad."""
    if angle > 0.3:
        raise AssemblyError(f"toggle pose at theta3 = {angle:.6f} rad")
    return 0.1 + angle * angle


def test_the_sweep_goes_only_as_far_as_asked_and_continues_from_where_it_stopped():
    calls = []

    def solve(angle, guess):
        calls.append((angle, guess))
        return quadratic_branch(angle, guess)

    sweep = ArmSweep(solve, 0.1)
    assert sweep.cover(-0.01, 0.02) is None
    low, high = sweep.reach()
    assert low == pytest.approx(-0.01) and high == pytest.approx(0.02)
    assert len(calls) == 20 + 40
    # Each pose is continued from its neighbour towards the straight pose.
    assert calls[1] == (pytest.approx(-2 * SWEEP_STEP_RAD), pytest.approx(0.1 + SWEEP_STEP_RAD**2))
    calls.clear()
    assert sweep.cover(-0.005, 0.03) is None
    assert len(calls) == 20  # only the new stretch, on the positive side


def test_where_the_branch_ends_the_reason_stays():
    sweep = ArmSweep(quadratic_branch, 0.1)
    reason = sweep.cover(-0.1, 0.5)
    assert reason is not None and "toggle" in reason
    assert sweep.reach()[1] == pytest.approx(0.3, abs=SWEEP_STEP_RAD)
    assert sweep.cover(0.0, 0.4) == reason
    assert sweep.cover(-0.2, 0.25) is None  # what lies inside still serves


def test_the_sweep_stops_at_half_a_turn():
    sweep = ArmSweep(lambda angle, guess: guess, 0.1, step_rad=0.01)
    reason = sweep.cover(-4.0, 0.0)
    assert reason is not None and "opposite" in reason
    assert sweep.reach()[0] == pytest.approx(-math.pi, abs=0.01)


def test_samples_keep_both_ends_and_thin_the_rest():
    sweep = ArmSweep(quadratic_branch, 0.1)
    sweep.cover(-0.2, 0.25)
    angles, sliders = sweep.samples(-0.15, 0.2, most=50)
    assert len(angles) <= 50
    assert angles[0] <= -0.15 - SWEEP_STEP_RAD and angles[-1] >= 0.2 + SWEEP_STEP_RAD
    assert np.all(np.diff(angles) > 0.0)
    np.testing.assert_allclose(sliders, 0.1 + angles**2, rtol=0, atol=1e-15)
    everything, _ = sweep.samples(-0.15, 0.2, most=10**6)
    assert len(everything) == round(0.35 / SWEEP_STEP_RAD) + 5


@pytest.mark.parametrize("boundary", [0.0123, -0.047, 0.09999, -0.0999999])
def test_the_last_working_shift_is_found_to_the_tolerance_on_the_working_side(boundary):
    limit = math.copysign(0.1, boundary)
    found = last_working_shift(lambda shift: abs(shift) < abs(boundary), limit, 64, 1e-9)
    assert abs(found) < abs(boundary) and abs(found - boundary) <= 1e-9
    assert last_working_shift(lambda shift: True, limit, 64, 1e-9) == limit
