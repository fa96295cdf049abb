"""The whole loop as processes: pilot -> driver -> simulator -> pilot, the fish sent to a goal.

The driver runs its simulated DC motor under the firmware's speed loop (it lags the profile the
pilot asks for, as a real motor does); the simulator integrates the fish from the carrier's
samples; the pilot reads fish/odom and commands motor/cmd_profile. The goal is 3 m away; the
pilot must bring the fish within 0.2 m and stop the carrier. With the pivot actuator the pilot's
pivot command reaches the driver's actuator and the simulator's tail.
"""

from __future__ import annotations

import math

from geometry_msgs.msg import PoseStamped, Twist
from nav_msgs.msg import Odometry
from sensor_msgs.msg import JointState

from fishtail_common.interface import (
    CMD_VEL,
    FISH_ODOM,
    GOAL_POSE,
    MOTOR_JOINT_STATE,
    PIVOT_JOINT_STATE,
    Level,
)
from fishtail_common.ros import publisher_qos
from fishtail_driver.parameters import DC_MOTOR_ENCODER

PILOT_MODULE = "fishtail_pilot.node"
SIM_MODULE = "fishtail_swim.nodes.sim_node"
GOAL = (3.0, 0.5)
#: The pilot reaches a goal 3 m away in about 10-15 s of swimming in the pure closed loop; the
#: processes add the pilot's start-up (steering map, numba's first compile) and the motor's lag.
GOAL_TIMEOUT_S = 90.0
START_TIMEOUT_S = 60.0


def start_loop(start_node, ros, parameters, driver=None, pilot=None):
    # The DC gear motor with its gearbox and encoder, as fishtail-run --motor dc runs it.
    start_node("driver", params={"motor_model": "dc", **DC_MOTOR_ENCODER, **(driver or {})})
    start_node(SIM_MODULE, name="swim", params_file=parameters)
    start_node(PILOT_MODULE, name="pilot", params_file=parameters, params=pilot or {})
    ros.wait_for_subscribers(GOAL_POSE.name, 1, START_TIMEOUT_S)
    ros.wait_for_subscribers(FISH_ODOM.name, 1, START_TIMEOUT_S)  # the pilot


def test_a_goal_three_metres_away_is_reached_and_the_carrier_stops(start_node, ros, fish_and_tail):
    odometry = ros.record(Odometry, FISH_ODOM.name)
    motor = ros.record(JointState, MOTOR_JOINT_STATE.name)
    diagnostics = ros.record_diagnostics()
    start_loop(start_node, ros, fish_and_tail)
    goal = PoseStamped()
    goal.header.frame_id = "odom"
    goal.pose.position.x, goal.pose.position.y = GOAL
    ros.node.create_publisher(PoseStamped, GOAL_POSE.name, publisher_qos(GOAL_POSE)).publish(goal)

    def reached():
        return any(
            status.message == "goal reached" for _, _, status in ros.statuses(diagnostics, "pilot")
        )

    ros.spin_until(reached, GOAL_TIMEOUT_S, "the pilot's 'goal reached'")
    closest = min(
        math.hypot(o.pose.pose.position.x - GOAL[0], o.pose.pose.position.y - GOAL[1])
        for o in odometry
    )
    assert closest <= 0.2
    # The carrier stops: the motor's speed falls to zero (the DC motor coasts down).
    count = len(motor)
    ros.spin_until(
        lambda: any(abs(m.velocity[0]) < 1e-3 for m in motor[count:]),
        20.0,
        "the carrier at rest after the goal",
    )
    assert all(level != Level.ERROR for _, level, _ in ros.statuses(diagnostics, "pilot"))


def test_pivot_steering_moves_the_drivers_actuator_and_the_simulated_tail(
    start_node, ros, fish_and_tail
):
    pivot = ros.record(JointState, PIVOT_JOINT_STATE.name)
    diagnostics = ros.record_diagnostics()
    start_loop(
        start_node, ros, fish_and_tail,
        driver={"pivot_actuator": "sim"}, pilot={"steering": "pivot", "cmd_timeout_sec": 0.0},
    )  # fmt: skip
    command = Twist()
    command.linear.x, command.angular.z = 0.3, 0.05  # left: the pivot moves S forwards
    ros.node.create_publisher(Twist, CMD_VEL.name, publisher_qos(CMD_VEL)).publish(command)
    ros.spin_until(
        lambda: any(m.position and m.position[0] < -0.002 for m in pivot),
        START_TIMEOUT_S,
        "the driver's pivot actuator moving S forwards",
    )

    def simulator_follows():
        for _, _, status in ros.statuses(diagnostics, "swim"):
            shift = ros.values(status).get("pivot_shift_m")
            if shift is not None and float(shift) < -0.002:
                return True
        return False

    ros.spin_until(simulator_follows, START_TIMEOUT_S, "the simulator's tail with S shifted")
