"""SwimFollower on implausible or irregular input: jumps held, work bounded, sampling irrelevant.

A jump beyond what the motor can turn since the last sample is not integrated (the follower is
left as it was and the next good sample continues); an interval whose sub-steps would exceed the
cap is a gap; and the fish's state is a function of the (stamp, angle) samples, whatever their
spacing, jitter or losses, to the integrator's accuracy.
"""

import math

import numpy as np
import pytest

from fishtail_kinematics.engine.geometry import OscillatoryGeometry
from fishtail_kinematics.engine.mechanisms import make_tail
from fishtail_plant.fish.fish import FishParameters
from fishtail_plant.fish.follower import CarrierJumpError, SwimFollower

SPEED_RAD_S = 8.0
SAMPLE_NS = 5_000_000
#: The simulator node's default sub-step.
MAX_STEP_S = 0.01

#: Odometry at equal stamps, any sampling of one carrier: RK4's error at 10 ms sub-steps over
#: 10 s (measured at most 8e-8 m of the 2 m swum, against 1 ms samples), with a margin of 10.
SAMPLING_TOLERANCE_M = 1e-6


@pytest.fixture(scope="module")
def tail():
    return make_tail(OscillatoryGeometry())


def angle_at(stamp_ns: int) -> float:
    return SPEED_RAD_S * stamp_ns * 1e-9


def swimming(tail, samples: int, **options) -> SwimFollower:
    """A follower that has followed ``samples`` samples at 8 rad/s, every 5 ms."""
    follower = SwimFollower(tail, FishParameters(), MAX_STEP_S, **options)
    for k in range(samples):
        follower.follow(k * SAMPLE_NS, angle_at(k * SAMPLE_NS))
    return follower


def snapshot(follower: SwimFollower) -> tuple:
    return (
        follower.state.tolist(), follower.time_s, follower.angle_rad, follower.last_stamp_ns,
        follower.sub_steps, follower.restarts, follower.beats_completed,
    )  # fmt: skip


@pytest.mark.parametrize(("jump_rad", "after_ns"), [(10.0, 100_000), (10.0, SAMPLE_NS),
                                                   (1e3, SAMPLE_NS), (1e6, SAMPLE_NS)])  # fmt: skip
def test_a_jump_is_not_integrated_and_the_next_good_sample_continues(tail, jump_rad, after_ns):
    """10 rad 0.1 ms after a sample (was 1e112 m/s), 1e3 and 1e6 rad (was minutes of CPU)."""
    follower = swimming(tail, 200)
    unchanged = snapshot(follower)
    last_ns = follower.last_stamp_ns
    with pytest.raises(CarrierJumpError) as raised:
        follower.follow(last_ns + after_ns, angle_at(last_ns) + jump_rad)
    assert raised.value.advance_rad == pytest.approx(jump_rad)
    assert snapshot(follower) == unchanged  # held: not a sub-step spent
    never_saw_it = swimming(tail, 200)
    for each in (follower, never_saw_it):
        each.follow(last_ns + SAMPLE_NS, angle_at(last_ns + SAMPLE_NS))
    assert snapshot(follower) == snapshot(never_saw_it)
    assert np.isfinite(follower.state).all()
    assert follower.sub_steps - unchanged[4] == 1


def test_a_one_sample_spike_changes_nothing(tail):
    """A 1000 rad spike for one sample: no speed from it, no beats from it (was 16.5 m/s)."""
    clean = swimming(tail, 400)
    spiked = swimming(tail, 200)
    with pytest.raises(CarrierJumpError):
        spiked.follow(200 * SAMPLE_NS, angle_at(200 * SAMPLE_NS) + 1e3)
    for k in range(201, 400):
        spiked.follow(k * SAMPLE_NS, angle_at(k * SAMPLE_NS))
    # The spiked run lost one sample (one 10 ms sub-step for two of 5 ms): RK4's accuracy.
    np.testing.assert_allclose(spiked.state, clean.state, rtol=0, atol=SAMPLING_TOLERANCE_M)
    assert spiked.beats_completed == clean.beats_completed


@pytest.mark.parametrize("jump_rad", [1e3, 1e6, 1e9])
def test_without_a_speed_limit_the_work_per_sample_is_still_capped(tail, jump_rad):
    """No limit: a jump needing more sub-steps than the cap is a gap, zero sub-steps spent."""
    follower = swimming(tail, 200, max_speed_rad_s=math.inf)
    steps, last_ns = follower.sub_steps, follower.last_stamp_ns
    follower.follow(last_ns + SAMPLE_NS, angle_at(last_ns) + jump_rad)
    assert follower.sub_steps == steps and follower.restarts == 1
    assert follower.beats_completed == swimming(tail, 200).beats_completed


def test_sub_steps_per_sample_never_exceed_the_cap(tail):
    """Any accepted sample: its sub-steps (beat boundaries included) stay within the cap."""
    rng = np.random.default_rng(3)
    follower = SwimFollower(tail, FishParameters(), MAX_STEP_S, max_interval_s=2.0,
                            max_sub_steps=100)  # fmt: skip
    stamp_ns, angle = 0, 0.0
    follower.follow(stamp_ns, angle)
    for _ in range(300):
        stamp_ns += int(rng.choice([1e3, 1e5, 5e6, 1e8, 1.5e9]))
        elapsed = (stamp_ns - follower.last_stamp_ns) * 1e-9
        angle += rng.uniform(0.0, 1.4 * 20.0 * elapsed)
        before = follower.sub_steps
        follower.follow(stamp_ns, angle)
        assert follower.sub_steps - before <= 100
        assert np.isfinite(follower.state).all()
        # Plausible input never drives the fish beyond a few m/s (the steady speed is 0.3).
        assert np.hypot(*follower.state[0, 3:5]) < 5.0


def follow_samples(tail, stamps_ns) -> dict[int, np.ndarray]:
    """The fish's state after each sample of the 8 rad/s carrier at ``stamps_ns``."""
    follower = SwimFollower(tail, FishParameters(), MAX_STEP_S)
    states = {}
    for stamp_ns in stamps_ns:
        follower.follow(int(stamp_ns), angle_at(int(stamp_ns)))
        states[int(stamp_ns)] = follower.state[0].copy()
    return states


def test_the_fish_depends_on_the_samples_not_their_spacing_or_losses(tail):
    """One carrier, sampled regularly, jittered, with 30 % dropped and bunched: same odometry."""
    rng = np.random.default_rng(8)
    end_ns = 10_000_000_000
    regular = np.arange(0, end_ns + 1, SAMPLE_NS)
    jitter = regular[1:-1] + rng.integers(-2_000_000, 2_000_000, regular.size - 2)
    jittered = np.unique(np.concatenate(([0], jitter, regular[::100], [end_ns])))
    dropped = regular[(rng.random(regular.size) > 0.3) | (regular % 500_000_000 == 0)]
    bunched = np.unique(np.concatenate((regular[::100], rng.integers(0, end_ns, 300))))
    reference = follow_samples(tail, np.arange(0, end_ns + 1, 1_000_000))
    distance = float(np.hypot(*reference[end_ns][:2]))
    assert distance > 1.0
    for stamps in (regular, jittered, dropped, bunched):
        states = follow_samples(tail, stamps)
        for stamp_ns in range(0, end_ns + 1, 500_000_000):
            np.testing.assert_allclose(states[stamp_ns], reference[stamp_ns], rtol=0,
                                       atol=SAMPLING_TOLERANCE_M)  # fmt: skip


@pytest.mark.parametrize("apart_ns", [1, 1_000, 100_000])
def test_a_sample_microseconds_after_another_never_turns_the_carrier_beyond_the_margin(
    tail, apart_ns
):
    """Three encoder counts ahead 1 ns after a sample (3e3 m/s before): held, the next taken."""
    follower = swimming(tail, 200)
    clean = swimming(tail, 400)
    for k in range(200, 400):
        stamp_ns = k * SAMPLE_NS
        if k % 10 == 0:
            early_ns = follower.last_stamp_ns + apart_ns
            # 0.0099 rad in at most 0.1 ms is beyond 30 rad/s: held, not integrated.
            assert not follower.follow(early_ns, angle_at(early_ns) + 0.0099)
        assert follower.follow(stamp_ns, angle_at(stamp_ns))
        assert abs(follower.carrier.speed_rad_s) <= 1.5 * 20.0
    assert np.isfinite(follower.state).all()
    np.testing.assert_array_equal(follower.state, clean.state)  # held samples leave no trace
