"""Measuring the modulation a carrier achieved, and what the simulated motors achieve.

The measurement is checked on exact profiles and on a first-order lag, whose response theory
gives; then it measures the simulated DC motor under the firmware's loop, which a test holds to
the figures measured when this was written (docs/serial.md, 'Speed profiles').
"""

from __future__ import annotations

import doctest
import math

import numpy as np
import pytest

from fishtail_driver.parameters import DC_MOTOR_ENCODER, DRIVER_PARAMETERS, make_sim_motor
from fishtail_kinematics.engine.carrier_profile import CarrierSpeedProfile
from fishtail_testkit import modulation_fit
from fishtail_testkit.modulation_fit import (
    fit_revolutions,
    follow_simulated,
    measure_following,
    speeds_from_angles,
    wrap_angle,
)

ONE_HZ = 2.0 * math.pi  # the mean carrier speed of a 1 Hz beat [rad/s]


def sim_motor(**changes):
    """The simulated backend's motor at the driver's defaults with ``changes``."""
    values = {**{spec.name: spec.default for spec in DRIVER_PARAMETERS}, **changes}
    return make_sim_motor(values)


def test_doctests():
    result = doctest.testmod(modulation_fit)
    assert result.failed == 0 and result.attempted >= 5


@pytest.mark.parametrize("depth", [0.0, 0.2, 0.5, 0.9])
@pytest.mark.parametrize("phase", [-2.5, 0.0, 1.0, 3.0])
def test_an_exactly_followed_profile_measures_as_commanded(depth, phase):
    profile = CarrierSpeedProfile(3.0, depth, phase)
    times = np.arange(0.0, 4 * 2 * math.pi / 3.0 + 0.1, 0.004)
    angles, speeds, _ = profile.motion(start_angle_rad=0.3)(times)
    result = measure_following(times, angles, speeds, profile)
    assert len(result.revolutions) == 4
    assert result.depth == pytest.approx(depth, abs=1e-4)
    assert result.mean_speed_rad_s == pytest.approx(3.0, rel=1e-4)
    if depth > 0.0:
        assert result.phase_lag_rad == pytest.approx(0.0, abs=1e-3)
        assert result.depth_ratio == pytest.approx(1.0, abs=1e-3)


def test_a_later_peak_is_a_positive_lag_and_crossing_pi_wraps():
    commanded = CarrierSpeedProfile(4.0, 0.4, 3.0)
    angles = np.linspace(0.0, 6 * math.pi, 3000)
    times = np.cumsum(np.full(angles.size, 0.002))
    for lag in (0.3, -0.5, 1.2):
        speeds = 5.0 * (1.0 + 0.25 * np.cos(angles - 3.0 - lag))
        result = measure_following(times, angles, speeds, commanded)
        assert result.phase_lag_rad == pytest.approx(lag, abs=1e-3)
        assert wrap_angle(result.revolutions[0].peak_angle_rad) == pytest.approx(
            wrap_angle(3.0 + lag), abs=1e-3
        )
        assert result.depth == pytest.approx(0.25, abs=1e-3)
        assert result.phase_lag_spread_rad < 1e-6 and result.depth_spread < 1e-6


def test_the_fit_weighs_the_angle_not_the_time():
    """Samples crowd where the carrier is slow; the fit must not lean towards them."""
    profile = CarrierSpeedProfile(2.0, 0.8, 0.0)  # 9:1 between the fastest and slowest point
    dense_times = np.arange(0.0, 3 * math.pi, 0.001)
    angles, speeds, _ = profile.motion()(dense_times)
    # An extra harmonic, which time weighting would fold into the first one unevenly.
    speeds = speeds + 0.3 * np.cos(2.0 * angles)
    fits = fit_revolutions(dense_times, angles, speeds)
    assert fits[0].depth == pytest.approx(0.8, abs=0.01)


def test_incomplete_and_sparse_revolutions_are_left_out():
    profile = CarrierSpeedProfile(2.0, 0.5, 0.0)
    times = np.arange(0.0, 1.9 * 2 * math.pi / 2.0, 0.01)
    angles, speeds, _ = profile.motion()(times)
    assert len(fit_revolutions(times, angles, speeds)) == 1
    with pytest.raises(ValueError, match="no whole revolution"):
        measure_following(times[:200], angles[:200], speeds[:200], profile)
    sparse = slice(None, None, 30)  # fewer than 12 samples a revolution
    assert fit_revolutions(times[sparse], angles[sparse], speeds[sparse]) == []


def test_a_revolution_with_a_gap_is_left_out_and_counted():
    """A recorder that stalled for 60 degrees: the fit would guess across the gap."""
    profile = CarrierSpeedProfile(2.0, 0.5, 0.0)
    times = np.arange(0.0, 5.5 * 2 * math.pi / 2.0, 0.01)
    angles, speeds, _ = profile.motion()(times)
    stalled = (angles > 2 * 2 * math.pi + 1.0) & (angles < 2 * 2 * math.pi + 1.0 + math.pi / 3)
    kept = ~stalled
    fits = fit_revolutions(times[kept], angles[kept], speeds[kept])
    assert [fit.index for fit in fits] == [0, 1, 3, 4]
    result = measure_following(times[kept], angles[kept], speeds[kept], profile, 1)
    assert [fit.index for fit in result.revolutions] == [1, 3, 4] and result.left_out == 1
    assert result.depth == pytest.approx(0.5, abs=1e-3)


def test_speeds_from_angles_follow_the_modulation_without_delay():
    profile = CarrierSpeedProfile(4 * ONE_HZ, 0.5, 0.0)  # a 4 Hz beat
    times = np.arange(0.0, 1.0, 0.01)  # 100 samples a second
    angles, speeds, _ = profile.motion()(times)
    estimated = speeds_from_angles(times, angles)
    result = measure_following(times, angles, estimated, profile)
    assert result.depth_ratio == pytest.approx(0.99, abs=0.01)
    assert result.phase_lag_rad == pytest.approx(0.0, abs=0.01)


def test_a_first_order_lag_measures_as_theory_says():
    """Shallow modulation at 1 Hz on a 0.15 s lag: gain 1/sqrt(1 + (w tau)²), lag atan(w tau)."""
    profile = CarrierSpeedProfile(ONE_HZ, 0.1, 2.0)
    motor = sim_motor(sim_time_constant_sec=0.15)
    recording = follow_simulated(motor, profile, 1000.0, 8.0)
    result = measure_following(
        recording.times_s, recording.angles_rad, recording.speeds_rad_s, profile, skip_revolutions=2
    )
    w_tau = ONE_HZ * 0.15
    assert result.depth_ratio == pytest.approx(1.0 / math.hypot(1.0, w_tau), abs=0.01)
    # A sample's command waits for the next sample: half a millisecond's worth of angle later.
    assert 0.0 <= result.phase_lag_rad - math.atan(w_tau) < 0.01


def test_the_dc_motor_follows_depth_half_at_one_hertz():
    """Depth 0.5 at a 1 Hz beat, 200 samples a second (the node's default publish rate).

    The simulated DC motor at its defaults: a Pololu 37D 30:1 under the firmware's 30 Hz loop.
    Measured: depth 0.491, lag 0.566 rad (90 ms at 1 Hz), the same to 0.02 in every revolution.
    """
    profile = CarrierSpeedProfile(ONE_HZ, 0.5, 2.0)
    motor = sim_motor(motor_model="dc", **DC_MOTOR_ENCODER)
    recording = follow_simulated(motor, profile, 200.0, 8.0)
    result = measure_following(
        recording.times_s, recording.angles_rad, recording.speeds_rad_s, profile, skip_revolutions=2
    )
    assert len(result.revolutions) >= 5
    assert result.depth == pytest.approx(0.5, abs=0.03)
    assert result.phase_lag_rad == pytest.approx(0.57, abs=0.07)
    assert result.depth_spread < 0.03 and result.phase_lag_spread_rad < 0.05
    # The revolution takes 2 pi / Omega within 2 %: steering leaves the beat frequency alone.
    assert result.mean_speed_rad_s == pytest.approx(ONE_HZ, rel=0.02)
