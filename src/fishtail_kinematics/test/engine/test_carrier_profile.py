"""The carrier's speed profile: its closed-form motion against the law it integrates."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fishtail_kinematics.engine.carrier_profile import MAX_DEPTH, CarrierSpeedProfile
from fishtail_kinematics.engine.errors import CarrierProfileError, FishtailKinematicsError

DEPTHS = (0.0, 0.3, 0.75, MAX_DEPTH)


@pytest.mark.parametrize("depth", DEPTHS)
def test_a_revolution_lasts_two_pi_over_the_mean_speed_at_every_depth(depth):
    profile = CarrierSpeedProfile(mean_speed_rad_s=5.0, depth=depth, phase_rad=1.1)
    motion = profile.motion(start_time_s=0.7, start_angle_rad=0.4)
    period = 2 * math.pi / 5.0
    angles, _, _ = motion(np.array([0.7, 0.7 + period, 0.7 + 3 * period]))
    assert angles[0] == pytest.approx(0.4, abs=1e-12)
    assert angles[1] - angles[0] == pytest.approx(2 * math.pi, abs=1e-12)
    assert angles[2] - angles[0] == pytest.approx(6 * math.pi, abs=1e-12)


@pytest.mark.parametrize("depth", DEPTHS)
def test_the_motion_follows_the_speed_law_at_its_own_angle(depth):
    profile = CarrierSpeedProfile(mean_speed_rad_s=3.0, depth=depth, phase_rad=-2.0)
    times = np.linspace(0.0, 5.0, 20001)
    angles, speeds, accelerations = profile.motion(start_angle_rad=1.0)(times)
    law = np.array([profile.speed_at(float(angle)) for angle in angles])
    np.testing.assert_allclose(speeds, law, rtol=1e-12)
    # Derivatives against central differences of the closed form (step 2.5e-4 s).
    step = times[1] - times[0]
    np.testing.assert_allclose(
        (angles[2:] - angles[:-2]) / (2 * step), speeds[1:-1], rtol=0, atol=1e-5 * law.max()
    )
    np.testing.assert_allclose(
        (speeds[2:] - speeds[:-2]) / (2 * step), accelerations[1:-1], rtol=0,
        atol=1e-4 * max(1.0, np.abs(accelerations).max()),
    )  # fmt: skip
    assert np.all(np.diff(angles) > 0)


def test_fastest_and_slowest_points_are_a_half_revolution_apart():
    profile = CarrierSpeedProfile(mean_speed_rad_s=2.0, depth=0.5, phase_rad=0.3)
    assert profile.speed_at(0.3) == pytest.approx(profile.peak_speed_rad_s)
    assert profile.speed_at(0.3 + math.pi) == pytest.approx(profile.lowest_speed_rad_s)
    # Hand-derived: Omega (1 +- delta) / sqrt(1 - delta^2).
    assert profile.peak_speed_rad_s == pytest.approx(2.0 * 1.5 / math.sqrt(0.75))
    assert profile.lowest_speed_rad_s == pytest.approx(2.0 * 0.5 / math.sqrt(0.75))


def test_the_harmonic_mean_of_the_speed_over_the_angle_is_the_mean_speed():
    profile = CarrierSpeedProfile(mean_speed_rad_s=4.0, depth=0.8, phase_rad=0.0)
    angles = np.linspace(0.0, 2 * math.pi, 200001)[:-1]
    time_per_revolution = np.mean([1.0 / profile.speed_at(float(a)) for a in angles]) * 2 * math.pi
    assert time_per_revolution == pytest.approx(2 * math.pi / 4.0, rel=1e-9)


def test_mean_phase_inverts_angle_at_phase_over_many_turns():
    profile = CarrierSpeedProfile(mean_speed_rad_s=1.0, depth=0.9, phase_rad=2.5)
    angles = np.linspace(-20.0, 40.0, 10001)
    np.testing.assert_allclose(profile.angle_at_phase(profile.mean_phase(angles)), angles,
                               atol=1e-10)  # fmt: skip


def test_a_constant_profile_turns_uniformly():
    angle, speed, acceleration = CarrierSpeedProfile(2.0).motion(1.0, 0.5)(np.array([1.0, 2.0]))
    np.testing.assert_allclose(angle, [0.5, 2.5])
    np.testing.assert_allclose(speed, [2.0, 2.0])
    np.testing.assert_allclose(acceleration, [0.0, 0.0])


@pytest.mark.parametrize(
    ("arguments", "named"),
    [
        ((-1.0, 0.0, 0.0), "mean_speed_rad_s"),
        ((math.nan, 0.0, 0.0), "mean_speed_rad_s"),
        ((1.0, 0.95, 0.0), "depth"),
        ((1.0, -0.1, 0.0), "depth"),
        ((1.0, math.inf, 0.0), "depth"),
        ((1.0, 0.2, math.nan), "phase_rad"),
    ],
)
def test_a_bad_profile_is_refused_by_name(arguments, named):
    with pytest.raises(CarrierProfileError, match=named) as caught:
        CarrierSpeedProfile(*arguments)
    assert isinstance(caught.value, FishtailKinematicsError)
