"""The launch file, run against stand-ins for launch/launch_ros (not on PyPI).

This checks what can be checked without ROS 2's launch: the file imports only what launch and
launch_ros provide, and every Node it declares names an executable the packages really install.
"""

from __future__ import annotations

import ast
import importlib.util
import sys
import types
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[2]
LAUNCH_FILE = SRC / "fishtail_bringup" / "launch" / "fishtail.launch.py"


class Recorded:
    """Stands in for any launch class: remembers its arguments."""

    def __init__(self, *args, **kwargs) -> None:
        """Keep the arguments."""
        self.args = args
        self.kwargs = kwargs


def console_scripts(package: str) -> set[str]:
    """Executable names a package's setup.py declares (read, not run)."""
    tree = ast.parse((SRC / package / "setup.py").read_text())
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and " = " in node.value:
            names.add(node.value.split(" = ")[0].strip())
    return names


@pytest.fixture
def launch_stand_ins(monkeypatch):
    provided = {
        "launch": ["LaunchDescription"],
        "launch.actions": ["DeclareLaunchArgument"],
        "launch.substitutions": ["LaunchConfiguration", "PathJoinSubstitution"],
        "launch_ros": [],
        "launch_ros.actions": ["Node"],
        "launch_ros.substitutions": ["FindPackageShare"],
    }
    for module_name, classes in provided.items():
        module = types.ModuleType(module_name)
        for class_name in classes:
            setattr(module, class_name, type(class_name, (Recorded,), {}))
        monkeypatch.setitem(sys.modules, module_name, module)


def test_launch_file_declares_the_three_nodes(launch_stand_ins):
    spec = importlib.util.spec_from_file_location("fishtail_launch", LAUNCH_FILE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    description = module.generate_launch_description()
    entities = description.args[0]
    nodes = [e for e in entities if type(e).__name__ == "Node"]
    arguments = {e.args[0] for e in entities if type(e).__name__ == "DeclareLaunchArgument"}
    assert {"mechanism", "params_file", "namespace", "backend"} <= arguments
    launched = {(n.kwargs["package"], n.kwargs["executable"]) for n in nodes}
    assert launched == {
        ("fishtail_driver", "driver"),
        ("fishtail_kinematics", "node"),
        ("fishtail_kinematics", "monitor"),
    }
    for package, executable in launched:
        assert executable in console_scripts(package)
    for node in nodes:
        assert node.kwargs["parameters"], "every node gets the parameter file"


def test_launch_default_config_files_exist():
    for mechanism in ("oscillatory", "undulatory"):
        assert (SRC.parent / "config" / f"{mechanism}.yaml").is_file()
