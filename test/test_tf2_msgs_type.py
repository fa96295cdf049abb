"""tf2_msgs/msg/TFMessage as this environment puts it on the wire: the real type and type hash.

RViz and tf2 on a ROS 2 machine read the simulator's /tf only if the type name and the RIHS01 type
hash match their own tf2_msgs. On the venv set-up the package is the one make setup builds from
tools/interfaces/tf2_msgs; on a ROS 2 install it is the system's. Either must give ROS 2 Jazzy's
hash (that of ros2/geometry2's tf2_msgs, built against Jazzy's geometry_msgs).
"""

from __future__ import annotations

import importlib.util

import pytest

HAVE_TF2_MSGS = importlib.util.find_spec("tf2_msgs") is not None
NO_TF2_MSGS = "tf2_msgs is not installed (the ROS 2 wheels have none; make setup builds it)"

TYPE_NAME = "tf2_msgs/msg/TFMessage"
#: ROS 2 Jazzy's tf2_msgs/msg/TFMessage (depends only on the field and the nested geometry_msgs,
#: std_msgs and builtin_interfaces types).
JAZZY_TYPE_HASH = "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087"


@pytest.mark.skipif(not HAVE_TF2_MSGS, reason=NO_TF2_MSGS)
def test_tf_message_has_the_jazzy_type_name_and_hash(ros):
    from tf2_msgs.msg import TFMessage

    topic = "/tf2_msgs_type_check"
    ros.node.create_publisher(TFMessage, topic, 1)
    (info,) = ros.node.get_publishers_info_by_topic(topic)
    assert info.topic_type == TYPE_NAME
    assert str(info.topic_type_hash) == JAZZY_TYPE_HASH
