"""The tail, its links' masses, the fish and the carrier's load, from parameter values.

A node declares the parameters (:data:`TAIL_PARAMETERS`, :data:`LOAD_PARAMETERS`: the specs of
the engine, the links and the fish, each default written there) and builds what they describe
here; a command line or the emulated board reads the same values from the parameter files
(:func:`values_from_files`). Importing this module loads no fish dynamics: a load brings them
along when one is built (:func:`tail_load_from_values`).

>>> load = tail_load_from_values({"mechanism": "oscillatory", "tail_link_mass_kg": 0.1}, "air")
>>> load.surroundings, load.torque(0.3, 0.0), load.inertia(0.3) > 0.0
('air', 0.0, True)
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

from fishtail_common.parameter_files import (
    ParameterFileError,
    default_parameter_file,
    load_parameter_file,
)
from fishtail_common.parameters import ParameterSpec
from fishtail_kinematics.engine.geometry import GEOMETRY_PARAMETERS
from fishtail_kinematics.engine.mechanisms import Tail, make_tail
from fishtail_kinematics.engine.parameters import (
    MECHANISM,
    geometry_from_parameters,
    geometry_parameters_in,
)
from fishtail_plant.errors import FishConfigError
from fishtail_plant.fish.fish import FISH_PARAMETERS, FISH_PARAMETERS_BY_NAME, FishParameters
from fishtail_plant.linkage_load.link_inertia import (
    INERTIA_PARAMETERS,
    LinkInertia,
    inertia_parameters_in,
    link_inertia_from_parameters,
)

if TYPE_CHECKING:
    from fishtail_plant.linkage_load.tail_load import TailLoad

#: The mechanism and its lengths.
TAIL_PARAMETERS: tuple[ParameterSpec, ...] = (MECHANISM, *GEOMETRY_PARAMETERS)
#: Everything the carrier's load depends on: the tail, its links' masses and the fish.
LOAD_PARAMETERS: tuple[ParameterSpec, ...] = (
    *TAIL_PARAMETERS,
    *INERTIA_PARAMETERS,
    *FISH_PARAMETERS,
)
#: The parameter files read when none is named (``config/<name>.yaml``).
DEFAULT_CONFIG = "oscillatory"
DEFAULT_FISH = "fish"


def read_only_load_parameters() -> tuple[ParameterSpec, ...]:
    """:data:`LOAD_PARAMETERS`, read-only: what a node that only uses them declares."""
    return tuple(dataclasses.replace(spec, read_only=True) for spec in LOAD_PARAMETERS)


def tail_from_values(values: Mapping[str, object]) -> Tail:
    """The engine's tail of the geometry in ``values`` (other names are ignored).

    Raises:
        FishtailKinematicsError: the engine's, with its reason: a value out of range
            (``ParameterError``) or a linkage that cannot assemble (``AssemblyError``, ...).
    """
    return make_tail(geometry_from_parameters(geometry_parameters_in(values)))


def link_inertia_from_values(values: Mapping[str, object]) -> LinkInertia:
    """The links' masses and moments of inertia in ``values`` (others keep their defaults).

    Raises:
        ParameterError: a mass or moment of inertia out of range.
    """
    return link_inertia_from_parameters(inertia_parameters_in(values))


def fish_from_values(values: Mapping[str, object]) -> FishParameters:
    """The fish of the fish parameters in ``values`` (others keep their defaults).

    Raises:
        FishParameterError: a value out of range or not a number.
    """
    return FishParameters.from_values(
        {name: value for name, value in values.items() if name in FISH_PARAMETERS_BY_NAME}
    )


def tail_load_from_values(values: Mapping[str, object], surroundings: str) -> TailLoad:
    """The carrier's load of the tail, links and fish in ``values``, in ``surroundings``.

    Raises:
        ValueError: ``motor_load <surroundings>: <reason>``, the engine's reason for the
            geometry or the masses, the dynamics' for the fish (a fin with chord in water) or
            unknown surroundings.
    """
    # The load brings the fish dynamics (and numba) with it: loaded when a load is built.
    from fishtail_plant.linkage_load.tail_load import TailLoad

    try:
        return TailLoad(
            tail_from_values(values),
            link_inertia_from_values(values),
            fish_from_values(values),
            surroundings,
        )
    except ValueError as error:
        raise ValueError(f"motor_load {surroundings}: {error}") from None


def read_fish_values(path: str | Path) -> dict[str, float]:
    """The fish parameters of the parameter file at ``path``, checked against their specs.

    Raises:
        FishConfigError: naming the file, for one that cannot be read, a name that is not a
            fish parameter or a value outside its range.
    """
    try:
        parameters = load_parameter_file(path)
    except ParameterFileError as error:
        raise FishConfigError(f"{path}: cannot read the fish parameters: {error}") from None
    values: dict[str, float] = {}
    for name, value in parameters.items():
        spec = FISH_PARAMETERS_BY_NAME.get(str(name))
        if spec is None:
            raise FishConfigError(f"{path}: unknown fish parameter {name!r}")
        try:
            values[str(name)] = float(spec.check(value))
        except ValueError as error:
            raise FishConfigError(f"{path}: {error}") from None
    return values


def load_fish_parameters(path: str | Path) -> FishParameters:
    """The fish the file at ``path`` describes (names not in the file keep their defaults).

    Raises:
        FishConfigError: as :func:`read_fish_values`.
    """
    return FishParameters.from_values(read_fish_values(path))


def values_from_files(config: str | Path, fish: str | Path) -> dict[str, object]:
    """The tail's and the fish's values from their parameter files (config/*.yaml, fish.yaml).

    From ``config`` only the geometry and the links' masses are kept (the file may hold other
    nodes' parameters); every name in ``fish`` must be a fish parameter.

    Raises:
        ValueError: naming the file, for one that cannot be read or holds a refused value.
    """
    file_values = load_parameter_file(config)
    return {
        **geometry_parameters_in(file_values),
        **inertia_parameters_in(file_values),
        **read_fish_values(fish),
    }


def tail_load_from_files(
    surroundings: str, config: Path | None = None, fish: Path | None = None
) -> TailLoad:
    """The load of the tail in ``config`` (default config/oscillatory.yaml) and of ``fish``'s fish.

    The default files are the workspace's or the installed ones
    (:func:`~fishtail_common.parameter_files.default_parameter_file`).

    Raises:
        ValueError: with the reason, for a file that is missing or refused, and for what
            :func:`tail_load_from_values` refuses.
    """
    try:
        config_path = config or default_parameter_file(DEFAULT_CONFIG)
        fish_path = fish or default_parameter_file(DEFAULT_FISH)
    except LookupError as error:
        raise ValueError(str(error)) from None
    for path in (config_path, fish_path):
        if not path.is_file():
            raise ValueError(f"no parameter file {path}")
    return tail_load_from_values(values_from_files(config_path, fish_path), surroundings)
