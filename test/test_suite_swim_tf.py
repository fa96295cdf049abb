"""The swimming simulator's tf, received from the running node (driver + simulator processes).

Where tf2_msgs is installed (every ROS 2 install; the wheels have none), the simulator broadcasts
odom -> base_link on /tf with each fish/odom message and base_link -> tail_mechanism on
/tf_static; the tests check both against the odometry and the fish's parameters. Where it is not,
the simulator runs without tf and says so; that is checked everywhere, with tf2_msgs hidden from
the simulator's process where it is installed.
"""

from __future__ import annotations

import importlib.util
import math
import os

import pytest
import yaml
from nav_msgs.msg import Odometry
from rclpy.qos import DurabilityPolicy, QoSProfile

from fishtail_common.interface import (
    BODY_FRAME,
    FISH_ODOM,
    MOTOR_JOINT_STATE,
    ODOM_FRAME,
    TAIL_FRAME,
    TF,
    TF_STATIC,
)
from fishtail_plant.values import read_fish_values
from fishtail_swim.frames import TAIL_IN_BODY_ROTATION, FrameTransform

SIM_MODULE = "fishtail_swim.nodes.sim_node"
HAVE_TF2_MSGS = importlib.util.find_spec("tf2_msgs") is not None
NO_TF2_MSGS = "tf2_msgs is not installed (the ROS 2 wheels have none; a ROS 2 install does)"
#: Not config/fish.yaml's 0.05 m, so that the static transform must come from the parameter.
TAIL_ORIGIN_OFFSET_M = 0.07
SPEED_RAD_S = 12.0
#: Odometry messages to compare (about 1.5 s at the driver's 200 Hz).
SAMPLES = 300
STREAM_TIMEOUT_S = 40.0


@pytest.fixture
def fish_parameters(tmp_path, config_dir):
    """Mechanism 1 and config/fish.yaml in one parameter file, O moved to TAIL_ORIGIN_OFFSET_M."""
    document = yaml.safe_load((config_dir / "oscillatory.yaml").read_text(encoding="utf-8"))
    parameters = document["/**"]["ros__parameters"]
    parameters.update(read_fish_values(config_dir / "fish.yaml"))
    parameters["tail_origin_offset_m"] = TAIL_ORIGIN_OFFSET_M
    path = tmp_path / "fish.yaml"
    path.write_text(yaml.safe_dump(document), encoding="utf-8")
    return path


def transform_of(message) -> FrameTransform:
    """A geometry_msgs/TransformStamped as plain numbers."""
    t, r = message.transform.translation, message.transform.rotation
    return FrameTransform(
        message.header.frame_id, message.child_frame_id, (t.x, t.y, t.z), (r.x, r.y, r.z, r.w)
    )


def wait_for_swim_values(ros, diagnostics):
    """The simulator's diagnostic values, once its first status has arrived."""
    ros.spin_until(
        lambda: ros.statuses(diagnostics, "swim"), STREAM_TIMEOUT_S, "the simulator's diagnostics"
    )
    return ros.values(ros.statuses(diagnostics, "swim")[-1][2])


@pytest.mark.skipif(not HAVE_TF2_MSGS, reason=NO_TF2_MSGS)
def test_simulator_puts_the_fish_and_its_tail_on_tf(start_node, ros, fish_parameters):
    """/tf has the odometry's pose at its stamp; /tf_static has O at -l_O, tail x = body -x."""
    from tf2_msgs.msg import TFMessage

    odom = ros.record(Odometry, FISH_ODOM.name)
    # Reliable, as tf2's listeners subscribe; deep enough that a busy test process drops nothing.
    dynamic = ros.record(TFMessage, TF.name, QoSProfile(depth=1000))
    diagnostics = ros.record_diagnostics()
    start_node("driver", params={"cmd_timeout_sec": 0.0})
    start_node(SIM_MODULE, name="swim", params_file=fish_parameters)
    ros.wait_for_publishers(TF.name)
    ros.wait_for_subscribers(MOTOR_JOINT_STATE.name)
    ros.command_speed(SPEED_RAD_S)
    # Until the fish has moved: on a loaded machine the command can reach the driver after the
    # first samples, and a fish still at the origin proves nothing about the transforms.
    ros.spin_until(
        lambda: (
            len(odom) >= SAMPLES and len(dynamic) >= SAMPLES and odom[-1].pose.pose.position.x > 0.0
        ),
        STREAM_TIMEOUT_S,
        f"{SAMPLES} messages on {FISH_ODOM.name} and {TF.name} (so far {len(odom)}, "
        f"{len(dynamic)}) with the fish moved forward",
    )
    # Subscribed only now, long after the simulator sent it: transient local keeps it for us.
    static = ros.record(
        TFMessage, TF_STATIC.name, QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    )
    ros.wait_for_messages(static, 1, STREAM_TIMEOUT_S, TF_STATIC.name)

    # odom -> base_link: one transform per message, the odometry's pose at the odometry's stamp.
    poses = {ros.stamp_ns(message): message.pose.pose for message in odom}
    stamps = []
    matched = 0
    for message in dynamic:
        (transform,) = message.transforms
        assert (transform.header.frame_id, transform.child_frame_id) == (ODOM_FRAME, BODY_FRAME)
        stamp = ros.stamp_ns(transform)
        stamps.append(stamp)
        pose = poses.get(stamp)
        if pose is None:
            continue  # an odometry message the best-effort probe lost
        matched += 1
        t, r = transform.transform.translation, transform.transform.rotation
        assert (t.x, t.y, t.z) == (pose.position.x, pose.position.y, 0.0)
        assert (r.x, r.y, r.z, r.w) == (
            pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w,
        )  # fmt: skip
    assert stamps == sorted(set(stamps)), "the /tf stamps must increase"
    assert matched >= 0.9 * len(odom), (matched, len(odom))
    body = transform_of(dynamic[-1].transforms[0])
    assert body.translation[0] > 0.0  # it swims forward from the origin

    # base_link -> tail_mechanism: O on the body axis at -l_O, tail x back, y left, z down.
    (latched,) = static[0].transforms
    tail = transform_of(latched)
    assert (tail.parent, tail.child) == (BODY_FRAME, TAIL_FRAME)
    assert tail.translation == pytest.approx((-TAIL_ORIGIN_OFFSET_M, 0.0, 0.0), abs=1e-15)
    assert tail.rotation == TAIL_IN_BODY_ROTATION
    assert tail.apply((1.0, 0.0, 0.0)) == pytest.approx((-TAIL_ORIGIN_OFFSET_M - 1.0, 0.0, 0.0))
    # Chained, as RViz draws tail/markers: O is l_O behind the centre of mass along the heading.
    x, y, _ = body.translation
    psi = 2.0 * math.atan2(body.rotation[2], body.rotation[3])
    o_world = body.apply(tail.apply((0.0, 0.0, 0.0)))
    expected = (x - TAIL_ORIGIN_OFFSET_M * math.cos(psi), y - TAIL_ORIGIN_OFFSET_M * math.sin(psi))
    assert o_world[:2] == pytest.approx(expected, abs=1e-12)

    assert wait_for_swim_values(ros, diagnostics)["tf"] == "on"


@pytest.mark.skipif(not HAVE_TF2_MSGS, reason=NO_TF2_MSGS)
def test_the_frames_are_parameters_and_the_odometry_says_it_is_exact(
    start_node, ros, fish_parameters
):
    """odom_frame_id / base_frame_id name every frame the fish uses: odometry, tf, markers."""
    from tf2_msgs.msg import TFMessage
    from visualization_msgs.msg import MarkerArray

    from fishtail_swim.nodes.sim_node import EXACT_VARIANCE

    frames = {"odom_frame_id": "fish1/odom", "base_frame_id": "fish1/base_link"}
    odom = ros.record(Odometry, FISH_ODOM.name)
    dynamic = ros.record(TFMessage, TF.name, QoSProfile(depth=100))
    markers = ros.record(MarkerArray, "fish/markers", 10)
    start_node("driver", params={"cmd_timeout_sec": 0.0})
    start_node(SIM_MODULE, name="swim", params_file=fish_parameters, params=frames)
    ros.wait_for_subscribers(MOTOR_JOINT_STATE.name)
    ros.command_speed(SPEED_RAD_S)
    ros.spin_until(
        lambda: len(odom) >= 10 and len(dynamic) >= 10 and len(markers) >= 1,
        STREAM_TIMEOUT_S,
        "odometry, tf and markers",
    )
    static = ros.record(
        TFMessage, TF_STATIC.name, QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    )
    ros.wait_for_messages(static, 1, STREAM_TIMEOUT_S, TF_STATIC.name)
    message = odom[-1]
    assert (message.header.frame_id, message.child_frame_id) == ("fish1/odom", "fish1/base_link")
    for covariance in (message.pose.covariance, message.twist.covariance):
        assert list(covariance) == [EXACT_VARIANCE if i % 7 == 0 else 0.0 for i in range(36)]
    (transform,) = dynamic[-1].transforms
    assert (transform.header.frame_id, transform.child_frame_id) == (
        "fish1/odom", "fish1/base_link"
    )  # fmt: skip
    assert static[0].transforms[0].header.frame_id == "fish1/base_link"
    assert {marker.header.frame_id for marker in markers[-1].markers} == {"fish1/odom"}


@pytest.mark.skipif(not HAVE_TF2_MSGS, reason=NO_TF2_MSGS)
def test_publish_tf_false_leaves_tf_alone(start_node, ros, fish_parameters):
    diagnostics = ros.record_diagnostics()
    start_node(SIM_MODULE, name="swim", params_file=fish_parameters, params={"publish_tf": False})
    values = wait_for_swim_values(ros, diagnostics)
    assert values["tf"] == "off: publish_tf is false"
    # The node's endpoints were discovered with its diagnostics publisher.
    assert ros.node.count_publishers(TF.name) == 0
    assert ros.node.count_publishers(TF_STATIC.name) == 0


def test_without_tf2_msgs_the_simulator_runs_and_says_it_has_no_tf(
    start_node, ros, fish_parameters, tmp_path, monkeypatch
):
    if HAVE_TF2_MSGS:
        # First on the simulator's path: a tf2_msgs whose import fails as a missing one does.
        hidden = tmp_path / "no_tf2_msgs"
        (hidden / "tf2_msgs").mkdir(parents=True)
        (hidden / "tf2_msgs" / "__init__.py").write_text(
            "raise ModuleNotFoundError(\"No module named 'tf2_msgs'\", name='tf2_msgs')\n",
            encoding="utf-8",
        )
        monkeypatch.setenv(
            "PYTHONPATH", os.pathsep.join(filter(None, [str(hidden), os.environ.get("PYTHONPATH")]))
        )
    diagnostics = ros.record_diagnostics()
    process = start_node(SIM_MODULE, name="swim", params_file=fish_parameters)
    values = wait_for_swim_values(ros, diagnostics)
    assert values["tf"] == "off: tf2_msgs is not installed"
    assert "tf off: tf2_msgs is not installed" in process.stderr()
