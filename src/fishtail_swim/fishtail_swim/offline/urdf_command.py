"""``fishtail-swim urdf``: the fish's robot model (URDF) for robot_state_publisher and RViz.

The model is :func:`fishtail_swim.robot_model.robot_description` of the tail of ``--config`` (or
``--mechanism``) and the fish of ``--fish``, with their flags; docs/visualisation.md ("Robot model
(URDF)").
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path
from typing import TextIO

from fishtail_common.command_line import OneLineErrorParser, UsageError, add_parameter_options
from fishtail_kinematics.engine.input_guard import MAX_CARRIER_SPEED
from fishtail_swim.offline.inputs import swimmer_from_arguments
from fishtail_swim.robot_model import robot_description

#: The carrier's top speed, which sets the joints' velocity limits.
TOP_CARRIER_SPEED = dataclasses.replace(
    MAX_CARRIER_SPEED,
    description="the carrier's top speed: each joint's velocity limit is its highest rate at it",
)


def add_urdf_parser(
    commands: argparse._SubParsersAction[OneLineErrorParser], swimmer: OneLineErrorParser
) -> None:
    """The ``urdf`` subcommand and its options."""
    urdf = commands.add_parser(
        "urdf", parents=[swimmer],
        help="the fish's robot model (URDF) for robot_state_publisher: the hull, the tail frame "
        "and the tail's joints, driven by tail/joint_states",
        description="The URDF of the fish (hull, tail frame) and its tail (theta3, and theta5 "
        "for the undulatory mechanism, named as on tail/joint_states), with the joints' ranges "
        "from the geometry. Run robot_state_publisher with it and -r joint_states:="
        "tail/joint_states.",
    )  # fmt: skip
    add_parameter_options(urdf, [TOP_CARRIER_SPEED])
    urdf.add_argument(
        "--output", type=Path, metavar="FILE",
        help="write the URDF to FILE (default: standard output)",
    )  # fmt: skip


def run_urdf(arguments: argparse.Namespace, out: TextIO) -> None:
    """Print the URDF, or write it to --output.

    Raises:
        UsageError: an output that cannot be written; and the errors of
            :func:`~fishtail_swim.offline.inputs.swimmer_from_arguments`.
    """
    swimmer = swimmer_from_arguments(arguments)
    text = robot_description(swimmer.tail, swimmer.fish, arguments.max_carrier_speed_rad_s)
    output: Path | None = arguments.output
    if output is None:
        out.write(text)
        return
    if output.is_dir():
        raise UsageError(f"cannot write {output}: it is a directory")
    if not output.parent.is_dir():
        raise UsageError(f"cannot write {output}: no directory {output.parent}")
    try:
        output.write_text(text, "utf-8")
    except OSError as error:
        raise UsageError(f"cannot write {output}: {error.strerror or error}") from None
    print(f"wrote {output}", file=out)
