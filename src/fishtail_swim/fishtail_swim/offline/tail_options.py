"""``--tail``: the Cardan-gear linkage (the default) or a servo-driven fin, for steady and simulate.

The Cardan tail is the engine's linkage of ``--config`` (or ``--mechanism``) and the geometry
flags, turned at carrier speeds (``--speed``, ``--speeds``). The servo tail
(:data:`~fishtail_plant.fish.tail_drive.SERVO_TAIL_PARAMETERS`) is a rigid fin pivoting at O,
θ = α0 + α_a sin 2πft: its values from ``--servo FILE`` (a ROS 2 parameter file of ``servo_*``
names) and the ``--servo-*`` flags, which win; ``steady`` sweeps its beat frequency and amplitude
(``--frequencies-hz``, ``--amplitudes-rad``). An option of the other tail is refused in one line.
Either tail is a :class:`TailChoice`, which gives the fish and the
:class:`~fishtail_swim.offline.tail_beats.TailBeats` a command swims.
"""

from __future__ import annotations

import argparse
import functools
from pathlib import Path
from typing import ClassVar, Protocol

import numpy as np

from fishtail_common.command_line import (
    UsageError,
    add_parameter_flags,
    add_parameter_options,
    flag_name,
    value_list,
)
from fishtail_common.parameter_files import ParameterFileError, load_parameter_file
from fishtail_common.parameters import ParameterSpec, ParameterValueError
from fishtail_kinematics.engine.geometry import GEOMETRY_PARAMETERS
from fishtail_plant.fish.fish import FishParameters, FloatArray
from fishtail_plant.fish.tail_drive import SERVO_TAIL_PARAMETERS, SERVO_TAIL_PARAMETERS_BY_NAME
from fishtail_swim.offline.inputs import fish_from_arguments, swimmer_from_arguments
from fishtail_swim.offline.options import CARRIER_SPEED, MAX_VALUES
from fishtail_swim.offline.tail_beats import CardanBeats, ServoBeats, TailBeats

#: The tail a command swims.
TAIL = ParameterSpec(
    "tail", "cardan", "the tail: the engine's Cardan-gear linkage (--config, the geometry flags, "
    "carrier speeds) or a servo-driven rigid fin (--servo, the --servo-* flags)",
    choices=("cardan", "servo"),
)  # fmt: skip
#: The carrier speeds of ``steady`` [rad/s] without --speeds or --speed-range.
DEFAULT_SPEEDS = "2,4,8,12,16"
#: The servo's beat frequencies of ``steady`` [Hz] when nothing sets one.
DEFAULT_FREQUENCIES = "0.5,1,1.5,2,2.5"
FREQUENCY = SERVO_TAIL_PARAMETERS_BY_NAME["servo_frequency_hz"]
AMPLITUDE = SERVO_TAIL_PARAMETERS_BY_NAME["servo_amplitude_rad"]


def add_tail_options(parser: argparse.ArgumentParser, sweep: bool) -> None:
    """``--tail``, ``--servo FILE`` and the ``--servo-*`` flags (and with ``sweep``, the lists).

    Args:
        parser: the command's parser.
        sweep: add ``--frequencies-hz`` and ``--amplitudes-rad`` (``steady``'s rows).
    """
    group = parser.add_argument_group(
        "servo tail (with --tail servo; SI units; flags override --servo)"
    )
    add_parameter_options(group, [TAIL])
    group.add_argument(
        "--servo", type=Path, metavar="FILE",
        help="servo tail parameter file: a ROS 2 parameter file of servo_* values (names not in "
        "it keep the flags' defaults)",
    )  # fmt: skip
    add_parameter_flags(group, SERVO_TAIL_PARAMETERS)
    if not sweep:
        return
    group.add_argument(
        "--frequencies-hz", type=functools.partial(_values, FREQUENCY), metavar="LIST",
        help="beat frequencies [Hz], comma-separated, a row each (default: --servo-frequency-hz "
        f"or the file's, else {DEFAULT_FREQUENCIES})",
    )  # fmt: skip
    group.add_argument(
        "--amplitudes-rad", type=functools.partial(_values, AMPLITUDE), metavar="LIST",
        help="fin angle amplitudes [rad], comma-separated: a row for each frequency and "
        "amplitude (default: --servo-amplitude-rad)",
    )  # fmt: skip


def _values(spec: ParameterSpec, text: str) -> list[float]:
    return value_list(spec, text, MAX_VALUES)


class TailChoice(Protocol):
    """The tail the command line chose, with the fish it drives."""

    #: The options only this tail takes: (destination, flag as the refusal names it).
    OPTIONS: ClassVar[tuple[tuple[str, str], ...]]
    #: The refusal of one of :attr:`OPTIONS` with the other tail (``{flag}``: the flag).
    REFUSAL: ClassVar[str]

    @property
    def fish(self) -> FishParameters:
        """The fish the tail drives."""

    def sweep(self, arguments: argparse.Namespace) -> TailBeats:
        """``steady``'s rows, one beat each."""

    def run(self, arguments: argparse.Namespace) -> TailBeats:
        """``simulate``'s one fish."""


class CardanChoice:
    """The engine's Cardan-gear linkage at constant carrier speeds."""

    OPTIONS: ClassVar[tuple[tuple[str, str], ...]] = (
        ("config", "--config"), ("mechanism", "--mechanism"),
        *((spec.name, flag_name(spec.name)) for spec in GEOMETRY_PARAMETERS),
        ("speeds", "--speeds/--speed-range"), ("speed", "--speed"),
    )  # fmt: skip
    REFUSAL: ClassVar[str] = (
        "{flag} is for the Cardan tail (its linkage and carrier), not with --tail servo"
    )

    def __init__(self, arguments: argparse.Namespace) -> None:
        """The tail and fish of the files and flags.

        Raises:
            UsageError, ParameterValueError, FishtailKinematicsError: as
                :func:`~fishtail_swim.offline.inputs.swimmer_from_arguments`.
        """
        self.swimmer = swimmer_from_arguments(arguments)

    @property
    def fish(self) -> FishParameters:
        """The fish of --fish and the fish flags."""
        return self.swimmer.fish

    def sweep(self, arguments: argparse.Namespace) -> CardanBeats:
        """The carrier speeds of --speeds or --speed-range (default :data:`DEFAULT_SPEEDS`)."""
        speeds = arguments.speeds
        if speeds is None:
            speeds = np.array(value_list(CARRIER_SPEED, DEFAULT_SPEEDS, MAX_VALUES))
        return CardanBeats(self.swimmer.tail, speeds)

    def run(self, arguments: argparse.Namespace) -> CardanBeats:
        """The carrier speed of --speed (default 4 rad/s)."""
        speed = CARRIER_SPEED.default if arguments.speed is None else arguments.speed
        return CardanBeats(self.swimmer.tail, np.array([speed], dtype=float))


class ServoChoice:
    """The servo-driven fin of --servo and the --servo-* flags."""

    OPTIONS: ClassVar[tuple[tuple[str, str], ...]] = (
        ("servo", "--servo"),
        *((spec.name, flag_name(spec.name)) for spec in SERVO_TAIL_PARAMETERS),
        ("frequencies_hz", "--frequencies-hz"), ("amplitudes_rad", "--amplitudes-rad"),
    )  # fmt: skip
    REFUSAL: ClassVar[str] = "{flag} is for the servo tail: add --tail servo"

    def __init__(self, arguments: argparse.Namespace) -> None:
        """The servo's values (file, then flags) and the fish.

        Raises:
            UsageError: a parameter file that does not exist.
            ParameterValueError: an unreadable file, an unknown name, or a value out of range.
        """
        self.values, self.given = _servo_values(arguments)
        self._fish = fish_from_arguments(arguments)

    @property
    def fish(self) -> FishParameters:
        """The fish of --fish and the fish flags."""
        return self._fish

    def sweep(self, arguments: argparse.Namespace) -> ServoBeats:
        """A row for each beat frequency and amplitude, the frequency the outer loop.

        Raises:
            UsageError: a list with its single-value flag, or more than MAX_VALUES rows.
        """
        frequencies = self._swept(arguments, "frequencies_hz", FREQUENCY)
        amplitudes = self._swept(arguments, "amplitudes_rad", AMPLITUDE)
        if frequencies.size * amplitudes.size > MAX_VALUES:
            raise UsageError(
                f"{frequencies.size} frequencies x {amplitudes.size} amplitudes is "
                f"{frequencies.size * amplitudes.size} rows, over the limit of {MAX_VALUES}"
            )
        frequency, amplitude = np.meshgrid(frequencies, amplitudes, indexing="ij")
        return ServoBeats.of(
            {**self.values, FREQUENCY.name: frequency.ravel(), AMPLITUDE.name: amplitude.ravel()}
        )

    def _swept(
        self, arguments: argparse.Namespace, list_name: str, spec: ParameterSpec
    ) -> FloatArray:
        listed: list[float] | None = getattr(arguments, list_name)
        flag = flag_name(list_name)
        if listed is not None:
            if getattr(arguments, spec.name) is not None:
                raise UsageError(
                    f"{flag} and {flag_name(spec.name)}: give one (a list of rows, or one value)"
                )
            return np.array(listed, dtype=float)
        if spec is FREQUENCY and spec.name not in self.given:
            return np.array(value_list(spec, DEFAULT_FREQUENCIES, MAX_VALUES))
        return np.array([self.values[spec.name]])

    def run(self, arguments: argparse.Namespace) -> ServoBeats:
        """One fin with the servo's values."""
        return ServoBeats.of(self.values)


_CHOICES: dict[str, type[CardanChoice] | type[ServoChoice]] = {
    "cardan": CardanChoice,
    "servo": ServoChoice,
}


def tail_choice(arguments: argparse.Namespace) -> TailChoice:
    """The chosen tail, after refusing the other tail's options.

    Raises:
        UsageError: an option of the other tail (one line naming it), a missing file.
        ParameterValueError, FishtailKinematicsError: a bad value or a linkage that does not
            assemble (the chosen tail's).
    """
    chosen = _CHOICES[arguments.tail]
    for other in _CHOICES.values():
        if other is chosen:
            continue
        for destination, flag in other.OPTIONS:
            if getattr(arguments, destination, None) is not None:
                raise UsageError(other.REFUSAL.format(flag=flag))
    return chosen(arguments)


def _servo_values(arguments: argparse.Namespace) -> tuple[dict[str, float], set[str]]:
    """The servo's values (defaults, then --servo FILE, then the flags) and the names set.

    Raises:
        UsageError: no such file.
        ParameterValueError: an unreadable file, an unknown name, or a value out of range.
    """
    values = {spec.name: float(spec.default) for spec in SERVO_TAIL_PARAMETERS}
    given: set[str] = set()
    path: Path | None = arguments.servo
    if path is not None:
        if not path.is_file():
            raise UsageError(f"--servo {path}: no such file")
        for name, value in load_parameter_file(path).items():
            spec = SERVO_TAIL_PARAMETERS_BY_NAME.get(str(name))
            if spec is None:
                raise ParameterFileError(f"{path}: unknown servo tail parameter {name!r}")
            try:
                values[spec.name] = float(spec.check(value))
            except ParameterValueError as error:
                raise ParameterFileError(f"{path}: {error}") from None
            given.add(spec.name)
    for spec in SERVO_TAIL_PARAMETERS:
        flagged = getattr(arguments, spec.name)
        if flagged is not None:
            values[spec.name] = float(spec.check(flagged))
            given.add(spec.name)
    return values, given
