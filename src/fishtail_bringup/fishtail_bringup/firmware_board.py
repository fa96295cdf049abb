"""``fishtail-run --firmware``: the suite's driver on the real motor-board firmware in simavr.

Starts ``fishtail-avr-board`` (:mod:`fishtail_boards.avr_board`) as one more process of the
supervisor, before the nodes and stopped after them, and gives the driver ``backend:=serial`` on
its link, so that the whole chain from ROS node to the firmware's PID runs without hardware.
The project's firmware (build/firmware/fishtail: the board follows a speed profile itself) where
it is built, else the stock ROSArduinoBridge; ``--firmware stock`` picks the stock one. On the
project's firmware with the tail in water, the driver gets ``serial_profile_tuning``: ``k``'s
lead and feed-forward computed for the board's motor and that load
(:func:`fishtail_plant.motor.profile_tuning.profile_tuning`), so that the board follows the
profile without the default loop's lag. docs/serial.md ("The real firmware in a simulator"),
docs/firmware.md.
"""

from __future__ import annotations

import sys
from pathlib import Path

from fishtail_boards.avr_board import (
    ELF_NAME,
    PROJECT_FIRMWARE_DIR,
    SIMULATOR_NAME,
    built_artifacts,
    default_build_dir,
)
from fishtail_driver.parameters import DC_MOTOR_ENCODER
from fishtail_plant.linkage_load.surroundings import NO_LOAD
from fishtail_plant.motor.board_units import Scale
from fishtail_plant.motor.profile_tuning import profile_tuning

#: The supervisor's label of the board's process (its output is prefixed with it).
BOARD_LABEL = "board"
#: The symlink's name in the run's folder.
LINK_NAME = "ttyFIRMWARE"
#: ``--firmware`` values: the project's (``fishtail``), the stock one, or the project's where
#: built (``auto``, what ``--firmware`` alone means).
FIRMWARES = ("fishtail", "stock")
AUTO = "auto"
#: The loads for which the driver gets ``k``: the water's, where docs/firmware.md measured it.
TUNED_LOADS = ("water_held", "water_swimming")


def build_dir(firmware: str) -> Path:
    """The build folder of ``firmware`` (``fishtail`` or ``stock``)."""
    stock = default_build_dir()
    return stock / PROJECT_FIRMWARE_DIR if firmware == "fishtail" else stock


def pick_firmware(asked: str) -> str:
    """``auto``: the project's firmware if it is built, else the stock one; others as asked."""
    if asked != AUTO:
        return asked
    return "fishtail" if built_artifacts(build_dir("fishtail")) is not None else "stock"


def missing_firmware(firmware: str = "stock") -> str | None:
    """Why ``firmware`` cannot run (not built: the command that builds it), or None."""
    folder = build_dir(firmware)
    if built_artifacts(folder) is None:
        return f"no {ELF_NAME} and {SIMULATOR_NAME} in {folder}: run make firmware"
    return None


def describe(firmware: str, tuning: str | None = None) -> str:
    """For fishtail-run's first line."""
    if firmware == "fishtail":
        tuned = f", k {tuning} for its motor in this load" if tuning else ""
        return f"the project's firmware (profile on the board{tuned})"
    return "the stock ROSArduinoBridge (profile on the host)"


def board_tuning(firmware: str, load: str, config: Path, fish: Path | None) -> str | None:
    """``k``'s argument for the board's motor turning the tail in ``load``, or None.

    The board's motor: the default DC motor behind the encoder and gearbox it is started with;
    the tail: ``config``'s and ``fish``'s. None where it is not sent: the stock firmware, or a
    load other than the water's.

    Raises:
        ValueError: a parameter file refused.
    """
    if firmware != "fishtail" or load not in TUNED_LOADS:
        return None
    scale = Scale(
        int(DC_MOTOR_ENCODER["encoder_counts_per_revolution"]),
        float(DC_MOTOR_ENCODER["gear_ratio"]),
    )
    return profile_tuning(load, scale, config=config, fish=fish)


def board_command(
    link: Path, load: str, config: Path, fish: Path | None, firmware: str = "stock"
) -> list[str]:
    """``fishtail-avr-board`` at ``link``; with ``load`` its motors turn the tail of ``config``."""
    command = [sys.executable, "-m", "fishtail_boards.avr_board", "--link", str(link),
               "--build-dir", str(build_dir(firmware)),
               "--counts-per-rev", str(DC_MOTOR_ENCODER["encoder_counts_per_revolution"]),
               "--gear-ratio", str(DC_MOTOR_ENCODER["gear_ratio"])]  # fmt: skip
    if load != NO_LOAD:
        command += ["--load", load, "--config", str(config)]
        command += ["--fish", str(fish)] if fish is not None else []
    return command


def driver_parameters(link: Path, tuning: str | None = None) -> list[str]:
    """The driver's ``NAME:=VALUE`` items for the board at ``link`` (before --driver-param).

    ``tuning``: ``serial_profile_tuning`` (quoted: a YAML reader would take ``8:5955`` for a
    sexagesimal number).
    """
    items = ["backend:=serial", f"serial_port:={link}"]
    items += [f"serial_profile_tuning:={tuning!r}"] if tuning else []
    return items + [f"{name}:={value!r}" for name, value in DC_MOTOR_ENCODER.items()]
