"""tf of the simulator: ``world`` -> ``base_link`` on ``/tf``, ``base_link`` -> ``tail_mechanism``.

With the body's pose in tf, RViz (fixed frame ``world``) draws the kinematics node's
``tail/markers`` on the swimming fish. The transforms are :mod:`fishtail_swim.frames`', sent on
tf2's own topics with its QoS; without tf2_msgs (not in the ROS 2 wheels) the simulator runs
without tf and says so. Topics and stamps: docs/swimming-dynamics.md ("The simulator node", "tf").
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from geometry_msgs.msg import Pose, TransformStamped
from rclpy.node import Node

from fishtail_common.interface import TF, TF_STATIC
from fishtail_common.parameters import ParameterSpec
from fishtail_common.ros import ListenedPublisher, publisher_qos
from fishtail_swim.frames import FrameTransform, body_in_world, tail_in_body

if TYPE_CHECKING:
    from builtin_interfaces.msg import Time

PUBLISH_TF = ParameterSpec(
    "publish_tf",
    True,
    f"broadcast world -> base_link on {TF.name} per sample and base_link -> tail_mechanism on "
    f"{TF_STATIC.name}",
    read_only=True,
)


def tf_message_type() -> type[Any] | None:
    """tf2_msgs/msg/TFMessage, or None where tf2_msgs is not installed."""
    try:
        message_type: type[Any] = importlib.import_module("tf2_msgs.msg").TFMessage
        return message_type
    except ModuleNotFoundError:
        return None


def transform_message(transform: FrameTransform, stamp: Time) -> TransformStamped:
    """The geometry_msgs/TransformStamped of ``transform`` at ``stamp``."""
    message = TransformStamped()
    message.header.stamp = stamp
    message.header.frame_id = transform.parent
    message.child_frame_id = transform.child
    translation, rotation = message.transform.translation, message.transform.rotation
    translation.x, translation.y, translation.z = transform.translation
    rotation.x, rotation.y, rotation.z, rotation.w = transform.rotation
    return message


class FishTfBroadcaster:
    """Publishers of ``/tf`` and ``/tf_static`` for one simulated fish."""

    def __init__(self, node: Node, message_type: type[Any], tail_origin_offset_m: float) -> None:
        """Create both publishers and send the static transform."""
        self.published = 0
        self.publisher = ListenedPublisher(node, message_type, TF)
        self.static_publisher = node.create_publisher(
            message_type, TF_STATIC.name, publisher_qos(TF_STATIC)
        )
        stamp = node.get_clock().now().to_msg()
        self.static_publisher.publish(
            message_type(transforms=[transform_message(tail_in_body(tail_origin_offset_m), stamp)])
        )
        # One message, refilled per sample (as the node's odometry message is).
        self._body = transform_message(body_in_world(0.0, 0.0, 0.0), stamp)
        self._message = message_type(transforms=[self._body])

    def publish(self, stamp: Time, pose: Pose) -> None:
        """Broadcast ``world`` -> ``base_link`` at ``stamp``, the body at ``pose`` (odometry's)."""
        body = self._body
        body.header.stamp = stamp
        translation, rotation = body.transform.translation, body.transform.rotation
        translation.x, translation.y = pose.position.x, pose.position.y
        orientation = pose.orientation
        rotation.x, rotation.y, rotation.z, rotation.w = (
            orientation.x, orientation.y, orientation.z, orientation.w,
        )  # fmt: skip
        self.publisher.publish(self._message)
        self.published += 1
