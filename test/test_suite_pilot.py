"""The pilot node as a process: cmd_vel and odometry in, the carrier's profile out, limits said.

The probe plays the fish: it publishes fish/odom (a fish swimming straight along x at a steady
speed) and cmd_vel, and records what the pilot commands on motor/cmd_profile and says on
/diagnostics. The closed loop through the simulator is test_suite_pilot_loop.py.
"""

from __future__ import annotations

import math
import time

import pytest
from geometry_msgs.msg import PoseStamped, Twist
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rcl_interfaces.srv import SetParameters

from fishtail_common.interface import CMD_VEL, FISH_ODOM, GOAL_POSE, MOTOR_CMD_PROFILE, Level
from fishtail_common.ros import publisher_qos
from fishtail_msgs.msg import CarrierSpeedProfile

PILOT_MODULE = "fishtail_pilot.node"
#: The pilot measures its steering map at start-up (under a second, plus numba's first compile).
START_TIMEOUT_S = 60.0
TIMEOUT_S = 20.0
ODOM_PERIOD_S = 0.02


class FakeFish:
    """fish/odom of a fish swimming along x at ``speed_m_s``, published by the probe."""

    def __init__(self, ros, speed_m_s: float, frame: str = "odom") -> None:
        """Publish every ODOM_PERIOD_S on the probe's node, in ``frame``."""
        self.ros = ros
        self.frame = frame
        self.speed_m_s = speed_m_s
        self.x_m = 0.0
        self.publisher = ros.node.create_publisher(
            Odometry, FISH_ODOM.name, publisher_qos(FISH_ODOM)
        )
        self.timer = ros.node.create_timer(ODOM_PERIOD_S, self.publish)
        self.running = True
        self.not_finite = False  # a tracker's NaN heading

    def publish(self) -> None:
        """One odometry message, the fish a step further along x."""
        if not self.running:
            return
        message = Odometry()
        message.header.stamp = self.ros.node.get_clock().now().to_msg()
        message.header.frame_id = self.frame
        self.x_m += self.speed_m_s * ODOM_PERIOD_S
        message.pose.pose.position.x = self.x_m
        message.pose.pose.orientation.w = 1.0
        if self.not_finite:
            message.pose.pose.orientation.z = math.nan
        message.twist.twist.linear.x = self.speed_m_s
        self.publisher.publish(message)


def start_pilot(start_node, ros, **params):
    process = start_node(PILOT_MODULE, name="pilot", params=params)
    ros.wait_for_subscribers(CMD_VEL.name, 1, START_TIMEOUT_S)
    return process


def twist(forward: float, yaw_rate: float) -> Twist:
    message = Twist()
    message.linear.x = forward
    message.angular.z = yaw_rate
    return message


def test_cmd_vel_becomes_a_carrier_profile_and_the_watchdog_stops_it(start_node, ros):
    profiles = ros.record(CarrierSpeedProfile, MOTOR_CMD_PROFILE.name)
    start_pilot(start_node, ros, cmd_timeout_sec=0.5)
    fish = FakeFish(ros, 0.3)
    commands = ros.node.create_publisher(Twist, CMD_VEL.name, publisher_qos(CMD_VEL))
    sender = ros.node.create_timer(0.1, lambda: commands.publish(twist(0.3, 0.0)))
    ros.spin_until(
        lambda: any(p.mean_speed > 0.0 for p in profiles), TIMEOUT_S, "a moving carrier profile"
    )
    moving = [p for p in profiles if p.mean_speed > 0.0][-1]
    # The fish already swims at the commanded speed: the command is the feed-forward, the
    # carrier speed of 0.3 m/s on the straight-swimming map, 2 pi 0.3 / (U/f), U/f ~ 0.2226 m
    # (the default fish, fin plate and all).
    assert moving.mean_speed == pytest.approx(2 * math.pi * 0.3 / 0.2226, rel=0.05)
    sender.cancel()
    count = len(profiles)
    ros.spin_until(
        lambda: any(p.mean_speed == 0.0 for p in profiles[count:]),
        TIMEOUT_S,
        "the watchdog's stop after cmd_vel ended",
    )
    fish.running = False


def test_a_turn_beyond_reach_is_reported_with_the_achievable_rate(start_node, ros):
    diagnostics = ros.record_diagnostics()
    start_pilot(start_node, ros, cmd_timeout_sec=0.0)
    FakeFish(ros, 0.3)
    commands = ros.node.create_publisher(Twist, CMD_VEL.name, publisher_qos(CMD_VEL))
    commands.publish(twist(0.3, 5.0))

    def warned():
        return any(
            level == Level.WARN and "yaw_rate" in status.message
            for _, level, status in ros.statuses(diagnostics, "pilot")
        )

    ros.spin_until(warned, TIMEOUT_S, "a WARN naming the yaw rate")
    status = next(
        status for _, level, status in ros.statuses(diagnostics, "pilot") if level == Level.WARN
    )
    achievable = float(ros.values(status)["achievable_yaw_rate_rad_s"])
    # At most 0.48 rad a beat (the map's strongest left turn) at 0.3 / 0.287 beats a second.
    assert 0.2 < achievable < 0.6
    assert "beyond reach" in status.message


def test_goals_are_flown_in_the_odometry_frame_and_refused_in_another(start_node, ros):
    """A goal in ``map`` is refused with a WARN naming it; in the odometry's frame it is flown."""
    profiles = ros.record(CarrierSpeedProfile, MOTOR_CMD_PROFILE.name)
    diagnostics = ros.record_diagnostics()
    start_pilot(start_node, ros, cmd_timeout_sec=0.0)
    FakeFish(ros, 0.1, frame="fish1/odom")
    goals = ros.node.create_publisher(PoseStamped, GOAL_POSE.name, publisher_qos(GOAL_POSE))

    def goal(frame: str) -> PoseStamped:
        message = PoseStamped()
        message.header.frame_id = frame
        message.pose.position.x = 3.0
        return message

    ros.spin_for(0.5)  # the pilot has the odometry's frame
    goals.publish(goal("map"))
    ros.spin_until(
        lambda: any(
            level == Level.WARN and "'map' refused" in status.message
            for _, level, status in ros.statuses(diagnostics, "pilot")
        ),
        TIMEOUT_S,
        "a WARN refusing the goal in map",
    )
    assert not any(p.mean_speed > 0.0 for p in profiles), "a goal in map was flown"
    goals.publish(goal("fish1/odom"))
    ros.spin_until(lambda: any(p.mean_speed > 0.0 for p in profiles), TIMEOUT_S, "the goal flown")


@pytest.mark.parametrize("odometry_first", [True, False])
def test_a_goal_pivot_steering_cannot_turn_to_is_refused_with_the_reason(
    start_node, ros, odometry_first
):
    """Pivot steering turns only left: a goal 18 degrees right is refused with a WARN saying so.

    Sent before the first odometry, it is judged on it and given up with the same WARN.
    """
    profiles = ros.record(CarrierSpeedProfile, MOTOR_CMD_PROFILE.name)
    diagnostics = ros.record_diagnostics()
    start_pilot(start_node, ros, cmd_timeout_sec=0.0, steering="pivot")
    goals = ros.node.create_publisher(PoseStamped, GOAL_POSE.name, publisher_qos(GOAL_POSE))
    goal = PoseStamped()
    goal.pose.position.x, goal.pose.position.y = 3.0, -1.0
    ros.wait_for_subscribers(GOAL_POSE.name, 1, TIMEOUT_S)  # so that the goal is not lost
    if odometry_first:
        FakeFish(ros, 0.0)  # at rest at the origin, heading along x
        ros.spin_for(0.5)  # the pilot knows where the fish is
        goals.publish(goal)
    else:
        goals.publish(goal)
        ros.spin_for(0.5)
        FakeFish(ros, 0.0)

    def refused():
        return any(
            level == Level.WARN
            and "refused: goal (3.000, -1.000) m is out of reach" in status.message
            and "turns only left" in status.message
            for _, level, status in ros.statuses(diagnostics, "pilot")
        )

    ros.spin_until(refused, TIMEOUT_S, "a WARN refusing the goal out of the pivot's reach")
    assert not any(p.mean_speed > 0.0 for p in profiles), "a goal out of reach was flown"


def test_odometry_that_stops_stops_the_carrier_until_it_is_back(start_node, ros):
    profiles = ros.record(CarrierSpeedProfile, MOTOR_CMD_PROFILE.name)
    diagnostics = ros.record_diagnostics()
    start_pilot(start_node, ros, cmd_timeout_sec=0.0, odom_timeout_sec=0.3)
    fish = FakeFish(ros, 0.1)
    commands = ros.node.create_publisher(Twist, CMD_VEL.name, publisher_qos(CMD_VEL))
    commands.publish(twist(0.3, 0.0))
    ros.spin_until(
        lambda: any(p.mean_speed > 0.0 for p in profiles), TIMEOUT_S, "a moving carrier profile"
    )
    fish.running = False
    count = len(profiles)
    ros.spin_until(lambda: any(p.mean_speed == 0.0 for p in profiles[count:]), TIMEOUT_S, "a stop")
    ros.spin_until(
        lambda: any(level == Level.ERROR for _, level, _ in ros.statuses(diagnostics, "pilot")),
        TIMEOUT_S,
        "an ERROR status",
    )
    # The command stands: with odometry back, the carrier runs again.
    count = len(profiles)
    fish.running = True
    ros.spin_until(
        lambda: any(p.mean_speed > 0.0 for p in profiles[count:]), TIMEOUT_S, "the carrier again"
    )


def test_odometry_that_is_not_finite_stops_the_carrier_with_an_error_until_it_is_finite(
    start_node, ros
):
    profiles = ros.record(CarrierSpeedProfile, MOTOR_CMD_PROFILE.name)
    diagnostics = ros.record_diagnostics()
    start_pilot(start_node, ros, cmd_timeout_sec=0.0)
    fish = FakeFish(ros, 0.3)
    commands = ros.node.create_publisher(Twist, CMD_VEL.name, publisher_qos(CMD_VEL))
    commands.publish(twist(0.3, 0.0))
    ros.spin_until(
        lambda: any(p.mean_speed > 0.0 for p in profiles), TIMEOUT_S, "a moving carrier profile"
    )
    fish.not_finite = True
    count = len(profiles)
    ros.spin_until(lambda: any(p.mean_speed == 0.0 for p in profiles[count:]), TIMEOUT_S, "a stop")

    def not_finite_error():
        return any(
            level == Level.ERROR and "not finite" in status.message
            for _, level, status in ros.statuses(diagnostics, "pilot")
        )

    ros.spin_until(not_finite_error, TIMEOUT_S, "an ERROR naming the odometry not finite")
    fish.not_finite = False
    count = len(profiles)
    ros.spin_until(
        lambda: any(p.mean_speed > 0.0 for p in profiles[count:]), TIMEOUT_S, "the carrier again"
    )
    moving = [p for p in profiles if p.mean_speed > 0.0][-1]
    assert math.isfinite(moving.mean_speed) and moving.modulation_depth < 0.1


def set_parameters(ros, **values: float) -> list:
    """Set the pilot's parameters as `ros2 param set` does: the results, one per parameter."""
    request = SetParameters.Request(
        parameters=[
            Parameter(
                name=name,
                value=ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=value),
            )
            for name, value in values.items()
        ]
    )
    return list(ros.call(SetParameters, "/pilot/set_parameters", request).results)


def first_stop_ns(profiles, after: int) -> int:
    """When the first stopped profile after message ``after`` arrived."""
    return next(
        profiles.receive_ns[index]
        for index in range(after, len(profiles))
        if profiles[index].mean_speed == 0.0
    )


def test_timeouts_and_the_control_rate_set_at_run_time_are_in_force_and_gains_read_only(
    start_node, ros
):
    profiles = ros.record(CarrierSpeedProfile, MOTOR_CMD_PROFILE.name)
    start_pilot(start_node, ros, cmd_timeout_sec=0.5)
    fish = FakeFish(ros, 0.3)
    results = set_parameters(ros, cmd_timeout_sec=4.0, control_rate_hz=5.0)
    assert all(result.successful for result in results), results
    (refused,) = set_parameters(ros, speed_gain=1.0)
    assert not refused.successful  # the law's gains are fixed for the run
    commands = ros.node.create_publisher(Twist, CMD_VEL.name, publisher_qos(CMD_VEL))
    ros.wait_for_subscribers(FISH_ODOM.name, 1, TIMEOUT_S)
    # cmd_timeout_sec: one cmd_vel keeps the carrier going for 4 s, not 0.5 s.
    sent_ns = time.time_ns()
    commands.publish(twist(0.3, 0.0))
    ros.spin_until(lambda: any(p.mean_speed > 0.0 for p in profiles), TIMEOUT_S, "moving")
    start = next(index for index, p in enumerate(profiles) if p.mean_speed > 0.0)
    ros.spin_until(
        lambda: any(p.mean_speed == 0.0 for p in profiles[start:]), TIMEOUT_S, "the stop"
    )
    stopped_ns = first_stop_ns(profiles, start)
    assert 3.5 < (stopped_ns - sent_ns) * 1e-9 < 6.0
    # control_rate_hz: 5 profiles a second while moving, not 20.
    moving_s = (stopped_ns - profiles.receive_ns[start]) * 1e-9
    rate_hz = sum(1 for p in profiles[start:] if p.mean_speed > 0.0) / moving_s
    assert 3.0 < rate_hz < 8.0
    # odom_timeout_sec: 3 s without odometry before the carrier stops, not 1 s.
    results = set_parameters(ros, cmd_timeout_sec=0.0, odom_timeout_sec=3.0)
    assert all(result.successful for result in results), results
    count = len(profiles)
    commands.publish(twist(0.3, 0.0))
    ros.spin_until(lambda: any(p.mean_speed > 0.0 for p in profiles[count:]), TIMEOUT_S, "moving")
    count = len(profiles)
    fish.running = False
    blind_ns = time.time_ns()
    ros.spin_until(
        lambda: any(p.mean_speed == 0.0 for p in profiles[count:]), TIMEOUT_S, "the stop"
    )
    assert 2.5 < (first_stop_ns(profiles, count) - blind_ns) * 1e-9 < 5.0


def test_an_idle_pilot_sends_one_stop_then_nothing_beside_manual_commands(start_node, ros):
    profiles = ros.record(CarrierSpeedProfile, MOTOR_CMD_PROFILE.name)
    start_pilot(start_node, ros, cmd_timeout_sec=0.5)
    fish = FakeFish(ros, 0.3)
    manual = ros.command_speed(4.0)  # motor/cmd_speed at 10 Hz, someone driving by hand
    ros.wait_for_subscribers(FISH_ODOM.name, 1, TIMEOUT_S)
    ros.spin_for(2.0)
    assert len(profiles) == 0  # idle from the start, odometry coming: it has nothing to stop
    commands = ros.node.create_publisher(Twist, CMD_VEL.name, publisher_qos(CMD_VEL))
    commands.publish(twist(0.3, 0.0))
    ros.spin_until(
        lambda: any(p.mean_speed == 0.0 for p in profiles), TIMEOUT_S, "the watchdog's stop"
    )
    count = len(profiles)
    ros.spin_for(2.0)
    assert len(profiles) == count  # one stop, then silence
    assert sum(1 for p in profiles if p.mean_speed == 0.0) == 1
    manual.speed = None
    fish.running = False
