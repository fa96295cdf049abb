"""SwimFollower: following carrier samples reproduces the library's run and its beat figures."""

import math
from typing import Any

import numpy as np
import pytest

from fishtail_kinematics.engine.errors import FishtailKinematicsError
from fishtail_kinematics.engine.geometry import OscillatoryGeometry
from fishtail_kinematics.engine.mechanisms import Tail, make_tail
from fishtail_plant.fish.figures import beat_means, tail_figures
from fishtail_plant.fish.fish import FishParameters
from fishtail_plant.fish.follower import SwimFollower
from fishtail_plant.fish.integrator import Trajectory, simulate
from fishtail_plant.fish.model import SwimModel
from fishtail_plant.fish.tail_drive import EngineTailDrive, constant_carrier_speed

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


@pytest.fixture(scope="module")
def fine_run(tail):
    """The library's run at 8 times the steps: the reference for the follower's 1 ms sub-steps.

    The fin plate's drag |w| w has a kink where w changes sign, which costs RK4 accuracy: at 32
    steps a beat r is 1e-6 off (7.6e-6 of it), where 1 ms sub-steps (785 a beat) are not.
    """
    drive = EngineTailDrive(tail, constant_carrier_speed(np.array([SPEED_RAD_S])))
    return simulate(SwimModel(FishParameters(), drive), 1, STEP_S / 8, 8 * STEPS_PER_BEAT * BEATS)


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


def test_irregular_samples_reproduce_simulate_to_integration_accuracy(tail, fine_run):
    """Jittered sample times with 1 ms sub-steps: the same fish to RK4's accuracy."""
    trajectory = fine_run
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


def test_the_beat_figures_do_not_depend_on_when_its_steps_are_figured(tail):
    """Figures settled every DEFERRED_STEPS sub-steps or at every sample: the same beats.

    A tail set again after every sample (the same tail) makes the follower figure the sub-steps
    so far at once; 1 ms sub-steps make beats of hundreds, settled in blocks otherwise, each
    step with its own interval's carrier.
    """
    times = np.arange(0.0, 2.5 * PERIOD_S, 0.005)
    # A carrier that speeds up: each interval has a speed of its own.
    angles = SPEED_RAD_S * times * (1.0 + 0.2 * times)
    blocks = SwimFollower(tail, FishParameters(), 0.001)
    each = SwimFollower(tail, FishParameters(), 0.001)
    for time_s, angle in zip(times, angles, strict=True):
        blocks.follow(round(time_s * 1e9), angle)
        each.follow(round(time_s * 1e9), angle)
        each.set_tail(tail)
    assert blocks.beats_completed == each.beats_completed == 3
    for ours, theirs in zip(blocks.take_beats(), each.take_beats(), strict=True):
        for field in ("mean_thrust_n", "mean_tail_power_w", "tip_excursion_m", "mean_speed_m_s"):
            assert getattr(ours, field) == pytest.approx(getattr(theirs, field), rel=1e-12)
    assert blocks.state == pytest.approx(each.state, rel=1e-12, abs=1e-15)


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


SAMPLE_NS = 5_000_000
#: The sample interval (k - 1, k] crossing the first beat boundary 2 pi at 8 rad/s and 5 ms.
CROSSING_SAMPLE = 158


def sample_angle(k: int) -> float:
    return SPEED_RAD_S * k * SAMPLE_NS * 1e-9


class CountingTail:
    """A tail that counts its solves and refuses the one numbered ``fail_at``."""

    def __init__(self, tail: Tail) -> None:
        """Wrap ``tail``; no solve fails until ``fail_at`` is set."""
        self.tail = tail
        self.calls = 0
        self.fail_at: int | None = None

    def solve(self, angle: Any, speed: Any) -> Any:
        """The tail's solve, or FishtailKinematicsError at call ``fail_at``."""
        self.calls += 1
        if self.calls == self.fail_at:
            raise FishtailKinematicsError("solver refused (test)")
        return self.tail.solve(angle, speed)


def counting_follower(tail: Tail, upto: int) -> tuple[SwimFollower, CountingTail]:
    follower = SwimFollower(tail, FishParameters(), 0.001)
    counting = CountingTail(tail)
    follower.model.drive.tail = counting  # type: ignore[attr-defined]
    for k in range(upto + 1):
        follower.follow(k * SAMPLE_NS, sample_angle(k))
    return follower, counting


def snapshot(follower: SwimFollower) -> dict[str, Any]:
    """Everything a follow may change, copied."""
    beat = follower._beat
    carrier = follower.carrier
    return {
        "state": follower.state.tolist(),
        "time_s": follower.time_s,
        "angle_rad": follower.angle_rad,
        "first_stamp_ns": follower.first_stamp_ns,
        "last_stamp_ns": follower._last_stamp_ns,
        "next_boundary_rad": follower._next_boundary_rad,
        "beat": None if beat is None else dict(vars(beat)),
        "beats_completed": follower.beats_completed,
        "finished": list(follower.finished),
        "sub_steps": follower.sub_steps,
        "restarts": follower.restarts,
        "carrier": (carrier.start_time_s, carrier.start_angle_rad, carrier.speed_rad_s),
    }


def test_an_engine_error_mid_interval_leaves_the_follower_as_it_was(tail):
    """The last solve of an interval that ends a beat fails: nothing of it is kept."""
    before = CROSSING_SAMPLE - 1
    reference, counting = counting_follower(tail, before)
    calls = counting.calls
    reference.follow(CROSSING_SAMPLE * SAMPLE_NS, sample_angle(CROSSING_SAMPLE))
    solves_in_interval = counting.calls - calls
    assert reference.beats_completed == 1  # the interval does end a beat

    follower, failing = counting_follower(tail, before)
    unchanged = snapshot(follower)
    # Fail as late as possible: the whole interval, its beat end included, was worked through.
    failing.fail_at = failing.calls + solves_in_interval
    with pytest.raises(FishtailKinematicsError):
        follower.follow(CROSSING_SAMPLE * SAMPLE_NS, sample_angle(CROSSING_SAMPLE))
    assert snapshot(follower) == unchanged

    # The next sample continues as if the refused one never came.
    never_saw_it, _ = counting_follower(tail, before)
    after = CROSSING_SAMPLE + 1
    for each in (follower, never_saw_it):
        each.follow(after * SAMPLE_NS, sample_angle(after))
    assert snapshot(follower) == snapshot(never_saw_it)
    assert follower.beats_completed == 1


def test_a_restart_with_stamps_and_angle_going_back_is_followed(tail):
    """A restarted driver after a pause: stamps and angle from 0 again, the fish swims on."""
    follower = SwimFollower(tail, FishParameters(), 0.001)
    for k in range(100):
        follower.follow(10**12 + k * SAMPLE_NS, sample_angle(k))
    state, time_s = follower.state.copy(), follower.time_s
    assert follower._beat is not None

    follower.restart(SAMPLE_NS, 0.0)
    assert follower.restarts == 1 and follower._beat is None
    assert follower.time_s == time_s  # the fish's time does not go back
    np.testing.assert_array_equal(follower.state, state)
    assert follower.take_beats() == []
    revolution = 2 * math.ceil(PERIOD_S / (SAMPLE_NS * 1e-9))
    for k in range(2, revolution):
        follower.follow(k * SAMPLE_NS, sample_angle(k - 1))
        # The carrier's speed is the new stream's, never the jump back from the old angle.
        assert follower.carrier.speed_rad_s == pytest.approx(SPEED_RAD_S, rel=1e-6)
    (beat,) = follower.take_beats()
    assert beat.duration_s == pytest.approx(PERIOD_S, rel=STAMP_TOLERANCE)
    assert beat.end_time_s > time_s
    assert follower.first_stamp_ns + round(beat.end_time_s * 1e9) < revolution * SAMPLE_NS
