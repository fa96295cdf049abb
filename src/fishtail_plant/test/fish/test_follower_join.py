"""SwimFollower joining a carrier that already turns: the fish it would be after that history."""

import math

import numpy as np
import pytest

from fishtail_kinematics.engine.geometry import OscillatoryGeometry
from fishtail_kinematics.engine.mechanisms import make_tail
from fishtail_plant.fish.fish import FishParameters
from fishtail_plant.fish.follower import JOIN_HISTORY_BEATS, JOIN_STEPS_PER_BEAT, SwimFollower
from fishtail_plant.fish.integrator import simulate
from fishtail_plant.fish.model import PSI, SURGE, SwimModel, X, Y
from fishtail_plant.fish.tail_drive import EngineTailDrive, constant_carrier_speed

SPEED_RAD_S = 8.0
STEP_S = 2.0 * math.pi / SPEED_RAD_S / JOIN_STEPS_PER_BEAT
TWO_PI = 2.0 * math.pi


@pytest.fixture(scope="module")
def tail():
    return make_tail(OscillatoryGeometry())


@pytest.fixture(scope="module")
def from_rest(tail):
    """The library's fish from rest at constant carrier speed, on the join's step grid."""
    drive = EngineTailDrive(tail, constant_carrier_speed(np.array([SPEED_RAD_S])))
    model = SwimModel(FishParameters(), drive)
    return simulate(model, 1, STEP_S, JOIN_STEPS_PER_BEAT * (JOIN_HISTORY_BEATS + 2))


def joined(tail, angle_rad, speed_rad_s=SPEED_RAD_S, max_speed_rad_s=20.0):
    follower = SwimFollower(tail, FishParameters(), 0.01, max_speed_rad_s=max_speed_rad_s)
    follower.follow(10**12, angle_rad, speed_rad_s)
    return follower


@pytest.mark.parametrize("steps", [1, 7, JOIN_STEPS_PER_BEAT, 5 * JOIN_STEPS_PER_BEAT + 11])
def test_a_join_is_the_fish_that_swam_since_angle_zero(tail, from_rest, steps):
    """Joining at the angle of step k of a constant-speed run: that run's body velocities."""
    follower = joined(tail, SPEED_RAD_S * steps * STEP_S)
    np.testing.assert_allclose(
        follower.state[0, SURGE:], from_rest.state[steps, 0, SURGE:], rtol=1e-6, atol=1e-9
    )
    assert not follower.state[0, [X, Y, PSI]].any(), "the pose starts at the origin"
    assert follower.time_s == 0.0 and follower.first_stamp_ns == 10**12


def test_a_long_history_is_the_periodic_state(tail, from_rest):
    """A carrier that turned for ages: the state repeats beat to beat, whatever the angle."""
    periodic = from_rest.state[-1, 0, SURGE:]  # phase 0, 102 beats from rest
    for beats in (JOIN_HISTORY_BEATS, 10**5, 10**8):
        follower = joined(tail, TWO_PI * beats)
        np.testing.assert_allclose(follower.state[0, SURGE:], periodic, rtol=1e-5, atol=1e-8)


@pytest.mark.parametrize(
    ("angle_rad", "speed_rad_s"),
    [(10.0, 0.0), (10.0, -3.0), (0.0, SPEED_RAD_S), (-5.0, SPEED_RAD_S), (10.0, 25.0)],
    ids=["at rest", "negative speed", "at angle 0", "negative angle", "beyond the top speed"],
)
def test_no_history_to_give_starts_from_rest(tail, angle_rad, speed_rad_s):
    """Stopped, no angle turned, or a speed the motor cannot turn: the fish starts at rest."""
    assert not joined(tail, angle_rad, speed_rad_s).state.any()


def test_later_samples_ignore_the_speed(tail):
    """Only the first sample's speed gives a history; later ones follow angles and stamps."""
    one, other = joined(tail, 0.0), joined(tail, 0.0)
    one.follow(10**12 + 5_000_000, 0.04, 8.0)
    other.follow(10**12 + 5_000_000, 0.04, 0.0)
    np.testing.assert_array_equal(one.state, other.state)


def test_warm_up_leaves_the_follower_as_it_was(tail):
    follower = SwimFollower(tail, FishParameters(), 0.01)
    follower.warm_up()
    assert not follower.started and not follower.state.any() and follower.sub_steps == 0
    follower.follow(0, 0.0)
    follower.follow(5_000_000, 0.04)
    fresh = SwimFollower(tail, FishParameters(), 0.01)
    fresh.follow(0, 0.0)
    fresh.follow(5_000_000, 0.04)
    np.testing.assert_array_equal(follower.state, fresh.state)
