"""Launch the fishtail suite (driver, kinematics, monitor) on a full ROS 2 Jazzy install.

    ros2 launch fishtail_bringup fishtail.launch.py
    ros2 launch fishtail_bringup fishtail.launch.py mechanism:=undulatory namespace:=fish1
    ros2 launch fishtail_bringup fishtail.launch.py params_file:=/path/to/my_tail.yaml
    ros2 launch fishtail_bringup fishtail.launch.py swim:=true   # and the swimming simulator
    ros2 launch fishtail_bringup fishtail.launch.py view:=true   # and the live view (Rerun)
    ros2 launch fishtail_bringup fishtail.launch.py motor_model:=dc motor_load:=water_swimming
    ros2 launch fishtail_bringup fishtail.launch.py one_process:=true  # the nodes in one process
    ros2 launch fishtail_bringup fishtail.launch.py pilot:=true  # simulator and pilot (cmd_vel)
    ros2 launch fishtail_bringup fishtail.launch.py pilot:=true steering:=pivot

It does not command the motor: publish the carrier speed yourself (the driver's watchdog stops
the motor when commands stop), or, with ``pilot:=true``, a ``cmd_vel`` or a ``goal_pose``:
    ros2 topic pub -r 10 motor/cmd_speed std_msgs/msg/Float64 "{data: 4.0}"
Machines without ros2 launch use ``fishtail-run``. README.md ("With a system ROS 2 Jazzy").
"""

from launch.actions import DeclareLaunchArgument
from launch.conditions import IfCondition
from launch.substitution import Substitution
from launch.substitutions import (
    AndSubstitution,
    Command,
    EqualsSubstitution,
    IfElseSubstitution,
    LaunchConfiguration,
    NotSubstitution,
    OrSubstitution,
    PathJoinSubstitution,
)
from launch.utilities import normalize_to_list_of_substitutions, perform_substitutions
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue
from launch_ros.substitutions import FindPackagePrefix, FindPackageShare

from fishtail_bringup.own_parameters import write_own_parameters
from fishtail_common.interface import PILOT_NODE, SUITE_NODES, SWIM_NODE, VIEW_NODE
from fishtail_driver.parameters import DC_MOTOR_ENCODER, SPECS
from fishtail_pilot.steering import PIVOT_STEERING, STEERING
from fishtail_plant.linkage_load.surroundings import NO_LOAD, SURROUNDINGS
from launch import LaunchDescription


def dc_motor_encoder(motor_model):
    """The encoder parameters of ``motor_model``: the DC motor's with dc, else the defaults.

    Given before the params files, so that a file that sets them wins.
    """
    is_dc = EqualsSubstitution(motor_model, "dc")
    return {
        name: IfElseSubstitution(is_dc, repr(value), repr(SPECS[name].default))
        for name, value in DC_MOTOR_ENCODER.items()
    }


class OwnParameterFile(Substitution):
    """A parameter file of ``node_name``'s own with ``values`` (launch arguments): its path.

    Given last, it wins over ``params_file`` whatever its sections say; a parameter dict would
    join the ``/**`` section and lose to a ``driver:`` section there (own_parameters.py).
    """

    def __init__(self, node_name, values):
        """``values``: parameter name to substitutions, evaluated when the launch runs."""
        super().__init__()
        self.node_name = node_name
        self.values = {name: normalize_to_list_of_substitutions(v) for name, v in values.items()}

    def describe(self):
        """For launch's messages."""
        return f"OwnParameterFile({self.node_name!r}, {sorted(self.values)})"

    def perform(self, context):
        """Write the file; its path."""
        values = {name: perform_substitutions(context, v) for name, v in self.values.items()}
        return str(write_own_parameters(self.node_name, values))


def one_process_arguments(nodes, parameters):
    """``fishtail-one-process``'s command line: each node's name and its own ROS arguments.

    ``parameters`` maps a node to its list of parameter files and ``{name: value}`` dicts, in the
    order a Node action takes them (later ones win): files become ``--params-file``, dict items
    ``-p name:=value``, as in the node's own process.
    """
    arguments = []
    for node in nodes:
        arguments += [node.name, "--ros-args"]
        for item in parameters[node]:
            if isinstance(item, dict):
                for name, value in item.items():
                    arguments += ["-p", [f"{name}:=", value]]
            else:
                arguments += ["--params-file", item]
        arguments.append("--")
    return arguments


def generate_launch_description():
    """Three nodes in one namespace, geometry from the params file of the chosen mechanism.

    The simulator, the view, the pilot, the DC motor and one process are optional (the launch
    arguments' descriptions). With ``one_process:=true`` each hosted node gets the parameters it
    would get in its own process; the view and the pilot keep their own.
    """
    mechanism = LaunchConfiguration("mechanism")
    params_file = LaunchConfiguration("params_file")
    namespace = LaunchConfiguration("namespace")
    # A list of substitutions is their concatenation. Jazzy's launch (3.4) accepts only plain
    # substitutions as PathJoinSubstitution's items, so the ".yaml" suffix is appended outside it.
    default_params = [
        PathJoinSubstitution([FindPackageShare("fishtail_bringup"), "config", mechanism]),
        ".yaml",
    ]
    fish_params_file = LaunchConfiguration("fish_params_file")
    motor_model = LaunchConfiguration("motor_model")
    pilot = LaunchConfiguration("pilot")
    steering = LaunchConfiguration("steering")
    pivot_steering = AndSubstitution(pilot, EqualsSubstitution(steering, PIVOT_STEERING))
    driver = {
        "backend": LaunchConfiguration("backend"),
        "motor_model": motor_model,
        "motor_load": LaunchConfiguration("motor_load"),
        "pivot_actuator": IfElseSubstitution(pivot_steering, "sim", "none"),
    }
    # The driver declares the fish's parameters only with a motor_load; without one it ignores
    # them, as every node ignores the parameters of a file that it does not declare.
    parameters = {
        node: [params_file, fish_params_file] if node.reads_fish_file else [params_file]
        for node in (*SUITE_NODES, SWIM_NODE, PILOT_NODE)
    }
    for node in SUITE_NODES:
        if node.package == "fishtail_driver":
            parameters[node] = [
                dc_motor_encoder(motor_model),
                params_file,
                fish_params_file,
                OwnParameterFile(node.name, driver),
            ]
    parameters[PILOT_NODE].append(OwnParameterFile(PILOT_NODE.name, {STEERING.name: steering}))
    one_process = LaunchConfiguration("one_process")
    # The pilot flies the simulated fish: it brings the simulator.
    swim = OrSubstitution(LaunchConfiguration("swim"), pilot)
    separate = NotSubstitution(one_process)
    nodes = [
        Node(
            package=node.package,
            executable=node.executable,
            name=node.name,
            namespace=namespace,
            parameters=parameters[node],
            output="screen",
            condition=IfCondition(separate),
        )
        for node in SUITE_NODES
    ]
    # One process with or without the simulator: a Node action's arguments cannot be conditional.
    containers = [
        Node(
            package="fishtail_bringup",
            executable="fishtail-one-process",
            namespace=namespace,
            arguments=one_process_arguments(hosted, parameters),
            output="screen",
            condition=IfCondition(AndSubstitution(one_process, condition)),
        )
        for hosted, condition in (
            (SUITE_NODES, NotSubstitution(swim)),
            ((*SUITE_NODES, SWIM_NODE), swim),
        )
    ]
    simulator = Node(
        package=SWIM_NODE.package,
        executable=SWIM_NODE.executable,
        name=SWIM_NODE.name,
        namespace=namespace,
        parameters=parameters[SWIM_NODE],
        output="screen",
        condition=IfCondition(AndSubstitution(swim, separate)),
    )
    pilot_node = Node(
        package=PILOT_NODE.package,
        executable=PILOT_NODE.executable,
        name=PILOT_NODE.name,
        namespace=namespace,
        parameters=parameters[PILOT_NODE],
        output="screen",
        condition=IfCondition(pilot),
    )
    view = Node(
        package=VIEW_NODE.package,
        executable=VIEW_NODE.executable,
        name=VIEW_NODE.name,
        namespace=namespace,
        output="screen",
        condition=IfCondition(LaunchConfiguration("view")),
    )
    fish_params = PathJoinSubstitution(
        [FindPackageShare("fishtail_bringup"), "config", "fish.yaml"]
    )
    # The fish's URDF (fishtail-swim urdf) of params_file's tail and fish_params_file's fish,
    # driven by the kinematics node's tail/joint_states (docs/visualisation.md, "Robot model").
    fishtail_swim = PathJoinSubstitution(
        [FindPackagePrefix("fishtail_swim"), "lib", "fishtail_swim", "fishtail-swim"]
    )
    robot_model = Node(
        package="robot_state_publisher",
        executable="robot_state_publisher",
        namespace=namespace,
        parameters=[
            {
                "robot_description": ParameterValue(
                    Command(
                        [
                            fishtail_swim,
                            " urdf --config ",
                            params_file,
                            " --fish ",
                            fish_params_file,
                        ]
                    ),
                    value_type=str,
                )
            }
        ],
        remappings=[("joint_states", "tail/joint_states")],
        output="screen",
        condition=IfCondition(LaunchConfiguration("robot_model", default="false")),
    )
    return LaunchDescription(
        [
            DeclareLaunchArgument(
                "mechanism", default_value="oscillatory", description="oscillatory or undulatory"
            ),
            DeclareLaunchArgument(
                "params_file",
                default_value=default_params,
                description="ROS 2 parameter file with the geometry (config/<mechanism>.yaml)",
            ),
            DeclareLaunchArgument("namespace", default_value="", description="namespace"),
            DeclareLaunchArgument("backend", default_value="sim", description="sim or serial"),
            DeclareLaunchArgument(
                "motor_model",
                default_value=str(SPECS["motor_model"].default),
                description="the simulated motor: first_order, or dc (a DC gear motor under the "
                "board's speed loop; sets gear_ratio 30 and encoder_counts_per_revolution 64)",
            ),
            DeclareLaunchArgument(
                "motor_load",
                default_value=NO_LOAD,
                description="with motor_model:=dc, what the motor turns: "
                + ", ".join(SURROUNDINGS)
                + " (the tail of params_file, the fish of fish_params_file)",
            ),
            DeclareLaunchArgument(
                "swim",
                default_value="false",
                description="true: also start the swimming simulator (fishtail_swim sim)",
            ),
            DeclareLaunchArgument(
                "fish_params_file",
                default_value=fish_params,
                description="ROS 2 parameter file with the simulated fish (config/fish.yaml)",
            ),
            DeclareLaunchArgument(
                "view",
                default_value="false",
                description="true: also start the live view (fishtail-view; prints where to look)",
            ),
            DeclareLaunchArgument(
                "one_process",
                default_value="false",
                description="true: the nodes in one process on one executor (fishtail-one-process: "
                "a quarter to a third less CPU at 1 kHz, less latency; a crash in one node ends "
                "them all)",
            ),
            DeclareLaunchArgument(
                "pilot",
                default_value="false",
                description="true: also start the simulator and the pilot (fishtail_swim pilot: "
                "cmd_vel and goal_pose in, the carrier's profile out)",
            ),
            DeclareLaunchArgument(
                "steering",
                default_value=str(STEERING.default),
                description="the pilot's steering: "
                + " or ".join(STEERING.choices)
                + " (pivot gives the driver its simulated pivot actuator)",
            ),
            DeclareLaunchArgument(
                "robot_model",
                default_value="false",
                description="true: also start robot_state_publisher with the fish's URDF "
                "(fishtail-swim urdf of params_file and fish_params_file), driven by "
                "tail/joint_states, for RViz's RobotModel display (a system ROS 2 install)",
            ),
            *nodes,
            *containers,
            simulator,
            pilot_node,
            view,
            robot_model,
        ]
    )
