"""The tail, its links' masses, the fish and the carrier's load, from parameter values.

A node declares the parameters (:data:`TAIL_PARAMETERS`, :data:`LOAD_PARAMETERS`: the specs of
the engine and of :mod:`fishtail_swim.dynamics.fish`, each default written there)
and builds what they describe here, once: the swimming simulator its tail and fish, the driver's
simulated DC motor the load of that tail (:class:`~fishtail_swim.dynamics.motor_load.TailLoad`).
A command line or the emulated board reads the same values from the parameter files
(:func:`values_from_files`). Plain Python: no rclpy.

>>> load = tail_load_from_values({"mechanism": "oscillatory", "tail_link_mass_kg": 0.1}, "air")
>>> load.surroundings, load.torque(0.3, 0.0), load.inertia(0.3) > 0.0
('air', 0.0, True)
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from fishtail_common.parameters import ParameterSpec
from fishtail_kinematics.engine.geometry import GEOMETRY_PARAMETERS
from fishtail_kinematics.engine.link_inertia import (
    INERTIA_PARAMETERS,
    LinkInertia,
    inertia_parameters_in,
    link_inertia_from_parameters,
)
from fishtail_kinematics.engine.mechanisms import Tail, make_tail
from fishtail_kinematics.engine.parameters import (
    MECHANISM,
    geometry_from_parameters,
    geometry_parameters_in,
)
from fishtail_kinematics.offline.parameter_files import load_parameter_file
from fishtail_swim.dynamics.fish import FISH_PARAMETERS, FISH_PARAMETERS_BY_NAME, FishParameters
from fishtail_swim.dynamics.motor_load import TailLoad
from fishtail_swim.fish_config import read_fish_values

#: The mechanism and its lengths.
TAIL_PARAMETERS: tuple[ParameterSpec, ...] = (MECHANISM, *GEOMETRY_PARAMETERS)
#: Everything the carrier's load depends on: the tail, its links' masses and the fish.
LOAD_PARAMETERS: tuple[ParameterSpec, ...] = (
    *TAIL_PARAMETERS,
    *INERTIA_PARAMETERS,
    *FISH_PARAMETERS,
)


def tail_from_values(values: Mapping[str, object]) -> Tail:
    """The engine's tail of the geometry in ``values`` (other names are ignored).

    Raises the engine's error, with its reason, for a value out of range or a linkage that
    cannot assemble.
    """
    return make_tail(geometry_from_parameters(geometry_parameters_in(values)))


def link_inertia_from_values(values: Mapping[str, object]) -> LinkInertia:
    """The links' masses and moments of inertia in ``values`` (others keep their defaults)."""
    return link_inertia_from_parameters(inertia_parameters_in(values))


def fish_from_values(values: Mapping[str, object]) -> FishParameters:
    """The fish of the fish parameters in ``values`` (others keep their defaults)."""
    return FishParameters.from_values(
        {name: value for name, value in values.items() if name in FISH_PARAMETERS_BY_NAME}
    )


def tail_load_from_values(values: Mapping[str, object], surroundings: str) -> TailLoad:
    """The carrier's load of the tail, links and fish in ``values``, in ``surroundings``.

    Raises ValueError with the reason: the engine's for the geometry or the masses, the
    dynamics' for the fish (a fin with chord in water) or unknown surroundings.
    """
    return TailLoad(
        tail_from_values(values),
        link_inertia_from_values(values),
        fish_from_values(values),
        surroundings,
    )


def values_from_files(config: str | Path, fish: str | Path) -> dict[str, object]:
    """The tail's and the fish's values from their parameter files (config/*.yaml, fish.yaml).

    From ``config`` only the geometry and the links' masses are kept (the file may hold other
    nodes' parameters); every name in ``fish`` must be a fish parameter. Raises ValueError
    naming the file for one that cannot be read or holds a refused value.
    """
    file_values = load_parameter_file(config)
    return {
        **geometry_parameters_in(file_values),
        **inertia_parameters_in(file_values),
        **read_fish_values(fish),
    }
