r"""``fishtail-one-process``: several of the suite's nodes in one process, on one executor.

    fishtail-one-process driver --ros-args --params-file config/oscillatory.yaml -p backend:=sim \
        -- kinematics --ros-args --params-file config/oscillatory.yaml -- monitor

The Python counterpart of a component container, for a small computer: less CPU and latency
than a process per node, but a crash in one node ends them all
(:func:`fishtail_common.ros.run_nodes`). A node's own ROS arguments are closed by ``--``;
unclosed ones apply to every node. The command line and its rules: docs/two-computers.md ("A
small computer on the fish: one process").
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Sequence

from fishtail_common.command_line import UsageError
from fishtail_common.interface import PILOT_NODE, SUITE_NODES, SWIM_NODE, SuiteNode

PROGRAM = "fishtail-one-process"
ROS_ARGS = "--ros-args"
#: Ends a node's ROS arguments (rcl's own end marker).
END_OF_ROS_ARGS = "--"
#: The nodes this process can host, by name.
HOSTABLE: dict[str, SuiteNode] = {node.name: node for node in (*SUITE_NODES, SWIM_NODE, PILOT_NODE)}


def parse(argv: Sequence[str]) -> tuple[list[tuple[SuiteNode, list[str]]], list[str]]:
    """The nodes with each one's own ROS arguments, and the ROS arguments of every node.

    Raises:
        UsageError: the command line names no node, an unknown one or one twice, or misplaces
            ROS arguments.

    >>> driver = ["driver", "--ros-args", "-p", "a:=1", "--"]
    >>> nodes, every_node = parse([*driver, "monitor", "--ros-args", "-r", "__ns:=/a"])
    >>> [(node.name, own) for node, own in nodes], every_node
    ([('driver', ['--ros-args', '-p', 'a:=1']), ('monitor', [])], ['--ros-args', '-r', '__ns:=/a'])
    """
    nodes: list[tuple[SuiteNode, list[str]]] = []
    words = list(argv)
    index = 0
    while index < len(words):
        word = words[index]
        if word == ROS_ARGS:
            if END_OF_ROS_ARGS not in words[index:] and nodes:  # unclosed: for every node
                return _checked(nodes), words[index:]
            raise UsageError(f"{ROS_ARGS} ... {END_OF_ROS_ARGS} must follow a node's name")
        if word not in HOSTABLE:
            raise UsageError(f"unknown node {word}: choose from {', '.join(HOSTABLE)}")
        index += 1
        own: list[str] = []
        rest = words[index:]
        if rest[:1] == [ROS_ARGS] and END_OF_ROS_ARGS in rest:
            end = rest.index(END_OF_ROS_ARGS)
            own, index = rest[:end], index + end + 1
        nodes.append((HOSTABLE[word], own))
    return _checked(nodes), []


def _checked(nodes: list[tuple[SuiteNode, list[str]]]) -> list[tuple[SuiteNode, list[str]]]:
    if not nodes:
        raise UsageError(f"name the nodes to host: {', '.join(HOSTABLE)}")
    names = [node.name for node, _ in nodes]
    twice = sorted({name for name in names if names.count(name) > 1})
    if twice:
        raise UsageError(f"node {', '.join(twice)} named twice (node names must be unique)")
    return nodes


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``fishtail-one-process``."""
    from fishtail_common.ros import NodeFactory, run_nodes

    try:
        nodes, every_node = parse(sys.argv[1:] if argv is None else argv)
    except UsageError as error:
        print(f"{PROGRAM}: error: {error}", file=sys.stderr)
        return 2
    hosted = []
    for node, own in nodes:
        factory: NodeFactory = importlib.import_module(node.module).FACTORY
        hosted.append((factory, {"cli_args": own} if own else {}))
    return run_nodes(hosted, args=[PROGRAM, *every_node])


if __name__ == "__main__":
    sys.exit(main())
