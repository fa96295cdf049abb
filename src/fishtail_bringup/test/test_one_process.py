"""fishtail-one-process's command line, fishtail-run's commands in one process (no node started)."""

from __future__ import annotations

import doctest
from pathlib import Path

import pytest

import fishtail_bringup.one_process
from fishtail_bringup.one_process import UsageError, main, parse
from fishtail_bringup.supervisor import ONE_PROCESS_LABEL, Supervisor
from fishtail_common.interface import SUITE_NODES, SWIM_NODE, VIEW_NODE

CONFIG = Path("config/oscillatory.yaml")


def test_doctests():
    result = doctest.testmod(fishtail_bringup.one_process)
    assert result.attempted > 0 and result.failed == 0


@pytest.mark.parametrize(
    ("argv", "reason"),
    [
        ([], "name the nodes to host"),
        (["driver", "planner"], "unknown node planner: choose from driver, kinematics, monitor"),
        (["monitor", "monitor"], "node monitor named twice"),
        (["--ros-args", "-p", "a:=1"], "must follow a node's name"),
    ],
)
def test_usage_errors_name_the_problem(argv, reason, capsys):
    with pytest.raises(UsageError, match=reason):
        parse(argv)
    assert main(argv) == 2
    assert reason in capsys.readouterr().err


def test_every_node_keeps_its_own_arguments_in_one_process():
    supervisor = Supervisor(
        CONFIG, "fish1", ["backend:=sim"], (*SUITE_NODES, SWIM_NODE, VIEW_NODE), one_process=True
    )
    commands = supervisor.commands()
    assert list(commands) == [ONE_PROCESS_LABEL, VIEW_NODE.name]  # the view keeps its own
    nodes, every_node = parse(commands[ONE_PROCESS_LABEL][3:])
    assert every_node == []
    for node, own in nodes:
        # Exactly what the node's own process gets after its module.
        assert own == supervisor.command_for(node)[3:]
    assert [node for node, _ in nodes] == [*SUITE_NODES, SWIM_NODE]
    separate = Supervisor(CONFIG, "", [], SUITE_NODES).commands()
    assert list(separate) == [node.name for node in SUITE_NODES]
