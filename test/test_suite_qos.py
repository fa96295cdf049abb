"""Every topic the suite publishes reaches a subscriber made the usual way (REP 2003).

Driver (with its simulated pivot actuator, so that pivot/joint_state flows), kinematics node,
monitor, simulator and pilot as processes. For each topic they publish the probe holds a
subscription made as ``create_subscription(..., 10)`` makes it (reliable, volatile, depth 10:
also nav2's and robot_localization's defaults) and, for the state topics, a sensor-data one
(best effort, what the suite's own nodes ask for). All must receive. Before, the state topics
were published best effort, and the default subscriber received nothing from any of them.
"""

from __future__ import annotations

import importlib.util

from rclpy.qos import QoSProfile
from rosidl_runtime_py.utilities import get_message

from fishtail_common.interface import (
    CMD_VEL,
    GOAL_POSE,
    MOTOR_CMD_SPEED,
    SUITE_TOPICS,
    TF,
    TF_STATIC,
    QosKind,
)

SIM_MODULE = "fishtail_swim.nodes.sim_node"
PILOT_MODULE = "fishtail_pilot.node"
STATE_TOPICS = [topic for topic in SUITE_TOPICS if topic.qos is QosKind.STATE]
#: What the probe publishes itself (commands to the suite), and tf where tf2_msgs is missing.
NOT_PUBLISHED = {MOTOR_CMD_SPEED.name, CMD_VEL.name, GOAL_POSE.name} | (
    set() if importlib.util.find_spec("tf2_msgs") else {TF.name, TF_STATIC.name}
)
PUBLISHED = [topic for topic in SUITE_TOPICS if topic.name not in NOT_PUBLISHED]
MESSAGES = 5
TIMEOUT_S = 90.0


def test_a_default_subscriber_receives_every_topic_and_sensor_data_every_state_topic(
    start_node, ros, fish_and_tail
):
    assert {topic.name for topic in STATE_TOPICS} >= {
        "motor/joint_state", "pivot/joint_state", "tail/joint_states", "tail/tip", "tail/state",
        "fish/odom",
    }  # fmt: skip
    recorders = {}
    for topic in PUBLISHED:
        kind = get_message(topic.type)
        recorders[topic.name, "default"] = ros.record(kind, topic.name, QoSProfile(depth=10))
        if topic.qos is QosKind.STATE:
            recorders[topic.name, "sensor data"] = ros.record(kind, topic.name)
    start_node("driver", params_file=fish_and_tail, params={"pivot_actuator": "sim"})
    start_node("kinematics", params_file=fish_and_tail)
    start_node("monitor", params_file=fish_and_tail)
    start_node(SIM_MODULE, name="swim", params_file=fish_and_tail)
    start_node(PILOT_MODULE, name="pilot", params_file=fish_and_tail, params={"steering": "pivot"})
    ros.wait_for_subscribers(CMD_VEL.name)
    cmd_vel = ros.node.create_publisher(get_message(CMD_VEL.type), CMD_VEL.name, 10)
    command = get_message(CMD_VEL.type)()
    command.linear.x, command.angular.z = 0.2, 0.1  # the pivot moves: pivot/cmd_position flows
    ros.node.create_timer(0.1, lambda: cmd_vel.publish(command))

    def missing() -> list[tuple[str, str]]:
        # A latched or per-beat topic needs one message; the rest MESSAGES.
        return [
            key
            for key, recorder in recorders.items()
            if len(recorder) < (MESSAGES if key[0] not in ("tail/symmetry", TF_STATIC.name) else 1)
        ]

    try:
        ros.spin_until(lambda: not missing(), TIMEOUT_S, "every topic on its subscriptions")
    except TimeoutError:
        raise AssertionError(f"too few messages on {missing()}") from None
    for topic in STATE_TOPICS:
        offered = ros.node.get_publishers_info_by_topic(topic.name)
        assert offered, topic.name
        assert all(info.qos_profile.reliability.name == "RELIABLE" for info in offered), topic.name


def test_qos_overrides_in_a_parameter_file_switch_a_topic_back_to_best_effort(
    start_node, ros, tmp_path, config_dir
):
    """``qos_overrides./motor/joint_state.publisher`` in the driver's file: offered best effort.

    (The graph does not carry the history depth, which the file also sets.)
    """
    overrides = tmp_path / "qos.yaml"
    overrides.write_text(
        "/**:\n  ros__parameters:\n    qos_overrides:\n      /motor/joint_state:\n"
        "        publisher:\n          reliability: best_effort\n          depth: 3\n",
        encoding="utf-8",
    )
    start_node("driver", params_file=overrides)
    ros.wait_for_publishers("motor/joint_state")
    (offered,) = ros.node.get_publishers_info_by_topic("motor/joint_state")
    assert offered.qos_profile.reliability.name == "BEST_EFFORT"
    sensor = ros.record(get_message("sensor_msgs/msg/JointState"), "motor/joint_state")
    ros.wait_for_messages(sensor, MESSAGES, TIMEOUT_S, "motor/joint_state, best effort")
    # The other publishers keep theirs.
    (diagnostics,) = ros.node.get_publishers_info_by_topic("/diagnostics")
    assert diagnostics.qos_profile.reliability.name == "RELIABLE"
