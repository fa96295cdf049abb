"""The pilot's control law on its own: commands, limits, goals, stops (no fish, no ROS)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fishtail_pilot.pilot import (
    MAX_GOAL_COORDINATE_M,
    BeatAverage,
    Mode,
    Pilot,
    PilotSettings,
    wrap_angle,
)
from fishtail_pilot.steering_map import ModulationChannel, PivotChannel

SPEED_PER_BEAT_M = 0.25
TOP_CARRIER_RAD_S = 20.0


DISTANCE = [SPEED_PER_BEAT_M] * 3


def modulation(yaw_per_beat: float = 0.01) -> ModulationChannel:
    # A made-up table, linear in the signed depth: yaw_per_beat rad a beat at full depth.
    return ModulationChannel(
        [-0.9, 0.0, 0.9], [-yaw_per_beat, 0.0, yaw_per_beat], DISTANCE, 1.0, 1.0 + math.pi
    )


def pilot(steering=None, **settings) -> Pilot:
    settings.setdefault("motor_lag_s", 0.0)
    return Pilot(
        PilotSettings(SPEED_PER_BEAT_M, TOP_CARRIER_RAD_S, **settings), steering or modulation()
    )


def test_wrap_angle_keeps_angles_within_half_a_turn():
    assert wrap_angle(0.0) == 0.0
    assert wrap_angle(2 * math.pi + 0.1) == pytest.approx(0.1)
    assert wrap_angle(-math.pi - 0.1) == pytest.approx(math.pi - 0.1)
    # Half a turn either way is +pi: a goal straight behind is turned to the left.
    assert wrap_angle(math.pi) == wrap_angle(-math.pi) == math.pi


def test_beat_average_removes_a_whole_period_of_oscillation():
    average = BeatAverage()
    period = 0.8
    for time_s in np.arange(0.0, 5.0, 0.001):
        average.add(float(time_s), 0.3 + 0.2 * math.sin(2 * math.pi * time_s / period))
    # The window spans the period plus less than one sample interval: at most amplitude times
    # dt / period of the oscillation is left.
    assert average.mean(period) == pytest.approx(0.3, abs=0.2 * 0.001 / period)


def test_velocity_commands_that_are_not_finite_or_backwards_are_refused_with_a_reason():
    fish_pilot = pilot()
    assert "not finite" in fish_pilot.set_velocity(math.nan, 0.0)
    assert "backwards" in fish_pilot.set_velocity(-0.1, 0.0)
    assert fish_pilot.mode is Mode.IDLE
    assert "not finite" in fish_pilot.set_goal(1.0, math.inf)


def test_the_feed_forward_asks_the_carrier_speed_of_the_steady_speed_map():
    fish_pilot = pilot(speed_gain=0.0, speed_integral_per_s=0.0)
    fish_pilot.set_velocity(0.2, 0.0)
    command = fish_pilot.observe(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    # U = (U/f) f and f = Omega / 2 pi: Omega = 2 pi U / (U/f), hand-derived.
    assert command.carrier.mean_speed_rad_s == pytest.approx(2 * math.pi * 0.2 / SPEED_PER_BEAT_M)
    assert command.carrier.depth == 0.0
    assert fish_pilot.limit_reports == {}


def test_a_speed_beyond_the_carrier_is_flown_at_the_limit_and_reported_with_the_achievable():
    fish_pilot = pilot()
    fish_pilot.set_velocity(5.0, 0.0)
    command = fish_pilot.observe(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    assert command.carrier.mean_speed_rad_s == pytest.approx(TOP_CARRIER_RAD_S)
    report = fish_pilot.limit_reports["speed"]
    assert report.requested == 5.0
    assert report.achievable == pytest.approx(TOP_CARRIER_RAD_S / (2 * math.pi) * SPEED_PER_BEAT_M)


def test_a_turn_beyond_the_steering_is_reported_with_the_yaw_rate_it_can_give():
    fish_pilot = pilot()
    fish_pilot.set_velocity(0.2, 0.5)
    fish_pilot.observe(0.0, 0.0, 0.0, 0.0, 0.2, 0.0)
    report = fish_pilot.limit_reports["yaw_rate"]
    beat_hz = 0.2 / SPEED_PER_BEAT_M
    assert report.achievable == pytest.approx(0.01 * beat_hz)
    assert "radius of at least 25" in report.reason  # (U/f) / (r/f) = 0.25 / 0.01 m


def test_a_turn_without_speed_is_reported_as_impossible():
    fish_pilot = pilot()
    fish_pilot.set_velocity(0.0, 0.1)
    fish_pilot.observe(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    assert fish_pilot.limit_reports["yaw_rate"].achievable == 0.0


def test_a_left_turn_asks_for_leftward_steering_and_a_right_turn_for_rightward():
    for yaw_rate, phase in ((0.001, 1.0), (-0.001, 1.0 + math.pi)):
        fish_pilot = pilot()
        fish_pilot.set_velocity(0.2, yaw_rate)
        command = fish_pilot.observe(0.0, 0.0, 0.0, 0.0, 0.2, 0.0)
        assert command.carrier.depth > 0.0
        assert command.carrier.phase_rad == pytest.approx(phase)
        assert "yaw_rate" not in fish_pilot.limit_reports


def test_the_profile_peak_never_exceeds_the_carrier_top_speed():
    rng = np.random.default_rng(5)
    for _ in range(200):
        fish_pilot = pilot()
        fish_pilot.set_velocity(float(rng.uniform(0.0, 2.0)), float(rng.uniform(-1.0, 1.0)))
        command = fish_pilot.observe(0.0, 0.0, 0.0, 0.0, float(rng.uniform(0.0, 1.0)), 0.0)
        assert command.carrier.peak_speed_rad_s <= TOP_CARRIER_RAD_S * (1 + 1e-12)


def test_a_goal_ahead_is_swum_to_and_the_carrier_stops_within_the_tolerance():
    fish_pilot = pilot(goal_tolerance_m=0.2)
    fish_pilot.set_goal(3.0, 0.0)
    command = fish_pilot.observe(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    assert fish_pilot.mode is Mode.GOAL and command.carrier.mean_speed_rad_s > 0.0
    assert fish_pilot.distance_to_goal_m() == pytest.approx(3.0)
    command = fish_pilot.observe(0.1, 2.85, 0.05, 0.0, 0.1, 0.0)
    assert fish_pilot.goal_reached and fish_pilot.mode is Mode.IDLE
    assert command.carrier.mean_speed_rad_s == 0.0


def test_near_a_goal_the_pilot_slows_down_in_proportion_to_the_distance():
    fish_pilot = pilot(slow_down_distance_m=1.0, cruise_speed_m_s=0.3, goal_tolerance_m=0.1)
    fish_pilot.set_goal(0.5, 0.0)
    fish_pilot.observe(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    assert fish_pilot.speed_command_m_s == pytest.approx(0.15)


def test_a_goal_to_the_left_asks_for_a_left_turn():
    # Steering tight enough (0.5 rad a beat: a 0.5 m circle) for a goal 3 m to the side.
    fish_pilot = pilot(modulation(0.5))
    fish_pilot.set_goal(0.0, 3.0)
    command = fish_pilot.observe(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    assert command.carrier.depth > 0.0 and command.carrier.phase_rad == pytest.approx(1.0)


def test_stop_stops_the_carrier_and_holds_the_pivot():
    steering = PivotChannel([-0.03, 0.0, 0.03], [0.02, 0.0, -0.02], DISTANCE)
    fish_pilot = pilot(steering)
    fish_pilot.set_velocity(0.2, 0.001)
    moving = fish_pilot.observe(0.0, 0.0, 0.0, 0.0, 0.2, 0.0)
    assert moving.pivot_shift_m is not None and moving.pivot_shift_m < 0.0
    stopped = fish_pilot.stop()
    assert stopped.carrier.mean_speed_rad_s == 0.0
    assert stopped.pivot_shift_m == moving.pivot_shift_m
    assert fish_pilot.mode is Mode.IDLE


def test_the_modulation_is_asked_a_motor_lag_early():
    lagging, ideal = pilot(motor_lag_s=0.1), pilot()
    for fish_pilot in (lagging, ideal):
        fish_pilot.set_velocity(0.2, 0.001)
    early = lagging.observe(0.0, 0.0, 0.0, 0.0, 0.2, 0.0).carrier
    on_time = ideal.observe(0.0, 0.0, 0.0, 0.0, 0.2, 0.0).carrier
    # Hand-derived: a lag tau is a carrier angle of Omega tau.
    expected = (on_time.phase_rad - on_time.mean_speed_rad_s * 0.1) % (2 * math.pi)
    assert early.phase_rad == pytest.approx(expected)
    assert (early.mean_speed_rad_s, early.depth) == (on_time.mean_speed_rad_s, on_time.depth)


def samples(fish_pilot, start_s, end_s, yaw=0.0, speed=0.2):
    """Odometry of a fish at the origin, heading ``yaw``, every 50 ms: the last command."""
    command = None
    for time_s in np.arange(start_s, end_s, 0.05):
        command = fish_pilot.observe(float(time_s), 0.0, 0.0, yaw, speed, 0.0)
    return command


def test_a_nan_heading_is_dropped_counted_and_stops_the_carrier_until_good_odometry_returns():
    fish_pilot = pilot(modulation(0.5))
    fish_pilot.set_goal(3.0, 3.0)
    samples(fish_pilot, 0.0, 1.0)
    blind = fish_pilot.observe(1.0, 0.0, 0.0, math.nan, 0.2, 0.0)
    assert blind.carrier.mean_speed_rad_s == 0.0
    assert not fish_pilot.feedback_valid and fish_pilot.dropped_samples == 1
    assert fish_pilot.mode is Mode.GOAL
    command = samples(fish_pilot, 1.05, 2.0)
    assert fish_pilot.feedback_valid and fish_pilot.dropped_samples == 1
    assert math.isfinite(fish_pilot.mean_heading_rad)
    # The goal lies to the left: the pilot steers left again, as it did before the NaN.
    assert command.carrier.mean_speed_rad_s > 0.0 and command.carrier.depth > 0.0
    assert command.carrier.phase_rad == pytest.approx(1.0)


def test_a_nan_speed_is_dropped_and_the_speed_loop_recovers():
    fish_pilot = pilot()
    fish_pilot.set_velocity(0.2, 0.0)
    before = samples(fish_pilot, 0.0, 1.0)
    for time_s in (1.0, 1.05):
        blind = fish_pilot.observe(time_s, 0.0, 0.0, 0.0, math.nan, 0.0)
        assert blind.carrier.mean_speed_rad_s == 0.0
    assert fish_pilot.dropped_samples == 2 and not fish_pilot.feedback_valid
    after = samples(fish_pilot, 1.1, 2.0)
    assert math.isfinite(fish_pilot.mean_speed_m_s)
    assert after.carrier.mean_speed_rad_s == pytest.approx(before.carrier.mean_speed_rad_s)


def test_an_unreachable_turn_leaves_no_extra_turn_for_the_straight_command_after_it():
    fish_pilot = pilot()
    fish_pilot.set_velocity(0.3, 1e6)
    samples(fish_pilot, 0.0, 3.0, speed=0.3)  # the fish cannot turn that fast: it swims straight
    fish_pilot.set_velocity(0.3, 0.0)
    command = samples(fish_pilot, 3.0, 3.2, speed=0.3)
    assert command.carrier.depth == 0.0  # straight on, no debt of heading to make up


def test_a_turn_asked_with_the_carrier_stopped_leaves_no_extra_turn_after_it():
    fish_pilot = pilot()
    fish_pilot.set_velocity(0.0, 0.4)
    samples(fish_pilot, 0.0, 3.0, speed=0.0)
    fish_pilot.set_velocity(0.3, 0.0)
    command = samples(fish_pilot, 3.0, 3.2, speed=0.3)
    assert command.carrier.depth == 0.0


def test_the_heading_reference_of_a_repeated_unreachable_turn_stays_within_a_saturating_lead():
    fish_pilot = pilot(modulation(0.5), heading_gain_per_beat=3.0)
    for time_s in np.arange(0.0, 3.0, 0.05):
        fish_pilot.set_velocity(0.3, 1e6)  # cmd_vel repeated at 20 Hz
        fish_pilot.observe(float(time_s), 0.0, 0.0, 0.0, 0.3, 0.0)
    lead = fish_pilot.heading_reference_rad - fish_pilot.mean_heading_rad
    # At most half the strongest turn a beat (the beat mean's lag) plus what saturates the
    # steering through the heading gain: 0.5 * 0.5 + 0.5 / 3 rad, not the quarter turn of before.
    assert 0.0 < lead <= 0.5 * 0.5 + 0.5 / 3.0 + 1e-12


def test_a_goal_beyond_the_sane_range_is_refused_with_a_reason_naming_it():
    fish_pilot = pilot()
    reason = fish_pilot.set_goal(1e300, 3.0)
    assert reason is not None and "1e+300" in reason and f"{MAX_GOAL_COORDINATE_M:g}" in reason
    assert fish_pilot.mode is Mode.IDLE and fish_pilot.goal is None
    assert fish_pilot.set_goal(3.0, -MAX_GOAL_COORDINATE_M - 1.0) is not None
    assert fish_pilot.set_goal(-MAX_GOAL_COORDINATE_M, MAX_GOAL_COORDINATE_M) is None
    assert fish_pilot.mode is Mode.GOAL


def left_only() -> PivotChannel:
    # A made-up pivot table that turns left up to 0.05 rad a beat and right up to 0.005: with
    # 0.25 m a beat its tightest circles, (U/f) / (2 sin(r/2f)), are 5.0 m left and 50 m right.
    return PivotChannel([-0.02, 0.0, 0.02], [0.05, 0.0, -0.005], DISTANCE)


def at_rest(fish_pilot: Pilot, yaw: float = 0.0) -> None:
    """One odometry sample: the fish at rest at the origin, heading ``yaw``."""
    fish_pilot.observe(0.0, 0.0, 0.0, yaw, 0.0, 0.0)


def test_a_steering_that_turns_a_tenth_as_strongly_one_way_turns_only_the_other():
    assert pilot(left_only()).one_way() == 1.0
    mirrored = PivotChannel([-0.02, 0.0, 0.02], [0.005, 0.0, -0.05], DISTANCE)
    assert pilot(mirrored).one_way() == -1.0
    assert pilot(modulation(0.3)).one_way() == 0.0


def test_a_goal_to_the_side_a_one_way_steering_hardly_turns_to_is_refused_with_the_reason():
    fish_pilot = pilot(left_only())
    at_rest(fish_pilot)
    # 1 m right at 3 m ahead: inside the 50 m circle of its strongest right turn (centre 50 m to
    # the right, the goal 49.09 m from it).
    reason = fish_pilot.set_goal(3.0, -1.0)
    assert reason is not None
    for part in (
        "goal (3.000, -1.000) m is out of reach",
        "pivot steering turns only left",
        "tightest radius 5 m",
        "18° to the right",
        "no tighter than a radius of 50 m",
    ):
        assert part in reason
    assert fish_pilot.mode is Mode.IDLE and fish_pilot.goal is None
    # Behind on that side, however far: the weak turn would take a whole circle of 50 m.
    assert fish_pilot.set_goal(-30.0, -1.0) is not None


def test_a_goal_inside_a_one_way_steerings_tightest_circle_is_refused():
    fish_pilot = pilot(left_only())
    at_rest(fish_pilot)
    # The left circle's centre is (0, 5): the goal 4.47 m from it, 0.53 m inside.
    reason = fish_pilot.set_goal(2.0, 1.0)
    assert reason is not None and "inside that circle" in reason and "to the left" in reason
    assert fish_pilot.mode is Mode.IDLE


def test_goals_a_one_way_steering_reaches_are_accepted():
    # Left of it outside the 5 m circle, ahead or behind (it turns round the left way), or on
    # it ((3, 1) is 5 m from its centre (0, 5)); to its right outside the 50 m circle.
    for goal in ((10.0, 2.0), (-10.0, 3.0), (3.0, 1.0), (10.0, -0.5)):
        fish_pilot = pilot(left_only())
        at_rest(fish_pilot)
        assert fish_pilot.set_goal(*goal) is None, goal
        assert fish_pilot.mode is Mode.GOAL


def test_the_reach_is_judged_from_the_fish_heading():
    fish_pilot = pilot(left_only())
    at_rest(fish_pilot, yaw=math.pi / 2)  # heading north: its left is west
    assert fish_pilot.set_goal(-2.0, 10.0) is None
    assert fish_pilot.set_goal(2.0, 10.0) is not None


def test_a_steering_that_turns_both_ways_reaches_every_goal():
    for goal in ((2.0, 1.0), (3.0, -1.0), (-3.0, 0.0), (0.1, 0.5)):
        fish_pilot = pilot(modulation(0.3))
        at_rest(fish_pilot)
        assert fish_pilot.set_goal(*goal) is None, goal


def test_a_goal_set_before_the_first_odometry_is_judged_on_it_and_given_up_with_the_reason():
    fish_pilot = pilot(left_only())
    assert fish_pilot.set_goal(3.0, -1.0) is None  # the fish's pose is not known yet
    command = fish_pilot.observe(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    assert command.carrier.mean_speed_rad_s == 0.0
    reason = fish_pilot.pop_refusal()
    assert reason is not None and "out of reach" in reason
    assert fish_pilot.pop_refusal() is None  # said once
    assert fish_pilot.mode is Mode.IDLE and fish_pilot.goal is None and not fish_pilot.goal_reached


def test_in_flight_a_one_way_goal_is_given_up_only_once_passed():
    fish_pilot = pilot(left_only())
    at_rest(fish_pilot)
    assert fish_pilot.set_goal(10.0, 2.0) is None
    # Drifted left of the line: the goal, 0.6 m right at 5 m ahead, is beyond the weak turn,
    # but not passed, and sent again it is not refused: the fish may yet pass within reach.
    command = fish_pilot.observe(0.05, 5.0, 2.6, 0.0, 0.2, 0.0)
    assert fish_pilot.set_goal(10.0, 2.0) is None
    assert fish_pilot.pop_refusal() is None and command.carrier.mean_speed_rad_s > 0.0
    # Passed, 0.4 m to the right: given up, with the reason, and the carrier stops.
    command = fish_pilot.observe(0.1, 10.5, 2.4, 0.0, 0.2, 0.0)
    reason = fish_pilot.pop_refusal()
    assert reason is not None and "to the right" in reason
    assert command.carrier.mean_speed_rad_s == 0.0 and fish_pilot.mode is Mode.IDLE
