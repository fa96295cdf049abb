"""Every package's docstring examples, found and run the same way by its tests.

:func:`pure_modules` lists a package's modules (subpackages included) that do not import ROS
(the nodes and their helpers are left to the ROS tests), each with whether its source has
examples; :func:`check_examples` runs one module's and fails if one fails or none ran.
"""

from __future__ import annotations

import doctest
import importlib
import pkgutil
import re
from pathlib import Path
from types import ModuleType

_ROS_IMPORT = re.compile(r"^\s*(import|from)\s+(rclpy|rcl_interfaces|\w+_msgs)\b", re.MULTILINE)


def pure_modules(package: ModuleType) -> list[tuple[str, bool]]:
    """(module name, has examples) for every module of ``package`` that does not import ROS."""
    package_dir = Path(package.__file__ or "").parent
    modules = [(package.__name__, package_dir / "__init__.py")]
    for info in pkgutil.walk_packages([str(package_dir)], prefix=f"{package.__name__}."):
        relative = Path(*info.name.split(".")[1:])
        path = package_dir / (relative / "__init__.py" if info.ispkg else f"{relative}.py")
        modules.append((info.name, path))
    found = []
    for name, path in sorted(modules):
        source = path.read_text(encoding="utf-8")
        if not _ROS_IMPORT.search(source):
            found.append((name, ">>>" in source))
    return found


def run_examples(name: str) -> doctest.TestResults:
    """Run the examples of module ``name`` (ELLIPSIS on), reporting nothing itself."""
    module = importlib.import_module(name)
    return doctest.testmod(module, optionflags=doctest.ELLIPSIS, verbose=False, report=False)


def check_examples(name: str, has_examples: bool) -> None:
    """Run module ``name``'s examples (see :func:`pure_modules`).

    Raises:
        AssertionError: an example failed, or a module with examples ran none.
    """
    result = run_examples(name)
    assert result.failed == 0, f"{name}: {result.failed} of {result.attempted} examples failed"
    assert result.attempted > 0 or not has_examples, f"{name} has examples, none ran"
