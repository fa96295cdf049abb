"""The tail as the simulated DC motor's load: which settings allow it, and building it.

With ``motor_load`` other than ``none`` the simulated backend's DC motor (``motor_model: dc``)
turns the tail: the linkage's inertia and, in water, Lighthill's force on the fin
(:class:`fishtail_swim.dynamics.motor_load.TailLoad`: ``torque(phi, omega)``,
``inertia(phi)``). The tail, its links' masses and the fish are the parameters of the kinematics
node and of the swimming simulator (``config/<mechanism>.yaml``, ``config/fish.yaml``), built by
:mod:`fishtail_swim.tail_and_fish`. Those are imported only here, when a load is built: they bring
the swimming dynamics (numpy, numba) with them, which a driver without a load (the serial
backend on the fish's computer, the default simulated motor) need not load at start.

Plain Python: the node declares and builds through these functions; ``fishtail-fake-board
--load`` reads the same files.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

from fishtail_common.config_files import default_parameter_file
from fishtail_common.parameters import ParameterSpec

if TYPE_CHECKING:
    from fishtail_swim.dynamics.motor_load import TailLoad

#: ``motor_load`` values: fishtail_swim.dynamics.motor_load.SURROUNDINGS (a test holds them
#: equal), written here so that declaring the driver's parameters loads no dynamics.
MOTOR_LOADS = ("none", "air", "water_held", "water_swimming")
NO_LOAD = "none"
#: The parameter files read when none is named (``config/<name>.yaml``).
DEFAULT_CONFIG = "oscillatory"
DEFAULT_FISH = "fish"


def load_refusal(values: Mapping[str, object]) -> str | None:
    """Why the driver's ``values`` cannot carry their ``motor_load``, or None when they can."""
    load = values["motor_load"]
    if load == NO_LOAD:
        return None
    if values["backend"] != "sim" or values["motor_model"] != "dc":
        return (
            f"motor_load {load} needs backend sim with motor_model dc (got backend "
            f"{values['backend']}, motor_model {values['motor_model']}): only the simulated DC "
            "motor feels a load"
        )
    return None


def load_parameters() -> tuple[ParameterSpec, ...]:
    """The tail's, the links' and the fish's parameters, read-only, as the driver declares them."""
    from fishtail_swim.tail_and_fish import LOAD_PARAMETERS

    return tuple(dataclasses.replace(spec, read_only=True) for spec in LOAD_PARAMETERS)


def tail_load(values: Mapping[str, object], surroundings: str) -> TailLoad:
    """The carrier's load of the tail and fish in ``values`` (parameter values by name).

    ValueError, saying what was refused and why (the engine's reason for a geometry that cannot
    assemble, the dynamics' for a fin with chord in water).
    """
    from fishtail_swim.tail_and_fish import tail_load_from_values

    try:
        return tail_load_from_values(values, surroundings)
    except ValueError as error:
        raise ValueError(f"motor_load {surroundings}: {error}") from None


def tail_load_from_files(
    surroundings: str, config: Path | None = None, fish: Path | None = None
) -> TailLoad:
    """The load of the tail in ``config`` (default config/oscillatory.yaml) and of ``fish``'s fish.

    The default files are the workspace's or the installed ones
    (:func:`fishtail_common.config_files.default_parameter_file`). ValueError with the reason for a
    file that is missing or refused, and for what :func:`tail_load` refuses.
    """
    from fishtail_swim.tail_and_fish import values_from_files

    try:
        config_path = config or default_parameter_file(DEFAULT_CONFIG)
        fish_path = fish or default_parameter_file(DEFAULT_FISH)
    except LookupError as error:
        raise ValueError(str(error)) from None
    for path in (config_path, fish_path):
        if not path.is_file():
            raise ValueError(f"no parameter file {path}")
    return tail_load(values_from_files(config_path, fish_path), surroundings)
