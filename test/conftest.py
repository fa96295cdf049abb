"""Fixtures of the integration tests: a ROS domain per test, node processes and a probe node.

Every test gets

* ``ros_domain``: its own ROS_DOMAIN_ID (unique in this run, not bound by any other process on the
  machine, and locked against a parallel run of this suite), localhost-only discovery and
  ROS_LOG_DIR in the test's tmp_path, all set in this process's environment (children inherit it);
* ``start_node``: starts a node as its own process (own process group, stdout and stderr to files
  in tmp_path, shown in the report when the test fails) and stops it at teardown: SIGINT, a wait
  with a timeout, then SIGKILL to the process group;
* ``ros``: a :class:`~fishtail_common.testing.Probe`, this process's own rclpy context on the
  test's domain with a helper node, and helpers that spin until something happens, with a timeout
  (never a fixed sleep).

The machinery is :mod:`fishtail_common.testing`, shared with the packages' tests and the
benchmarks; the fixtures that reach it live here because pytest imports test files with
``--import-mode=importlib``: the test directory is not an importable package.
"""

from __future__ import annotations

import signal
import sys
from collections.abc import Callable
from pathlib import Path

import pytest
import yaml

from fishtail_common import pytest_fixtures
from fishtail_common.interface import SUITE_NODES
from fishtail_common.testing import NodeProcess

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "config"

#: ``start_node("driver")`` etc. start the suite's nodes by module.
NODE_MODULES = {node.name: node.module for node in SUITE_NODES}

_PROCESSES_KEY = pytest.StashKey[list]()

# The shared fixtures, registered for these tests by being names of this conftest.
ros_domain = pytest_fixtures.ros_domain
ros = pytest_fixtures.ros


# --------------------------------------------------------------------------------------------
# Node processes


def _parameter_text(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)  # always a float literal, so the parameter stays a double
    return str(value)


@pytest.fixture
def start_process(request, ros_domain, tmp_path) -> Callable[[str, list[str]], NodeProcess]:
    """Start processes on the test's domain: ``start_process(label, argv)``; stopped at teardown.

    Teardown sends SIGINT to each process (all at once, so they shut down in parallel), waits,
    then kills each process group.
    """
    processes: list[NodeProcess] = []
    request.node.stash[_PROCESSES_KEY] = processes

    def start(label: str, argv: list[str]) -> NodeProcess:
        if any(p.name == label for p in processes):
            label = f"{label}-{len(processes)}"
        process = NodeProcess(label, argv, tmp_path, cwd=ROOT)
        processes.append(process)
        return process

    yield start
    for process in processes:
        process.send_signal(signal.SIGINT)
    for process in processes:
        process.stop()


@pytest.fixture
def start_node(start_process) -> Callable[..., NodeProcess]:
    """Start node processes: ``start_node("driver", params={...}, params_file=..., name=...)``.

    ``node`` is ``driver``, ``kinematics``, ``monitor`` or a module name; ``params`` become
    ``-p name:=value`` (floats stay doubles), after ``--params-file`` so that they override it.
    """

    def start(
        node: str,
        *,
        params: dict[str, object] | None = None,
        params_file: str | Path | None = None,
        name: str | None = None,
    ) -> NodeProcess:
        module = NODE_MODULES.get(node, node)
        argv = [sys.executable, "-m", module, "--ros-args"]
        if params_file is not None:
            argv += ["--params-file", str(params_file)]
        for key, value in (params or {}).items():
            argv += ["-p", f"{key}:={_parameter_text(value)}"]
        return start_process(name or node, argv)

    return start


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    """Attach the node processes' command lines and output to a failed test's report."""
    outcome = yield
    report = outcome.get_result()
    if report.failed:
        for process in item.stash.get(_PROCESSES_KEY, []):
            report.sections.append((f"node process {process.name}", process.output()))


# --------------------------------------------------------------------------------------------
# The test's own ROS node


@pytest.fixture(scope="session")
def config_dir() -> Path:
    """The workspace's config/ directory (report geometries)."""
    return CONFIG


@pytest.fixture
def params_file(tmp_path) -> Callable[..., Path]:
    """Write a parameter file: a config/ file with some values changed, ``/**`` for every node.

    ``params_file("oscillatory.yaml", pivot_offset_m=0.17)`` returns the new file's path.
    """

    def write(base: str, **changes: object) -> Path:
        with open(CONFIG / base, encoding="utf-8") as stream:
            document = yaml.safe_load(stream)
        document["/**"]["ros__parameters"].update(changes)
        suffix = "_".join(f"{key}-{value}" for key, value in changes.items()) or "copy"
        path = tmp_path / f"{Path(base).stem}_{suffix}.yaml"
        with open(path, "w", encoding="utf-8") as stream:
            yaml.safe_dump(document, stream)
        return path

    return write


@pytest.fixture
def fish_and_tail(tmp_path, config_dir):
    """config/oscillatory.yaml and config/fish.yaml in one parameter file (pilot, simulator)."""
    from fishtail_plant.values import read_fish_values

    document = yaml.safe_load((config_dir / "oscillatory.yaml").read_text(encoding="utf-8"))
    document["/**"]["ros__parameters"].update(read_fish_values(config_dir / "fish.yaml"))
    path = tmp_path / "fish_and_tail.yaml"
    path.write_text(yaml.safe_dump(document), encoding="utf-8")
    return path
