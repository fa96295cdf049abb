"""The pilot flying the simulated fish (pure closed loop, no ROS): speed steps, turns, goals.

The bounds are the behaviour the pilot documents (docs/steering.md): a speed step up settles
within 10 % of the command in 4 beats, a step down in 15 (the fish can only glide down: drag is
its one brake); a positive yaw-rate command turns the fish to the left, at the commanded rate
once settled; a goal 3 m away, ahead, aside or behind, is reached within 0.2 m in the stated
time; the 2 m square is flown round without a loop within 1.3 times its documented time; pivot
steering refuses the goals it cannot turn to and reaches one it can.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest

from fishtail_pilot.pilot import GOAL_TOLERANCE, Pilot, PilotSettings
from fishtail_pilot.route import GoalRoute, square_route
from fishtail_pilot.steering import steering_from_values
from fishtail_plant.values import fish_from_values, tail_from_values
from fishtail_testkit.closed_loop import LoopRun, fly, follow
from fishtail_testkit.steering_doc import MECHANISMS, documented_square_seconds

#: Each closed-loop flight takes 2-5 s (make check leaves them to make test).
pytestmark = pytest.mark.slow

SAMPLE_RATE_HZ = 200.0
SQUARE_SIDE_M = 2.0


@functools.cache
def setup(mechanism: str, steering: str = "modulation"):
    tail = tail_from_values({"mechanism": mechanism})
    fish = fish_from_values({})
    means, speed_per_beat_m = steering_from_values({"steering": steering}, tail, fish)
    return tail, fish, means, speed_per_beat_m


def run(mechanism: str, duration_s: float, script, steering: str = "modulation") -> LoopRun:
    tail, fish, means, speed_per_beat_m = setup(mechanism, steering)
    settings = PilotSettings(speed_per_beat_m)
    pilot = Pilot(settings, means)
    # The motor lags as much as the pilot assumes (its default, the DC gear motor's).
    return fly(
        pilot, tail, fish, duration_s, script, SAMPLE_RATE_HZ, motor_lag_s=settings.motor_lag_s
    )


def settling_beats(loop: LoopRun, start_s: float, target_m_s: float, speed_per_beat_m: float):
    """Beats after ``start_s`` until the beat-mean speed stays within 10 % of the target."""
    after = loop.mean_speed_m_s[int(start_s * SAMPLE_RATE_HZ) :]
    outside = np.flatnonzero(np.abs(after - target_m_s) > 0.1 * target_m_s)
    settled_s = 0.0 if outside.size == 0 else (outside[-1] + 1) / SAMPLE_RATE_HZ
    return settled_s * target_m_s / speed_per_beat_m


@pytest.mark.parametrize("mechanism", MECHANISMS)
@pytest.mark.parametrize(
    ("before", "after", "beats"), [(0.0, 0.3, 4), (0.3, 0.5, 4), (0.5, 0.2, 15)]
)
def test_a_speed_step_settles_within_ten_percent_in_the_stated_beats(
    mechanism, before, after, beats
):
    def script(time_s, pilot):
        if time_s == 0.0:
            pilot.set_velocity(before, 0.0)
        elif abs(time_s - 20.0) < 1e-9:
            pilot.set_velocity(after, 0.0)

    loop = run(mechanism, 50.0, script)
    assert settling_beats(loop, 20.0, after, setup(mechanism)[3]) <= beats
    # The fish holds the speed, not just passes through it.
    assert loop.mean_speed_m_s[-1] == pytest.approx(after, rel=0.1)


@pytest.mark.parametrize("mechanism", MECHANISMS)
@pytest.mark.parametrize("yaw_rate", [0.15, -0.15])
def test_a_yaw_rate_command_turns_the_fish_that_way_at_that_rate(mechanism, yaw_rate):
    loop = run(mechanism, 40.0, lambda t, p: p.set_velocity(0.3, yaw_rate) if t == 0.0 else None)
    # REP 103: a positive yaw rate turns counter-clockwise (left), the heading grows.
    start = int(20.0 * SAMPLE_RATE_HZ)
    turned = loop.mean_heading_rad[-1] - loop.mean_heading_rad[start]
    assert turned / 20.0 == pytest.approx(yaw_rate, rel=0.05)
    assert loop.mean_speed_m_s[-1] == pytest.approx(0.3, rel=0.1)


def time_to_reach(loop: LoopRun, goal: tuple[float, float], within_m: float) -> float:
    distance = np.hypot(loop.x_m - goal[0], loop.y_m - goal[1])
    inside = np.flatnonzero(distance <= within_m)
    return math.inf if inside.size == 0 else float(loop.time_s[inside[0]])


@pytest.mark.parametrize(
    ("mechanism", "goal", "seconds"),
    [
        ("oscillatory", (3.0, 0.0), 15.0),
        ("oscillatory", (0.0, 3.0), 30.0),
        ("undulatory", (3.0, 0.0), 15.0),
        ("undulatory", (0.0, 3.0), 30.0),
        ("oscillatory", (-3.0, 0.0), 40.0),
        ("undulatory", (-3.0, 0.0), 40.0),
    ],
)
def test_a_goal_three_metres_away_is_reached_within_twenty_centimetres(mechanism, goal, seconds):
    loop = run(mechanism, seconds + 1.0, lambda t, p: p.set_goal(*goal) if t == 0.0 else None)
    reached_s = time_to_reach(loop, goal, 0.2)
    assert reached_s <= seconds
    # Once there the carrier stops: the fish glides on, the motor does not run on.
    after = loop.carrier_mean_speed_rad_s[int(reached_s * SAMPLE_RATE_HZ) + 1 :]
    assert np.all(after == 0.0)


@pytest.mark.parametrize("mechanism", MECHANISMS)
def test_the_pivot_actuator_turns_the_fish_left_for_a_positive_yaw_rate(mechanism):
    # The pivot's authority is one-sided (docs/steering.md): leftwards up to about 0.07 rad a
    # beat for mechanism 1, 0.04 for mechanism 2; a quarter of that is asked here.
    yaw_rate = 0.01
    loop = run(
        mechanism, 60.0, lambda t, p: p.set_velocity(0.3, yaw_rate) if t == 0.0 else None, "pivot"
    )
    start = int(30.0 * SAMPLE_RATE_HZ)
    turned = loop.mean_heading_rad[-1] - loop.mean_heading_rad[start]
    assert turned / 30.0 == pytest.approx(yaw_rate, rel=0.1)
    assert np.all(loop.modulation_depth == 0.0)
    # The actuator moved S forwards (a negative shift turns these tails left).
    assert loop.pivot_shift_m[-1] < 0.0


def distance_to_square_m(x_m, y_m, side_m: float):
    """Each point's distance to the nearest side of the square (0, 0)-(side, side)."""
    corners = [(0.0, 0.0), (side_m, 0.0), (side_m, side_m), (0.0, side_m), (0.0, 0.0)]
    nearest = np.full(np.shape(x_m), np.inf)
    for (ax, ay), (bx, by) in zip(corners[:-1], corners[1:], strict=True):
        along = np.clip(((x_m - ax) * (bx - ax) + (y_m - ay) * (by - ay)) / side_m**2, 0.0, 1.0)
        gap = np.hypot(x_m - (ax + along * (bx - ax)), y_m - (ay + along * (by - ay)))
        nearest = np.minimum(nearest, gap)
    return nearest


def tightest_radius_m(mechanism: str) -> float:
    """The tightest circle the modulation turns the fish in, either way (the steering table's)."""
    means = setup(mechanism)[2]
    return min(
        abs(means.turning_radius_at(means.input_for(end))) for end in means.yaw_per_beat_range_rad
    )


@pytest.mark.parametrize("mechanism", MECHANISMS)
def test_the_square_is_flown_round_without_a_loop_in_its_documented_time(mechanism):
    tolerance = float(GOAL_TOLERANCE.default)
    route = GoalRoute(square_route(SQUARE_SIDE_M), tolerance)
    fly_route = follow(route)
    finished_s: list[float] = []

    def script(time_s, pilot):
        fly_route(time_s, pilot)
        if route.finished and not finished_s:
            finished_s.append(time_s)

    allowed_s = 1.3 * documented_square_seconds()[mechanism]
    loop = run(mechanism, allowed_s, script)
    assert finished_s, f"the square not finished in {allowed_s:.1f} s"
    flown = loop.time_s <= finished_s[0]
    # Round a square, each corner the short way, the heading turns 4 x 90 degrees in all; a loop
    # adds a whole turn. Halfway between: a loop-free route with some hunting passes.
    turned = np.sum(np.abs(np.diff(loop.mean_heading_rad[flown])))
    assert math.degrees(turned) < 360.0 + 180.0
    # A corner whose next corner lies inside the tightest circle is passed straight until that
    # corner is on the circle (at most a radius on), then turned round on it (another radius
    # out): the fish stays within the circle's diameter, plus the tolerance, of the sides.
    outside = distance_to_square_m(loop.x_m[flown], loop.y_m[flown], SQUARE_SIDE_M)
    assert np.max(outside) <= 2.0 * tightest_radius_m(mechanism) + tolerance


def flight_with_refusals(mechanism: str, goal, duration_s: float):
    """Pivot steering to ``goal`` set at the start: the run and the (time, reason) refusals."""
    refusals: list[tuple[float, str]] = []

    def script(time_s, pilot):
        if time_s == 0.0:
            reason = pilot.set_goal(*goal)
            if reason is not None:
                refusals.append((time_s, reason))
        reason = pilot.pop_refusal()
        if reason is not None:
            refusals.append((time_s, reason))

    return run(mechanism, duration_s, script, "pivot"), refusals


@pytest.mark.parametrize("mechanism", MECHANISMS)
@pytest.mark.parametrize(
    ("goal", "where"),
    # 18 degrees left, within the tightest left circle (15-17 m); 18 degrees right.
    [((3.0, 1.0), "inside that circle"), ((3.0, -1.0), "to the right")],
)
def test_pivot_steering_refuses_a_goal_it_cannot_turn_to_and_never_runs_the_carrier(
    mechanism, goal, where
):
    loop, refusals = flight_with_refusals(mechanism, goal, 2.0)
    # Set before the first odometry: judged on the first sample.
    (when, reason), *_ = refusals
    assert when <= 1.0 / SAMPLE_RATE_HZ + 1e-12
    assert "out of reach: pivot steering turns only left" in reason and where in reason
    assert np.all(loop.carrier_mean_speed_rad_s == 0.0)


@pytest.mark.parametrize("mechanism", MECHANISMS)
def test_pivot_steering_reaches_a_goal_ahead_and_to_the_left_outside_its_circle(mechanism):
    goal = (10.0, 2.0)
    loop, refusals = flight_with_refusals(mechanism, goal, 45.0)
    assert refusals == []
    assert time_to_reach(loop, goal, 0.2) <= 45.0
