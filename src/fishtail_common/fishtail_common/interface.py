"""The suite's interface: topics, QoS kinds, joint and frame names, diagnostic levels, nodes.

Plain Python (no rclpy), so that the recorder, the offline analysis and the tests name topics the
way the nodes do. Topic names are relative (a namespace moves the whole suite) except
``/diagnostics``, ``/tf`` and ``/tf_static``, whose absolute names are ROS conventions;
:mod:`fishtail_common.ros` turns a :class:`QosKind` into the rclpy profiles of its publishers and
subscribers.

>>> TAIL_STATE.name, TAIL_STATE.type
('tail/state', 'fishtail_msgs/msg/TailState')
>>> [topic.name for topic in SUITE_TOPICS if topic.qos is QosKind.STATE][:3]
['motor/joint_state', 'pivot/joint_state', 'tail/joint_states']
"""

from __future__ import annotations

import dataclasses
import enum
from collections.abc import Mapping


class Level(enum.IntEnum):
    """diagnostic_msgs/DiagnosticStatus levels, for modules that do not import ROS messages."""

    OK = 0
    WARN = 1
    ERROR = 2
    STALE = 3


@dataclasses.dataclass(frozen=True)
class Status:
    """One diagnostic status of a node, as plain values (fishtail_common.ros publishes it)."""

    name: str  # what it is about; published as "<node's full name>: <name>"
    level: int  # a Level
    message: str
    values: Mapping[str, str] = dataclasses.field(default_factory=dict)
    hardware_id: str = ""


class QosKind(enum.Enum):
    """How a topic is delivered; each kind is one rclpy profile (``ros.qos_profile``)."""

    #: High-rate state (REP 2003): published reliable, volatile, depth 10 (the system default), so
    #: that a subscriber with default QoS receives it; the suite's own subscribers take it best
    #: effort, depth 5 (sensor data), which never waits for a lost sample.
    STATE = "state"
    #: Commands and diagnostics: reliable, volatile, depth 10.
    RELIABLE = "reliable"
    #: One message per event that a late subscriber still wants: reliable, transient local,
    #: depth 1 (the latest symmetry report).
    LATCHED = "latched"


@dataclasses.dataclass(frozen=True)
class Topic:
    """One topic of the suite."""

    name: str
    type: str  # rosbag2/rosidl form, package/msg/Name
    qos: QosKind
    description: str


MOTOR_CMD_SPEED = Topic(
    "motor/cmd_speed", "std_msgs/msg/Float64", QosKind.RELIABLE, "carrier speed command, rad/s >= 0"
)
MOTOR_CMD_PROFILE = Topic(
    "motor/cmd_profile",
    "fishtail_msgs/msg/CarrierSpeedProfile",
    QosKind.RELIABLE,
    "carrier speed command with a once-per-revolution modulation (mean rad/s, depth, phase rad)",
)
MOTOR_JOINT_STATE = Topic(
    "motor/joint_state",
    "sensor_msgs/msg/JointState",
    QosKind.STATE,
    "carrier joint: unwrapped angle rad, velocity rad/s, stamped when the encoder was read",
)
PIVOT_CMD_POSITION = Topic(
    "pivot/cmd_position",
    "std_msgs/msg/Float64",
    QosKind.RELIABLE,
    "pivot actuator command: shift of the tail pivot S along the body axis from its design, m",
)
PIVOT_JOINT_STATE = Topic(
    "pivot/joint_state",
    "sensor_msgs/msg/JointState",
    QosKind.STATE,
    "pivot actuator: shift of S m (+ towards the tail), its rate m/s",
)
TAIL_JOINT_STATES = Topic(
    "tail/joint_states", "sensor_msgs/msg/JointState", QosKind.STATE, "theta1..theta5, rad"
)
TAIL_TIP = Topic(
    "tail/tip", "geometry_msgs/msg/PointStamped", QosKind.STATE, "tail tip in the tail frame"
)
TAIL_STATE = Topic(
    "tail/state", "fishtail_msgs/msg/TailState", QosKind.STATE, "everything the engine solved"
)
TAIL_SYMMETRY = Topic(
    "tail/symmetry", "fishtail_msgs/msg/SymmetryReport", QosKind.LATCHED, "one report per beat"
)
TAIL_MARKERS = Topic(
    "tail/markers",
    "visualization_msgs/msg/MarkerArray",
    QosKind.RELIABLE,
    "ring, planet, links, joints and tip trail for RViz",
)
FISH_ODOM = Topic(
    "fish/odom",
    "nav_msgs/msg/Odometry",
    QosKind.STATE,
    "simulated fish: pose X, Y, yaw in world, twist u, v, r in base_link, per carrier sample",
)
FISH_MARKERS = Topic(
    "fish/markers",
    "visualization_msgs/msg/MarkerArray",
    QosKind.RELIABLE,
    "simulated fish's body outline, path and tail in world for RViz",
)
FISH_SWIMMING = Topic(
    "fish/swimming",
    "fishtail_msgs/msg/SwimFigures",
    QosKind.LATCHED,
    "simulated fish's swimming figures, one message per beat",
)
#: A velocity command for the fish (forward m/s in linear.x, yaw rate rad/s in angular.z), as any
#: mobile base takes it; the pilot turns it into carrier and pivot commands.
CMD_VEL = Topic(
    "cmd_vel",
    "geometry_msgs/msg/Twist",
    QosKind.RELIABLE,
    "velocity command for the fish: linear.x m/s, angular.z rad/s in base_link",
)
#: A goal for the simulated fish, from whoever sets one (RViz's 2D Goal Pose tool publishes here).
GOAL_POSE = Topic(
    "goal_pose",
    "geometry_msgs/msg/PoseStamped",
    QosKind.RELIABLE,
    "a goal for the fish in world: the pilot swims there (the live view shows it)",
)
DIAGNOSTICS = Topic(
    "/diagnostics", "diagnostic_msgs/msg/DiagnosticArray", QosKind.RELIABLE, "every node's health"
)
#: tf2's topics, with the reliability and durability of tf2's broadcasters (a static transform is
#: sent once and kept for late subscribers). Absolute, as every tf2 user expects them: a namespaced
#: simulator still broadcasts there, unless started with ``-r /tf:=tf -r /tf_static:=tf_static``.
TF = Topic(
    "/tf",
    "tf2_msgs/msg/TFMessage",
    QosKind.RELIABLE,
    "transforms that move: the simulated fish's world -> base_link, per carrier sample",
)
TF_STATIC = Topic(
    "/tf_static",
    "tf2_msgs/msg/TFMessage",
    QosKind.LATCHED,
    "fixed transforms: base_link -> tail_mechanism of the simulated fish",
)

#: Every topic the suite publishes or commands, in data-flow order (what the recorder records).
#: /tf and /tf_static are not among them: tf2_msgs is not always installed (no wheel of it), and
#: the transforms follow from fish/odom and the fish's parameters.
SUITE_TOPICS: tuple[Topic, ...] = (
    CMD_VEL,
    GOAL_POSE,
    MOTOR_CMD_SPEED,
    MOTOR_CMD_PROFILE,
    PIVOT_CMD_POSITION,
    MOTOR_JOINT_STATE,
    PIVOT_JOINT_STATE,
    TAIL_JOINT_STATES,
    TAIL_TIP,
    TAIL_STATE,
    TAIL_SYMMETRY,
    FISH_ODOM,
    FISH_SWIMMING,
    DIAGNOSTICS,
)

#: The joint the driver publishes and the kinematics node follows.
CARRIER_JOINT = "carrier_joint"
#: The pivot actuator's prismatic joint (the shift of S along the body axis).
PIVOT_JOINT = "pivot_joint"
#: The frame of the tail mechanism: origin at the ring-gear centre O, x along the stroke.
TAIL_FRAME = "tail_mechanism"
#: The simulated fish's odometry frame (REP 105: continuous, drifting; ``map`` would sit above
#: it for global goals): x, y horizontal, z up. The simulator's ``odom_frame_id`` default.
ODOM_FRAME = "odom"
#: The simulated fish's body frame (REP 103): origin at its centre of mass, x forward, y left.
BODY_FRAME = "base_link"
#: fishtail_msgs/TailState.mechanism of each mechanism (its MECHANISM_* constants).
MECHANISM_CODES = {"oscillatory": 1, "undulatory": 2}


@dataclasses.dataclass(frozen=True)
class SuiteNode:
    """One node of the suite: how ``ros2 run``/launch and ``fishtail-run`` start it."""

    name: str  # the node's name (and fishtail-run's label)
    package: str
    executable: str  # installed under lib/<package>/ for ros2 run and launch_ros
    module: str  # python -m <module> starts it without the ament index
    #: It declares the fish's parameters (the fin, the body): it gets the fish's parameter file.
    reads_fish_file: bool = False


#: The suite, in start-up order (data flows from the first to the last).
SUITE_NODES: tuple[SuiteNode, ...] = (
    SuiteNode("driver", "fishtail_driver", "driver", "fishtail_driver.node"),
    SuiteNode(
        "kinematics", "fishtail_kinematics", "node", "fishtail_kinematics.nodes.kinematics_node"
    ),
    SuiteNode(
        "monitor",
        "fishtail_kinematics",
        "monitor",
        "fishtail_kinematics.nodes.monitor_node",
        reads_fish_file=True,  # the fin of its swimming figures
    ),
)
#: The swimming simulator: not in the default suite (``fishtail-run --swim`` adds it).
SWIM_NODE = SuiteNode(
    "swim", "fishtail_swim", "sim", "fishtail_swim.nodes.sim_node", reads_fish_file=True
)
#: The pilot (cmd_vel and goal_pose in, carrier and pivot commands out): not in the default suite
#: (``fishtail-run --pilot`` adds it, with the simulator).
PILOT_NODE = SuiteNode(
    "pilot", "fishtail_swim", "pilot", "fishtail_pilot.node", reads_fish_file=True
)
#: The live view (a Rerun viewer's data source): not in the default suite (``fishtail-run --view``
#: adds it).
VIEW_NODE = SuiteNode("view", "fishtail_bringup", "fishtail-view", "fishtail_bringup.view")
