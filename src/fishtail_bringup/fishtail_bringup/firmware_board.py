"""``fishtail-run --firmware``: the suite's driver on the real motor-board firmware in simavr.

Starts ``fishtail-avr-board`` (:mod:`fishtail_boards.avr_board`) as one more process of the
supervisor, before the nodes and stopped after them, and gives the driver ``backend:=serial`` on
its link, so that the whole chain from ROS node to the firmware's PID runs without hardware.
docs/serial.md ("The real firmware in a simulator").
"""

from __future__ import annotations

import sys
from pathlib import Path

from fishtail_boards.avr_board import ELF_NAME, SIMULATOR_NAME, built_artifacts, default_build_dir
from fishtail_driver.parameters import DC_MOTOR_ENCODER
from fishtail_plant.linkage_load.surroundings import NO_LOAD

#: The supervisor's label of the board's process (its output is prefixed with it).
BOARD_LABEL = "board"
#: The symlink's name in the run's folder.
LINK_NAME = "ttyFIRMWARE"


def missing_firmware() -> str | None:
    """Why the firmware cannot run (not built: the command that builds it), or None."""
    if built_artifacts() is None:
        return f"no {ELF_NAME} and {SIMULATOR_NAME} in {default_build_dir()}: run make firmware"
    return None


def board_command(link: Path, load: str, config: Path, fish: Path | None) -> list[str]:
    """``fishtail-avr-board`` at ``link``; with ``load`` its motors turn the tail of ``config``."""
    command = [sys.executable, "-m", "fishtail_boards.avr_board", "--link", str(link),
               "--counts-per-rev", str(DC_MOTOR_ENCODER["encoder_counts_per_revolution"]),
               "--gear-ratio", str(DC_MOTOR_ENCODER["gear_ratio"])]  # fmt: skip
    if load != NO_LOAD:
        command += ["--load", load, "--config", str(config)]
        command += ["--fish", str(fish)] if fish is not None else []
    return command


def driver_parameters(link: Path) -> list[str]:
    """The driver's ``NAME:=VALUE`` items for the board at ``link`` (before --driver-param)."""
    items = ["backend:=serial", f"serial_port:={link}"]
    return items + [f"{name}:={value!r}" for name, value in DC_MOTOR_ENCODER.items()]
