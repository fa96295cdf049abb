"""How ``fishtail-run`` starts the node processes, forwards their output and stops them.

Each node runs as its own process (``python -m <module> --ros-args ...``), or, with
``one_process``, the nodes that ``fishtail-one-process`` hosts share one process, each with the
same ROS arguments as on its own; every process gets its own process group, so that one signal
reaches all of it.

The driver's and the pilot's own ``NAME:=VALUE`` items go in a parameter file of their own, last
(:mod:`fishtail_bringup.own_parameters`: why). ``-p driver:NAME:=VALUE`` cannot name a node in a
namespace.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import yaml

from fishtail_bringup.one_process import END_OF_ROS_ARGS, HOSTABLE
from fishtail_bringup.own_parameters import write_own_parameters
from fishtail_common.interface import PILOT_NODE, SUITE_NODES, VIEW_NODE, SuiteNode

SHUTDOWN_WAIT_S = 5.0
#: The label of the process that hosts the nodes with ``one_process``.
ONE_PROCESS_LABEL = "suite"


class Supervisor:
    """Starts the node processes, forwards their output, stops them."""

    def __init__(
        self,
        config: Path,
        namespace: str,
        driver_params: list[str],
        nodes: tuple[SuiteNode, ...] = SUITE_NODES,
        fish_config: Path | None = None,
        driver_reads_fish: bool = False,
        one_process: bool = False,
        pilot_params: list[str] | None = None,
        boards: dict[str, list[str]] | None = None,
        view_options: list[str] | None = None,
    ) -> None:
        """Remember how to start the nodes.

        ``fish_config``, the fish's parameter file, goes to the nodes that read it
        (:attr:`SuiteNode.reads_fish_file`: the monitor, the simulator, the pilot), and to the
        driver with ``driver_reads_fish`` (its motor turns the tail). ``one_process``: host
        the nodes in one process (:meth:`commands`). ``pilot_params`` (``NAME:=VALUE``) go to the
        pilot. ``boards``: commands by label of processes the nodes talk to (a simulated motor
        board), started before the nodes and stopped after them. ``view_options``: the live
        view's own options (``--send-period-s 0.5``), before its ROS arguments.
        """
        self.view_options = view_options or []
        self.boards = boards or {}
        self.pilot_params = pilot_params or []
        self.one_process = one_process
        self.nodes = nodes
        self.fish_config = fish_config
        self.driver_reads_fish = driver_reads_fish
        self.config = config
        self.namespace = namespace
        self.driver_params = driver_params
        self.processes: dict[str, subprocess.Popen] = {}
        self.print_lock = threading.Lock()
        self.clear_line = ""
        self._own_files: dict[tuple[str, str], Path] = {}

    def command_for(self, node: SuiteNode) -> list[str]:
        """The command line of one node in its own process."""
        options = self.view_options if node == VIEW_NODE else []
        return [sys.executable, "-m", node.module, *options, *self.ros_arguments_for(node)]

    def one_process_command(self, nodes: tuple[SuiteNode, ...]) -> list[str]:
        """The command line of one process hosting ``nodes``, each with its own ROS arguments."""
        command = [sys.executable, "-m", "fishtail_bringup.one_process"]
        for node in nodes:
            command += [node.name, *self.ros_arguments_for(node), END_OF_ROS_ARGS]
        return command

    def ros_arguments_for(self, node: SuiteNode) -> list[str]:
        """The ``--ros-args ...`` of one node: parameter files, namespace, driver parameters."""
        command = ["--ros-args", "--params-file", str(self.config)]
        reads_fish = node.reads_fish_file or (
            self.driver_reads_fish and node.package == "fishtail_driver"
        )
        if reads_fish and self.fish_config is not None:
            command += ["--params-file", str(self.fish_config)]
        if self.namespace:
            command += ["-r", f"__ns:=/{self.namespace.strip('/')}"]
        if node.package == "fishtail_driver":
            command += self.overrides(node, self.driver_params)
        if node == PILOT_NODE:
            command += self.overrides(node, self.pilot_params)
        return command

    def overrides(self, node: SuiteNode, items: list[str]) -> list[str]:
        """``--params-file`` of a file with ``items`` in a ``/**/<node>`` section (see above).

        An item that is not ``NAME:=VALUE`` stays ``-p ITEM``, for ROS to refuse in its words.
        """
        values: dict[str, object] = {}
        malformed: list[str] = []
        for item in items:
            name, separator, text = item.partition(":=")
            try:
                value = yaml.safe_load(text) if separator and name else None
            except yaml.YAMLError:
                value = None
            if not isinstance(value, (bool, int, float, str, list)):
                malformed += ["-p", item]
            else:
                values[name] = value
        if not values:
            return malformed
        # One file per node and values: every command for the node names the same one.
        key = (node.name, yaml.safe_dump(values))
        if key not in self._own_files:
            self._own_files[key] = write_own_parameters(node.name, values)
        return ["--params-file", str(self._own_files[key]), *malformed]

    def commands(self) -> dict[str, list[str]]:
        """The processes to start, by label: a node each, or one for the hostable nodes.

        With ``one_process`` the nodes that ``fishtail-one-process`` hosts share a process
        (labelled ``suite``); the live view always has its own (it serves its viewers there).
        """
        hosted = tuple(node for node in self.nodes if node.name in HOSTABLE)
        if not (self.one_process and hosted):
            return {node.name: self.command_for(node) for node in self.nodes}
        alone = {node.name: self.command_for(node) for node in self.nodes if node not in hosted}
        return {ONE_PROCESS_LABEL: self.one_process_command(hosted), **alone}

    def start(self) -> None:
        """Start the boards, then every node process, each in its own process group."""
        for label, command in {**self.boards, **self.commands()}.items():
            process = subprocess.Popen(
                command,
                stdout=subprocess.PIPE,
                stderr=subprocess.STDOUT,
                stdin=subprocess.DEVNULL,
                start_new_session=True,
                env=os.environ.copy(),
                text=True,
                bufsize=1,
            )
            self.processes[label] = process
            threading.Thread(target=self._forward, args=(label, process), daemon=True).start()

    def _forward(self, name: str, process: subprocess.Popen[str]) -> None:
        assert process.stdout is not None  # started with stdout=PIPE
        for line in process.stdout:
            self.say(f"[{name}] {line.rstrip()}")

    def say(self, text: str) -> None:
        """Print a line above the live status line."""
        with self.print_lock:
            sys.stdout.write(self.clear_line + text + "\n")
            sys.stdout.flush()

    def dead(self) -> list[tuple[str, int]]:
        """Node processes that have exited, with their status."""
        return [(n, p.returncode) for n, p in self.processes.items() if p.poll() is not None]

    def stop(self) -> dict[str, int | None]:
        """SIGINT every node's group, wait, kill what hangs, then the boards; the exit statuses.

        The boards last: a driver's stop command on exit must find its board there.
        """
        nodes = {name: p for name, p in self.processes.items() if name not in self.boards}
        boards = {name: p for name, p in self.processes.items() if name in self.boards}
        return {**self._stop(nodes), **self._stop(boards)}

    def _stop(self, processes: dict[str, subprocess.Popen]) -> dict[str, int | None]:
        """SIGINT each process's group, wait, kill what hangs; the exit statuses."""
        for process in processes.values():
            if process.poll() is None:
                try:
                    os.killpg(process.pid, signal.SIGINT)
                except ProcessLookupError:
                    pass
        deadline = time.monotonic() + SHUTDOWN_WAIT_S
        statuses: dict[str, int | None] = {}
        for name, process in processes.items():
            try:
                statuses[name] = process.wait(timeout=max(0.0, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                self.say(f"[{name}] did not stop within {SHUTDOWN_WAIT_S:g} s: killed")
                os.killpg(process.pid, signal.SIGKILL)
                statuses[name] = process.wait()
        return statuses
