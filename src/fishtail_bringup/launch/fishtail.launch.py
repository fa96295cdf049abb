"""Launch the fishtail suite (driver, kinematics, monitor) on a full ROS 2 Jazzy install.

    ros2 launch fishtail_bringup fishtail.launch.py
    ros2 launch fishtail_bringup fishtail.launch.py mechanism:=undulatory namespace:=fish1
    ros2 launch fishtail_bringup fishtail.launch.py params_file:=/path/to/my_tail.yaml
    ros2 launch fishtail_bringup fishtail.launch.py swim:=true   # and the swimming simulator

The launch file does not command the motor: publish the carrier speed yourself, e.g.
    ros2 topic pub -r 10 motor/cmd_speed std_msgs/msg/Float64 "{data: 4.0}"
(the driver's watchdog stops the motor when commands stop). Machines without ros2 launch use
`fishtail-run`, which also commands the speed and shows a live console.
"""

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.substitutions import FindPackageShare

from fishtail_common.interface import SUITE_NODES, SWIM_NODE


def generate_launch_description():
    """Three nodes in one namespace, geometry from the params file of the chosen mechanism.

    ``swim:=true`` adds the swimming simulator: the same geometry, the fish of ``fish_params_file``.
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
    backend = {"backend": LaunchConfiguration("backend")}
    nodes = [
        Node(
            package=node.package,
            executable=node.executable,
            name=node.name,
            namespace=namespace,
            parameters=[params_file, backend]
            if node.package == "fishtail_driver"
            else [params_file],
            output="screen",
        )
        for node in SUITE_NODES
    ]
    simulator = Node(
        package=SWIM_NODE.package,
        executable=SWIM_NODE.executable,
        name=SWIM_NODE.name,
        namespace=namespace,
        parameters=[params_file, LaunchConfiguration("fish_params_file")],
        output="screen",
        condition=IfCondition(LaunchConfiguration("swim")),
    )
    fish_params = PathJoinSubstitution(
        [FindPackageShare("fishtail_bringup"), "config", "fish.yaml"]
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
                "swim",
                default_value="false",
                description="true: also start the swimming simulator (fishtail_swim sim)",
            ),
            DeclareLaunchArgument(
                "fish_params_file",
                default_value=fish_params,
                description="ROS 2 parameter file with the simulated fish (config/fish.yaml)",
            ),
            *nodes,
            simulator,
        ]
    )
