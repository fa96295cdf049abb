"""The launch file, loaded and resolved by the real ``launch`` and ``launch_ros`` (Jazzy's).

Loading and resolving its substitutions needs no node process, so this catches what the launch
library refuses (types a Jazzy release does not accept, a wrong default path) in a second. Running
the launched suite is the integration tests' job (test/test_ros2_tools.py). Skipped with one line
where the upstream tools are not installed (they are not wheels; ``make setup`` installs them from
the pinned sources when those are at hand).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest
import yaml

# launch_ros first: this package's own launch/ folder makes ``import launch`` succeed as an empty
# namespace package wherever the package directory is on the path.
launch_ros_actions = pytest.importorskip(
    "launch_ros.actions",
    reason="upstream ROS 2 launch not installed (make setup installs it when the pinned "
    "sources, ../shared/upstream or FISHTAIL_ROS2_UPSTREAM, are there)",
)

from launch.actions import DeclareLaunchArgument  # noqa: E402
from launch.launch_description_sources import (  # noqa: E402
    get_launch_description_from_python_launch_file,
)
from launch.launch_description_sources.python_launch_file_utilities import (  # noqa: E402
    load_python_launch_file_as_module,
)
from launch.substitutions import LaunchConfiguration  # noqa: E402
from launch.utilities import perform_substitutions  # noqa: E402
from launch_ros.utilities import evaluate_parameters, normalize_parameters  # noqa: E402

import launch  # noqa: E402
from fishtail_driver.parameters import DC_MOTOR_ENCODER, SPECS  # noqa: E402

SRC = Path(__file__).resolve().parents[2]
LAUNCH_FILE = SRC / "fishtail_bringup" / "launch" / "fishtail.launch.py"


def own_values(path, node: str) -> dict:
    """The values of ``node``'s own parameter file (the launch arguments, given last)."""
    document = yaml.safe_load(Path(path).read_text(encoding="utf-8"))
    assert list(document) == [f"/**/{node}"], document
    return document[f"/**/{node}"]["ros__parameters"]


def console_scripts(package: str) -> set[str]:
    """Executable names a package's setup.py declares (read, not run)."""
    tree = ast.parse((SRC / package / "setup.py").read_text())
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and " = " in node.value:
            names.add(node.value.split(" = ")[0].strip())
    return names


@pytest.fixture
def description():
    """The launch description, as ``ros2 launch`` loads it; fresh, as its files evaluate once."""
    return get_launch_description_from_python_launch_file(str(LAUNCH_FILE))


def test_declares_the_arguments(description):
    names = [argument.name for argument in description.get_launch_arguments()]
    assert names == [
        "mechanism", "params_file", "namespace", "backend", "motor_model", "motor_load", "swim",
        "fish_params_file", "view", "one_process", "pilot", "steering", "robot_model",
    ]  # fmt: skip


def test_launches_the_three_nodes_of_the_packages(description):
    context = launch.LaunchContext()
    context.launch_configurations.update(
        one_process="false", swim="false", view="false", pilot="false"
    )
    nodes = [
        e
        for e in description.entities
        if isinstance(e, launch_ros_actions.Node) and e.condition.evaluate(context)
    ]
    launched = {(node.node_package, node.node_executable) for node in nodes}
    assert launched == {
        ("fishtail_driver", "driver"),
        ("fishtail_kinematics", "node"),
        ("fishtail_kinematics", "monitor"),
    }
    for package, executable in launched:
        assert executable in console_scripts(package)


@pytest.mark.parametrize("mechanism", ["oscillatory", "undulatory"])
def test_default_params_file_resolves_to_the_installed_config(description, mechanism):
    context = launch.LaunchContext()
    context.launch_configurations["mechanism"] = mechanism
    (params_file,) = [
        e
        for e in description.entities
        if isinstance(e, DeclareLaunchArgument) and e.name == "params_file"
    ]
    path = Path(perform_substitutions(context, params_file.default_value))
    assert path.name == f"{mechanism}.yaml"
    assert path.parent.name == "config"
    assert path.is_file(), f"{path} is not installed (colcon build installs config/)"
    assert path.read_text() == (SRC.parent / "config" / f"{mechanism}.yaml").read_text()


@pytest.mark.parametrize(("swim", "launched"), [("false", False), ("true", True)])
def test_swim_adds_the_simulator_with_the_installed_fish(description, swim, launched):
    context = launch.LaunchContext()
    context.launch_configurations.update(swim=swim, one_process="false", pilot="false")
    (simulator,) = [
        e
        for e in description.entities
        if isinstance(e, launch_ros_actions.Node)
        and e.condition is not None
        and e.node_package == "fishtail_swim"
        and e.node_executable == "sim"
    ]
    assert (simulator.node_package, simulator.node_executable) == ("fishtail_swim", "sim")
    assert "sim" in console_scripts("fishtail_swim")
    assert simulator.condition.evaluate(context) is launched
    (fish,) = [
        e
        for e in description.entities
        if isinstance(e, DeclareLaunchArgument) and e.name == "fish_params_file"
    ]
    path = Path(perform_substitutions(context, fish.default_value))
    assert path.is_file() and path.read_text() == (SRC.parent / "config" / "fish.yaml").read_text()


@pytest.mark.parametrize(("view", "launched"), [("false", False), ("true", True)])
def test_view_adds_the_live_view(description, view, launched):
    context = launch.LaunchContext()
    context.launch_configurations["view"] = view
    (node,) = [
        e
        for e in description.entities
        if isinstance(e, launch_ros_actions.Node) and e.node_executable == "fishtail-view"
    ]
    assert "fishtail-view" in console_scripts("fishtail_bringup")
    assert node.condition.evaluate(context) is launched


@pytest.mark.parametrize("motor_model", ["first_order", "dc"])
def test_the_dc_motor_gets_its_gearbox_and_encoder(motor_model):
    """motor_model:=dc sets gear_ratio 30 and 64 counts (before the params files); else defaults."""
    module = load_python_launch_file_as_module(str(LAUNCH_FILE))
    context = launch.LaunchContext()
    context.launch_configurations["motor_model"] = motor_model
    (values,) = evaluate_parameters(
        context, normalize_parameters([module.dc_motor_encoder(LaunchConfiguration("motor_model"))])
    )
    expected = (
        DC_MOTOR_ENCODER
        if motor_model == "dc"
        else {name: SPECS[name].default for name in DC_MOTOR_ENCODER}
    )
    assert values == expected
    # Typed as the driver declares them (a double and an integer parameter).
    assert [type(values[name]) for name in DC_MOTOR_ENCODER] == [float, int]


@pytest.mark.parametrize("swim", ["false", "true"])
def test_one_process_hosts_the_nodes_with_their_own_parameters(description, swim):
    """one_process:=true: one fishtail-one-process, each node with the files of its own process."""
    from fishtail_bringup.one_process import parse
    from fishtail_common.interface import SUITE_NODES, SWIM_NODE

    context = launch.LaunchContext()
    context.launch_configurations.update(
        one_process="true", swim=swim, view="false", mechanism="oscillatory",
        params_file="tail.yaml", fish_params_file="fish.yaml", motor_model="dc",
        backend="sim", motor_load="water_held", namespace="", pilot="false",
        steering="modulation",
    )  # fmt: skip
    launched = [
        e
        for e in description.entities
        if isinstance(e, launch_ros_actions.Node) and e.condition.evaluate(context)
    ]
    (container,) = launched
    assert container.node_executable == "fishtail-one-process"
    assert "fishtail-one-process" in console_scripts("fishtail_bringup")
    arguments = [perform_substitutions(context, item) for item in container.cmd[1:]]
    nodes, every_node = parse(arguments)
    assert every_node in ([], ["--ros-args"])  # launch_ros's own, for every node (empty here)
    own = {node.name: words for node, words in nodes}
    expected = [*SUITE_NODES, SWIM_NODE] if swim == "true" else list(SUITE_NODES)
    assert [node for node, _ in nodes] == expected
    *driver_words, own_file = own["driver"]
    assert driver_words == [
        "--ros-args", "-p", "gear_ratio:=30.0", "-p", "encoder_counts_per_revolution:=64",
        "--params-file", "tail.yaml", "--params-file", "fish.yaml", "--params-file",
    ]  # fmt: skip
    assert own_values(own_file, "driver") == {
        "backend": "sim", "motor_model": "dc", "motor_load": "water_held", "pivot_actuator": "none"
    }  # fmt: skip
    assert own["kinematics"] == ["--ros-args", "--params-file", "tail.yaml"]
    # The monitor's swimming figures use the simulator's fin.
    assert own["monitor"] == [
        "--ros-args", "--params-file", "tail.yaml", "--params-file", "fish.yaml",
    ]  # fmt: skip
    if swim == "true":
        assert own["swim"] == [
            "--ros-args", "--params-file", "tail.yaml", "--params-file", "fish.yaml",
        ]  # fmt: skip


@pytest.mark.parametrize(("steering", "actuator"), [("modulation", "none"), ("pivot", "sim")])
def test_pilot_adds_the_simulator_and_the_pilot_with_its_steering(description, steering, actuator):
    context = launch.LaunchContext()
    context.launch_configurations.update(
        one_process="false", swim="false", view="false", pilot="true", steering=steering,
        params_file="tail.yaml", fish_params_file="fish.yaml", motor_model="first_order",
        backend="sim", motor_load="none", namespace="",
    )  # fmt: skip
    launched = {
        e.node_executable: e
        for e in description.entities
        if isinstance(e, launch_ros_actions.Node) and e.condition.evaluate(context)
    }
    assert {"driver", "node", "monitor", "sim", "pilot"} <= set(launched)
    assert "pilot" in console_scripts("fishtail_swim")
    # launch_ros keeps a Node's parameters private until it runs: read them where it keeps them.
    (*files, pilot_file) = evaluate_parameters(
        context, normalize_parameters(launched["pilot"]._Node__parameters)
    )
    assert own_values(pilot_file, "pilot") == {"steering": steering}
    driver_file = evaluate_parameters(
        context, normalize_parameters(launched["driver"]._Node__parameters)
    )[-1]
    assert own_values(driver_file, "driver")["pivot_actuator"] == actuator


def test_robot_model_adds_robot_state_publisher_on_the_tails_joint_states(description):
    """robot_model:=true: robot_state_publisher, the URDF from fishtail-swim urdf of both files."""
    context = launch.LaunchContext()
    context.launch_configurations.update(
        one_process="false", swim="false", view="false", pilot="false", robot_model="true",
        params_file="tail.yaml", fish_params_file="fish.yaml", namespace="",
    )  # fmt: skip
    (publisher,) = [
        e
        for e in description.entities
        if isinstance(e, launch_ros_actions.Node) and e.node_package == "robot_state_publisher"
    ]
    assert publisher.condition.evaluate(context)
    assert publisher.node_executable == "robot_state_publisher"
    remappings = [
        tuple(perform_substitutions(context, list(part)) for part in pair)
        for pair in publisher._Node__remappings
    ]
    assert remappings == [("joint_states", "tail/joint_states")]
    (values,) = publisher._Node__parameters
    ((name, description_value),) = values.items()
    assert perform_substitutions(context, list(name)) == "robot_description"
    # The Command's words, not run here (robot_state_publisher is a system ROS 2 package).
    (command,) = description_value.value
    words = perform_substitutions(context, list(command.command))
    assert words.endswith("/fishtail-swim urdf --config tail.yaml --fish fish.yaml"), words
    assert "fishtail-swim" in console_scripts("fishtail_swim")
    context.launch_configurations["robot_model"] = "false"
    assert not publisher.condition.evaluate(context)
