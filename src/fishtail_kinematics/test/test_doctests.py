"""Run the examples in the docstrings of every pure module of fishtail_kinematics."""

from __future__ import annotations

import doctest
import importlib
import pkgutil
import re
from pathlib import Path

import pytest

import fishtail_kinematics

PACKAGE_DIR = Path(fishtail_kinematics.__file__).parent
# Modules that need ROS (nodes and their helpers) are left to the ROS tests.
ROS_IMPORT = re.compile(r"^\s*(import|from)\s+(rclpy|rcl_interfaces|\w+_msgs)\b", re.MULTILINE)


def pure_modules():
    """Names of the package's modules (subpackages included) that do not import ROS."""
    found = []
    modules = [("fishtail_kinematics", PACKAGE_DIR / "__init__.py")]
    for info in pkgutil.walk_packages([str(PACKAGE_DIR)], prefix="fishtail_kinematics."):
        relative = Path(*info.name.split(".")[1:])
        path = (
            PACKAGE_DIR / relative / "__init__.py"
            if info.ispkg
            else PACKAGE_DIR / (f"{relative}.py")
        )
        modules.append((info.name, path))
    for name, path in sorted(modules):
        source = path.read_text(encoding="utf-8")
        if not ROS_IMPORT.search(source):
            found.append((name, ">>>" in source))
    return found


def test_the_engine_modules_are_found():
    """The discovery sees the engine modules (so the doctest run below cannot be empty)."""
    names = {name for name, _ in pure_modules()}
    for module in ("errors", "mechanisms", "design", "parameters"):
        assert f"fishtail_kinematics.engine.{module}" in names


@pytest.mark.parametrize(("name", "has_examples"), pure_modules())
def test_doctests(name, has_examples):
    """Every docstring example passes; a module with examples does run them."""
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS, verbose=False, report=False)
    assert result.failed == 0
    if has_examples:
        assert result.attempted > 0
