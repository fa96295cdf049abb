"""SwimFollower: following carrier samples reproduces the library's run and its beat figures."""

import math

import numpy as np
import pytest

from fishtail_kinematics.engine.geometry import OscillatoryGeometry
from fishtail_kinematics.engine.mechanisms import make_tail
from fishtail_swim.dynamics.figures import beat_means, tail_figures
from fishtail_swim.dynamics.fish import FishParameters
from fishtail_swim.dynamics.integrator import Trajectory, simulate
from fishtail_swim.dynamics.model import SwimModel
from fishtail_swim.dynamics.tail_drive import EngineTailDrive, constant_carrier_speed
from fishtail_swim.follower import SwimFollower

SPEED_RAD_S = 8.0
PERIOD_S = 2.0 * math.pi / SPEED_RAD_S
STEPS_PER_BEAT = 32
STEP_S = PERIOD_S / STEPS_PER_BEAT
BEATS = 3
#: Samples are stamped in whole nanoseconds: times and angles agree with the library's to ~1e-9.
STAMP_TOLERANCE = 1e-7


@pytest.fixture(scope="module")
def tail():
    return make_tail(OscillatoryGeometry())


@pytest.fixture(scope="module")
def library_run(tail):
    drive = EngineTailDrive(tail, constant_carrier_speed(np.array([SPEED_RAD_S])))
    model = SwimModel(FishParameters(), drive)
    return model, simulate(model, 1, STEP_S, STEPS_PER_BEAT * BEATS)


def follow_constant_speed(tail, sample_times_s, max_step_s):
    follower = SwimFollower(tail, FishParameters(), max_step_s)
    for time_s in sample_times_s:
        follower.follow(round(time_s * 1e9), SPEED_RAD_S * time_s)
    return follower


@pytest.mark.parametrize("steps_per_sample", [1, 4])
def test_constant_speed_reproduces_simulate_and_its_figures(tail, library_run, steps_per_sample):
    """Samples every 1 or 4 library steps, sub-step = the library's: same grid, same numbers."""
    model, trajectory = library_run
    samples = np.arange(0, STEPS_PER_BEAT * BEATS + 1, steps_per_sample) * STEP_S
    follower = follow_constant_speed(tail, samples, STEP_S)
    assert follower.sub_steps == STEPS_PER_BEAT * BEATS
    np.testing.assert_allclose(follower.state, trajectory.state[-1], rtol=1e-6, atol=1e-9)
    beats = follower.take_beats()
    assert [beat.beat_index for beat in beats] == list(range(BEATS))
    assert follower.take_beats() == []
    for beat in beats:
        end = (beat.beat_index + 1) * STEPS_PER_BEAT
        upto = Trajectory(trajectory.time_s[: end + 1], trajectory.state[: end + 1])
        means = beat_means(upto, PERIOD_S, 1)
        figures = tail_figures(model, upto, PERIOD_S, 1)
        expected = {
            "duration_s": PERIOD_S,
            "mean_speed_m_s": means.mean_speed_m_s[0],
            "heading_change_rad": means.heading_change_per_beat_rad[0],
            "turning_radius_m": means.turning_radius_m[0],
            "mean_thrust_n": figures.mean_thrust_n[0],
            "mean_tail_power_w": figures.tail_power_w[0],
            "froude_efficiency": figures.froude_efficiency[0],
            "tip_excursion_m": figures.tip_excursion_m[0],
            "strouhal_number": figures.strouhal_number[0],
        }
        for name, value in expected.items():
            assert getattr(beat, name) == pytest.approx(value, rel=1e-5), name
        assert beat.body_lengths_per_s == pytest.approx(beat.mean_speed_m_s / 0.5)


def test_irregular_samples_reproduce_simulate_to_integration_accuracy(tail, library_run):
    """Jittered sample times with 1 ms sub-steps: the same fish to RK4's accuracy."""
    _, trajectory = library_run
    end_s = trajectory.time_s[-1]
    rng = np.random.default_rng(1)
    inner = np.sort(rng.uniform(0.0, end_s, 400))
    follower = follow_constant_speed(tail, [0.0, *inner, end_s], 0.001)
    assert follower.beats_completed == BEATS
    final = trajectory.state[-1, 0]
    got = follower.state[0]
    # Positions and speeds against their scale (the distance swum, the peak speed).
    assert abs(got[0] - final[0]) < 1e-5 * abs(final[0])
    np.testing.assert_allclose(got[1:], final[1:], atol=1e-5 * abs(final[0]))


def test_idle_carrier_starts_no_beat_and_the_fish_stays_at_rest(tail):
    follower = SwimFollower(tail, FishParameters(), 0.001)
    for k in range(50):
        follower.follow(k * 5_000_000, 0.0)
    assert follower.beats_completed == 0 and follower._beat is None
    np.testing.assert_array_equal(follower.state, np.zeros((1, 6)))
    # Moving off a boundary starts a beat at once; one revolution later it ends.
    start_ns = 49 * 5_000_000  # the last idle sample
    for k in range(1, 200):
        follower.follow(start_ns + k * 5_000_000, SPEED_RAD_S * k * 0.005)
    (beat,) = follower.take_beats()
    assert beat.duration_s == pytest.approx(PERIOD_S, rel=1e-9)
    assert beat.end_time_s == pytest.approx(0.245 + PERIOD_S, rel=1e-9)


def test_a_first_sample_off_a_boundary_waits_for_the_next(tail):
    follower = follow_constant_speed(tail, np.arange(1, 2 * STEPS_PER_BEAT + 1) * STEP_S, STEP_S)
    # From phi = 8 rad/s x STEP_S to 2 revolutions: only the second revolution is whole.
    (beat,) = follower.take_beats()
    assert beat.beat_index == 0
    assert beat.duration_s == pytest.approx(PERIOD_S, rel=STAMP_TOLERANCE)


def test_a_gap_longer_than_max_interval_restarts_and_abandons_the_beat(tail):
    follower = SwimFollower(tail, FishParameters(), 0.001, max_interval_s=0.5)
    for k in range(100):
        follower.follow(k * 5_000_000, SPEED_RAD_S * k * 0.005)
    state = follower.state.copy()
    follower.follow(99 * 5_000_000 + 2_000_000_000, SPEED_RAD_S * 2.5)
    assert follower.restarts == 1 and follower._beat is None
    np.testing.assert_array_equal(follower.state, state)
    assert follower.take_beats() == []


def test_refuses_what_the_node_must_drop_first(tail):
    follower = SwimFollower(tail, FishParameters(), 0.001)
    follower.follow(1_000, 0.0)
    with pytest.raises(ValueError, match="not after"):
        follower.follow(1_000, 0.1)
    with pytest.raises(ValueError, match="not finite"):
        follower.follow(2_000, math.nan)
    with pytest.raises(ValueError, match="max_step_s"):
        SwimFollower(tail, FishParameters(), 0.0)
