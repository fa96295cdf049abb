"""The options of ``fishtail-swim motor``: the surroundings, the frequencies, the figure, the motor.

A motor is given by its electrical constants, by two datasheet figures at the carrier, or by a
motor file (``--motor``, :mod:`fishtail_plant.motor.motor_file`); options not given keep
:class:`~fishtail_plant.motor.dc_motor.DcMotorParameters`' defaults (or the file's values), and
its checks' messages name the options. The options: docs/motor-load.md ("Choosing a motor").
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import re
from pathlib import Path

import numpy as np

from fishtail_common.command_line import (
    UsageError,
    add_parameter_flags,
    finite_number,
    flag_name,
    parameter_help,
    value_list,
)
from fishtail_common.parameters import ParameterSpec, ParameterValueError
from fishtail_plant.errors import MotorFileError, MotorSpecError
from fishtail_plant.fish.fish import FloatArray
from fishtail_plant.linkage_load.surroundings import SURROUNDINGS
from fishtail_plant.motor.dc_motor import DcMotorParameters
from fishtail_plant.motor.motor_file import read_motor_file
from fishtail_plant.motor.motor_ranges import (
    MOTOR_FIELDS,
    NO_LOAD_SPEED,
    RPM,
    STALL_TORQUE,
    motor_parameter_specs,
)
from fishtail_swim.offline.motor_sizing import DEFAULT_FREQUENCIES_HZ
from fishtail_swim.offline.options import MAX_VALUES

#: Options named after DcMotorParameters' fields, with their meaning, unit and the range of a
#: small fish's DC gear motor (fishtail_plant.motor.motor_ranges, which the motor files share;
#: checked after DcMotorParameters' own checks, on the motor the options give, so also on the
#: resistance and torque constant the datasheet figures give).
_FIELDS = MOTOR_FIELDS
_NO_LOAD_RAD_S = (NO_LOAD_SPEED.minimum or 0.0, NO_LOAD_SPEED.maximum or math.inf)
#: Set by the electrical constants; derived from the datasheet figures otherwise.
_ELECTRICAL = ("resistance_ohm", "torque_constant_n_m_a")
#: The datasheet figures' options (dest names).
_DATASHEET = ("stall_torque_n_m", "no_load_speed_rad_s", "no_load_speed_rpm")
_RPM = RPM
#: One item of --frequencies.
FREQUENCY = ParameterSpec("frequency_hz", 1.0, "beat frequency", "Hz", 0.0, exclusive_minimum=True)


def _defaults() -> dict[str, float]:
    return {spec.name: float(spec.default) for spec in motor_parameter_specs()}


def _motor_specs() -> tuple[ParameterSpec, ...]:
    """The motor's options as specs, their defaults DcMotorParameters' (which checks them)."""
    return motor_parameter_specs()


def _check_ranges(parameters: DcMotorParameters, derived: str = "") -> DcMotorParameters:
    """``parameters`` if every field the options set is within its spec's range.

    Raises:
        ParameterValueError: a field outside its range (``derived`` says where it came from).
    """
    for spec in _motor_specs():
        try:
            spec.check(getattr(parameters, spec.name))
        except ParameterValueError as error:
            if derived and spec.name in _ELECTRICAL:
                raise ParameterValueError(f"{derived} give {error}") from None
            raise
    return parameters


def _frequency_list(text: str) -> FloatArray:
    return np.array(value_list(FREQUENCY, text, MAX_VALUES))


def check_figure_path(path: Path) -> None:
    """Check that ``path`` can be the PNG, before the run rather than after it.

    Raises:
        UsageError: a name not ending in .png, a directory, or a missing parent directory.
    """
    # matplotlib picks the format by the file's suffix.
    if path.suffix.lower() != ".png":
        raise UsageError(f"--figure {path}: the figure is a PNG, name it *.png")
    if path.is_dir():
        raise UsageError(f"cannot write {path}: it is a directory")
    if not path.parent.is_dir():
        raise UsageError(f"cannot write {path}: no directory {path.parent}")


def add_motor_arguments(parser: argparse.ArgumentParser) -> None:
    """The command's options: surroundings, frequencies, figure and motor (all optional).

    The motor's defaults are DcMotorParameters'.
    """
    parser.add_argument(
        "--surroundings", choices=SURROUNDINGS, default="water_swimming",
        help="what the tail works in (water_swimming: the fish towed at the speed it swims at)",
    )  # fmt: skip
    parser.add_argument(
        "--frequencies", type=_frequency_list, metavar="F1,F2,...",
        default=np.array(DEFAULT_FREQUENCIES_HZ),
        help="beat frequencies [Hz] of the table, one beat per carrier turn "
        f"({','.join(f'{f:g}' for f in DEFAULT_FREQUENCIES_HZ)})",
    )  # fmt: skip
    parser.add_argument(
        "--figure", type=Path, metavar="FILE.png",
        help="write the torque-speed figure at the carrier (motor line, load, limits) here",
    )  # fmt: skip
    motor = parser.add_argument_group(
        "motor (SI units; default: DcMotorParameters, a Pololu 37D 12 V with its 30:1 gearbox)"
    )
    motor.add_argument(
        "--motor", type=Path, metavar="FILE.yaml",
        help="the motor of a motor file (config/motors/*.yaml) instead of the constants: "
        "--gear-ratio picks one of the ratios it offers (default: its default ratio); "
        "--supply-voltage-v, --gearbox-efficiency, --rotor-inertia-kg-m2 and the friction options "
        "override its values; --resistance-ohm, --torque-constant-n-m-a and the datasheet "
        "figures cannot go with it (they would replace the motor)",
    )  # fmt: skip
    add_parameter_flags(motor, _motor_specs())
    datasheet = parser.add_argument_group(
        "motor from its datasheet (instead of --resistance-ohm and --torque-constant-n-m-a): "
        "both figures at the carrier at --supply-voltage-v; friction is 0 unless given"
    )
    datasheet.add_argument(
        "--stall-torque-n-m", type=finite_number, metavar="N_M",
        help=parameter_help(STALL_TORQUE, with_default=False),
    )  # fmt: skip
    speed = datasheet.add_mutually_exclusive_group()
    speed.add_argument(
        "--no-load-speed-rad-s", type=finite_number, metavar="RAD/S",
        help=parameter_help(NO_LOAD_SPEED, with_default=False),
    )  # fmt: skip
    speed.add_argument(
        "--no-load-speed-rpm", type=finite_number, metavar="RPM",
        help=f"no-load speed of the gearbox output [rpm] ({_NO_LOAD_RAD_S[0] / _RPM:.3g} to "
        f"{_NO_LOAD_RAD_S[1] / _RPM:.3g})",
    )  # fmt: skip


def _with_options(message: str) -> str:
    """DcMotorParameters' message with its field names written as the options."""
    names = (*_FIELDS, "stall_torque_n_m", "no_load_speed_rad_s")
    return re.sub(r"\b(" + "|".join(names) + r")\b", lambda m: flag_name(m.group(1)), message)


def _motor_from_file(arguments: argparse.Namespace, given: dict[str, float]) -> DcMotorParameters:
    """The motor of the file --motor names, at --gear-ratio, with the other options' overrides.

    Raises:
        UsageError: the file's error (naming the file and the key), a ratio the file does not
            offer, or an option that would replace the file's motor.
        ValueError: an override DcMotorParameters refuses (named as its field).
    """
    path: Path = arguments.motor
    electrical = [name for name in _ELECTRICAL if name in given]
    datasheet = [name for name in _DATASHEET if getattr(arguments, name) is not None]
    refused = [flag_name(name) for name in (*electrical, *datasheet)]
    if refused:
        raise UsageError(
            f"{refused[0]} cannot go with --motor: the file gives the motor (leave out --motor "
            "to give the motor by its constants or its datasheet figures)"
        )
    try:
        spec = read_motor_file(path)
    except MotorFileError as error:
        raise UsageError(str(error)) from None
    ratio = given.pop("gear_ratio", None)
    try:
        motor = spec.parameters(ratio)
    except MotorSpecError as error:
        option = "" if ratio is None else f"--gear-ratio {ratio:g} with "
        raise UsageError(f"{option}--motor {path}: {error}") from None
    return _check_ranges(dataclasses.replace(motor, **given))


def motor_parameters_from_arguments(arguments: argparse.Namespace) -> DcMotorParameters:
    """The checked motor the options describe.

    Raises:
        UsageError: a bad value (named as its option), a wrong mix of options or a motor file
            that cannot be used (naming the file and the key).
    """
    given = {name: getattr(arguments, name) for name in _FIELDS}
    given = {name: value for name, value in given.items() if value is not None}
    if arguments.motor is not None:
        try:
            return _motor_from_file(arguments, given)
        except ValueError as error:
            raise UsageError(_with_options(str(error))) from None
    stall = arguments.stall_torque_n_m
    no_load = arguments.no_load_speed_rad_s
    if arguments.no_load_speed_rpm is not None:
        no_load = arguments.no_load_speed_rpm * _RPM
    datasheet = stall is not None or no_load is not None
    try:
        if not datasheet:
            return _check_ranges(DcMotorParameters(**given))
        if stall is None or no_load is None:
            raise UsageError(
                "give both --stall-torque-n-m and --no-load-speed-rad-s (or -rpm), or neither"
            )
        mixed = [flag_name(name) for name in _ELECTRICAL if name in given]
        if mixed:
            raise UsageError(
                f"{' and '.join(mixed)} cannot go with --stall-torque-n-m: the datasheet figures "
                "set the resistance and the torque constant"
            )
        defaults = _defaults()
        voltage = given.pop("supply_voltage_v", defaults["supply_voltage_v"])
        motor = DcMotorParameters.from_stall_and_no_load(
            supply_voltage_v=voltage,
            stall_torque_n_m=stall,
            no_load_speed_rad_s=no_load,
            gear_ratio=given.pop("gear_ratio", defaults["gear_ratio"]),
            gearbox_efficiency=given.pop("gearbox_efficiency", defaults["gearbox_efficiency"]),
            **given,
        )
        STALL_TORQUE.check(stall)
        NO_LOAD_SPEED.check(no_load)
        return _check_ranges(motor, "the datasheet figures (with the supply and the gearbox)")
    except ValueError as error:
        raise UsageError(_with_options(str(error))) from None
