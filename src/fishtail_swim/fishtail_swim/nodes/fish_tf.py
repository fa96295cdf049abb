"""tf of the simulator: ``odom`` -> ``base_link`` on ``/tf``, ``base_link`` -> ``tail_mechanism``.

With the body's pose in tf, RViz (fixed frame ``odom``) draws the kinematics node's
``tail/markers`` on the swimming fish. The transforms are :mod:`fishtail_swim.frames`', sent on
tf2's own topics with its QoS; without tf2_msgs (not in the ROS 2 wheels) the simulator runs
without tf and says so. Topics and stamps: docs/swimming-dynamics.md ("The simulator node", "tf").
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from geometry_msgs.msg import Pose, TransformStamped
from rclpy.node import Node

from fishtail_common.interface import BODY_FRAME, ODOM_FRAME, TF, TF_STATIC
from fishtail_common.parameters import ParameterSpec
from fishtail_common.ros import ListenedPublisher, publisher_qos
from fishtail_swim.frames import FrameTransform, body_in_odom, tail_in_body

if TYPE_CHECKING:
    from builtin_interfaces.msg import Time

PUBLISH_TF = ParameterSpec(
    "publish_tf",
    True,
    f"broadcast odom -> base_link on {TF.name} per sample and base_link -> tail_mechanism on "
    f"{TF_STATIC.name}",
    read_only=True,
)
#: The fish's frames (REP 105), for several fish or other names: fish1/odom, fish1/base_link.
ODOM_FRAME_ID = ParameterSpec(
    "odom_frame_id",
    ODOM_FRAME,
    "odometry frame: fish/odom's header, the parent on /tf, the markers' frame, the goals' frame",
    non_empty=True,
    read_only=True,
)
BASE_FRAME_ID = ParameterSpec(
    "base_frame_id",
    BODY_FRAME,
    "the fish's body frame: fish/odom's child frame, the parent of tail_mechanism",
    non_empty=True,
    read_only=True,
)
FRAME_PARAMETERS = (ODOM_FRAME_ID, BASE_FRAME_ID)


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

    def __init__(
        self,
        node: Node,
        message_type: type[Any],
        tail_origin_offset_m: float,
        odom_frame: str,
        body_frame: str,
    ) -> None:
        """Create both publishers and send the static transform (frames: the node's names)."""
        self.published = 0
        self.publisher = ListenedPublisher(node, message_type, TF)
        self.static_publisher = node.create_publisher(
            message_type, TF_STATIC.name, publisher_qos(TF_STATIC)
        )
        stamp = node.get_clock().now().to_msg()
        self.static_publisher.publish(
            message_type(
                transforms=[
                    transform_message(tail_in_body(tail_origin_offset_m, body_frame), stamp)
                ]
            )
        )
        # One message, refilled per sample (as the node's odometry message is).
        self._body = transform_message(body_in_odom(0.0, 0.0, 0.0, odom_frame, body_frame), stamp)
        self._message = message_type(transforms=[self._body])

    def publish(self, stamp: Time, pose: Pose) -> None:
        """Broadcast ``odom`` -> ``base_link`` at ``stamp``, the body at ``pose`` (odometry's)."""
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
