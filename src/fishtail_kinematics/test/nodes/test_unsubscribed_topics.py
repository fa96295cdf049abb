"""The kinematics node builds no message for a topic nobody subscribes to, and resumes for one.

The node runs in this process (own context and domain); the test feeds it motor/joint_state by
calling its callback and counts what its publishers are handed.
"""

from __future__ import annotations

import pytest

from fishtail_common.pytest_fixtures import ros_domain

pytestmark = pytest.mark.filterwarnings("ignore:module 'sre_:DeprecationWarning")
SAMPLES = 50


@pytest.fixture
def kinematics(request):
    """A KinematicsNode and a helper node, on an executor of their own context and ROS domain."""
    request.getfixturevalue(ros_domain.__name__)
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.signals import SignalHandlerOptions

    from fishtail_kinematics.nodes.kinematics_node import KinematicsNode

    context = Context()
    rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
    node = KinematicsNode(context=context)
    helper = rclpy.create_node("helper", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    executor.add_node(helper)
    handed = {"tip": 0, "joints": 0, "state": 0}
    for name, publisher in (
        ("tip", node.tip_publisher),
        ("joints", node.joint_publisher),
        ("state", node.state_publisher),
    ):
        publish = publisher.publish

        def counting(message, name=name, publish=publish):
            handed[name] += 1
            publish(message)

        publisher.publish = counting
    try:
        yield node, helper, executor, handed
    finally:
        executor.shutdown()
        helper.destroy_node()
        node.destroy_node()
        context.try_shutdown()


def feed(node, count: int, first: int = 0) -> None:
    """Hand the node ``count`` carrier samples, 1 ms apart, turning at 4 rad/s."""
    from sensor_msgs.msg import JointState

    for k in range(first, first + count):
        message = JointState(name=["carrier_joint"], position=[0.004 * k], velocity=[4.0])
        stamp_ns = 1_000_000_000 + k * 1_000_000
        message.header.stamp.sec, message.header.stamp.nanosec = divmod(stamp_ns, 1_000_000_000)
        node._on_motor_state(message)


def spin_until(executor, predicate, timeout_s: float = 10.0) -> None:
    """Spin until ``predicate()`` holds (fails after ``timeout_s``)."""
    import time

    deadline = time.monotonic() + timeout_s
    while not predicate():
        assert time.monotonic() < deadline, "timed out"
        executor.spin_once(timeout_sec=0.05)


def test_no_subscriber_no_tip_then_a_late_subscriber_receives(kinematics):
    from geometry_msgs.msg import PointStamped

    from fishtail_common.interface import TAIL_TIP
    from fishtail_common.ros import subscriber_qos

    node, helper, executor, handed = kinematics
    executor.spin_once(timeout_sec=0.1)
    feed(node, SAMPLES)
    assert node.received == SAMPLES and node.drops.dropped == 0
    assert handed == {"tip": 0, "joints": 0, "state": 0}  # nobody listens: nothing built

    received = []
    helper.create_subscription(
        PointStamped, TAIL_TIP.name, received.append, subscriber_qos(TAIL_TIP)
    )
    spin_until(executor, lambda: node.tip_publisher.listened)
    feed(node, SAMPLES, first=SAMPLES)
    assert handed == {"tip": SAMPLES, "joints": 0, "state": 0}
    spin_until(executor, lambda: len(received) > 0)
    # It gets the newest of what was built after it subscribed (its queue keeps the last few).
    stamps_ms = [message.header.stamp.nanosec // 1_000_000 for message in received]
    assert SAMPLES <= min(stamps_ms) and max(stamps_ms) < 2 * SAMPLES


def test_a_latched_topic_is_always_built(kinematics):
    from fishtail_common.interface import TAIL_SYMMETRY
    from fishtail_common.ros import ListenedPublisher
    from fishtail_msgs.msg import SymmetryReport

    node, _, _, _ = kinematics
    latched = ListenedPublisher(node, SymmetryReport, TAIL_SYMMETRY)
    assert latched.listened and latched.subscribers == 0
