"""Geometry from parameter values, and back: the mechanism switch and the checked lengths.

The kinematics node declares :data:`MECHANISM` and the geometry specs
(:data:`~fishtail_kinematics.engine.geometry.GEOMETRY_PARAMETERS`), the command line builds its
flags from them, and ``config/*.yaml`` must agree with them (a test checks). The same files hold
other parameters (the links' masses, the fish): :func:`geometry_parameters_in` picks the geometry's.

>>> geometry = geometry_from_parameters({"mechanism": "oscillatory", "pivot_offset_m": 0.18})
>>> geometry.pivot_offset_m
0.18
>>> geometry_from_parameters({"ring_radius_m": -1.0})
Traceback (most recent call last):
...
fishtail_kinematics.engine.errors.ParameterError: ring_radius_m = -1.0 is outside [0.0001, 10.0] m
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

from fishtail_common.parameters import ParameterSpec, ParameterValueError
from fishtail_kinematics.engine.errors import ParameterError
from fishtail_kinematics.engine.geometry import (
    GEOMETRY_PARAMETERS_BY_NAME,
    GEOMETRY_TYPES,
    MECHANISMS,
    OSCILLATORY,
    Geometry,
)

MECHANISM = ParameterSpec("mechanism", OSCILLATORY, "tail mechanism", choices=MECHANISMS)
#: The mechanism and every length: the parameters that make a geometry.
GEOMETRY_PARAMETER_NAMES = frozenset({MECHANISM.name, *GEOMETRY_PARAMETERS_BY_NAME})


def check_parameter(name: str, value: object) -> float:
    """Return ``value`` as a float if it is a number inside the range of parameter ``name``.

    Raises:
        ParameterError: an unknown name, a wrong type or a value outside the range.
    """
    spec = GEOMETRY_PARAMETERS_BY_NAME.get(name)
    if spec is None:
        raise ParameterError(f"unknown geometry parameter {name!r}")
    try:
        return float(spec.check(value))
    except ParameterValueError as error:
        raise ParameterError(str(error)) from None


def geometry_from_parameters(values: Mapping[str, object]) -> Geometry:
    """Build the geometry that ``values`` describe; names not given keep their defaults.

    Names of the other mechanism are accepted and ignored (a node declares them all); pick a
    parameter file's geometry with :func:`geometry_parameters_in`. Whether the linkage assembles
    is checked by the engine, not here.

    Raises:
        ParameterError: an unknown name or mechanism, a wrong type or an out-of-range value.
    """
    mechanism = values.get(MECHANISM.name, MECHANISM.default)
    try:
        geometry_type = GEOMETRY_TYPES[str(MECHANISM.check(mechanism))]
    except ParameterValueError as error:
        raise ParameterError(str(error)) from None
    fields = geometry_type.__dataclass_fields__
    chosen = {}
    for name, value in values.items():
        if name == MECHANISM.name:
            continue
        number = check_parameter(name, value)
        if name in fields:
            chosen[name] = number
    return geometry_type(**chosen)


def parameters_of(geometry: Geometry) -> dict[str, object]:
    """The parameter values that describe ``geometry`` (the inverse of geometry_from_parameters)."""
    return {MECHANISM.name: geometry.mechanism, **dataclasses.asdict(geometry)}


def geometry_parameters_in(values: Mapping[str, object]) -> dict[str, object]:
    """The subset of ``values`` that describes geometry (mechanism and lengths)."""
    return {name: value for name, value in values.items() if name in GEOMETRY_PARAMETER_NAMES}


def geometry_changes(
    current: Mapping[str, object], requested: Mapping[str, object]
) -> dict[str, tuple[object, object]]:
    """The geometry parameters of ``requested`` whose value differs from ``current``: old, new.

    ``ros2 param load`` sets every parameter of a file, changed or not; only these are news.

    >>> geometry_changes({"pivot_offset_m": 0.2, "phase_rad": 0.0},
    ...                  {"pivot_offset_m": 0.2, "phase_rad": 0.3, "frame_id": "x"})
    {'phase_rad': (0.0, 0.3)}
    """
    return {
        name: (current.get(name), value)
        for name, value in requested.items()
        if name in GEOMETRY_PARAMETER_NAMES and current.get(name) != value
    }


def changes_text(changes: Mapping[str, tuple[object, object]]) -> str:
    """``name old -> new`` for each change, comma separated."""
    return ", ".join(f"{name} {old} -> {new}" for name, (old, new) in changes.items())
