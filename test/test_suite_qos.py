"""Every state topic reaches a subscriber made the usual way and a sensor-data one (REP 2003).

Driver (with its simulated pivot actuator, so that pivot/joint_state flows), kinematics node and
simulator as processes. For each state topic of the interface the probe holds two
subscriptions: ``QoSProfile(depth=10)`` (reliable, what ``create_subscription(..., 10)`` asks
for, and nav2's and robot_localization's defaults) and sensor data (best effort, what the suite's
own nodes ask for). Both must receive. Before, the state topics were published best effort, and
the default subscriber received nothing from any of them.
"""

from __future__ import annotations

from rclpy.qos import QoSProfile
from rosidl_runtime_py.utilities import get_message

from fishtail_common.interface import SUITE_TOPICS, QosKind

SIM_MODULE = "fishtail_swim.nodes.sim_node"
STATE_TOPICS = [topic for topic in SUITE_TOPICS if topic.qos is QosKind.STATE]
MESSAGES = 5
TIMEOUT_S = 60.0


def test_a_default_and_a_sensor_data_subscriber_both_receive_every_state_topic(
    start_node, ros, fish_and_tail
):
    assert {topic.name for topic in STATE_TOPICS} >= {
        "motor/joint_state", "pivot/joint_state", "tail/joint_states", "tail/tip", "tail/state",
        "fish/odom",
    }  # fmt: skip
    start_node("driver", params_file=fish_and_tail, params={"pivot_actuator": "sim"})
    start_node("kinematics", params_file=fish_and_tail)
    start_node(SIM_MODULE, name="swim", params_file=fish_and_tail)
    recorders = {}
    for topic in STATE_TOPICS:
        kind = get_message(topic.type)
        recorders[topic.name, "default"] = ros.record(kind, topic.name, QoSProfile(depth=10))
        recorders[topic.name, "sensor data"] = ros.record(kind, topic.name)
    ros.wait_for_subscribers("motor/cmd_speed")
    ros.command_speed(4.0)

    def missing() -> list[tuple[str, str]]:
        return [key for key, recorder in recorders.items() if len(recorder) < MESSAGES]

    try:
        ros.spin_until(lambda: not missing(), TIMEOUT_S, "every state topic on both subscriptions")
    except TimeoutError:
        raise AssertionError(f"fewer than {MESSAGES} messages on {missing()}") from None
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
