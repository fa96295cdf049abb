"""Parameter names, defaults, ranges and descriptions: the one place they are written down.

The kinematics and monitor nodes declare their ROS parameters from :data:`GEOMETRY_PARAMETERS`,
the CLI builds its flags from it, and ``config/*.yaml`` must agree with it (a test checks).

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
import math
from collections.abc import Mapping
from pathlib import Path

import yaml

from fishtail_kinematics.engine.errors import ParameterError
from fishtail_kinematics.engine.mechanisms import OscillatoryGeometry, UndulatoryGeometry

OSCILLATORY = "oscillatory"
UNDULATORY = "undulatory"
MECHANISMS = (OSCILLATORY, UNDULATORY)
MECHANISM_PARAMETER = "mechanism"

_MIN_LENGTH_M = 1e-4
_MAX_LENGTH_M = 10.0


@dataclasses.dataclass(frozen=True)
class ParameterSpec:
    """One floating-point geometry parameter: its name, default, range, unit and meaning."""

    name: str
    default: float
    minimum: float
    maximum: float
    unit: str
    symbol: str
    description: str
    mechanisms: tuple[str, ...]


def _spec(name: str, symbol: str, description: str, mechanisms: tuple[str, ...]) -> ParameterSpec:
    # Defaults come from the geometry dataclasses so that the numbers are written once.
    source = OscillatoryGeometry if OSCILLATORY in mechanisms else UndulatoryGeometry
    default = next(f.default for f in dataclasses.fields(source) if f.name == name)
    if name == "phase_rad":
        return ParameterSpec(
            name, default, -math.pi, math.pi, "rad", symbol, description, mechanisms
        )
    return ParameterSpec(
        name, default, _MIN_LENGTH_M, _MAX_LENGTH_M, "m", symbol, description, mechanisms
    )


_BOTH = (OSCILLATORY, UNDULATORY)
GEOMETRY_PARAMETERS: tuple[ParameterSpec, ...] = (
    _spec("ring_radius_m", "R", "ring-gear radius; the planet's radius is half of it", _BOTH),
    _spec("crank_link_m", "PR", "link from the Cardan point P to joint R", _BOTH),
    _spec("rocker_link_m", "RS", "link from joint R to the body pivot S", _BOTH),
    _spec("pivot_offset_m", "OS", "distance from the ring-gear centre O to the pivot S", _BOTH),
    _spec("phase_rad", "psi", "carrier phase: OP = R cos(motor angle + phase)", _BOTH),
    _spec("tail_link_m", "ST", "tail link, rigid with RS at S (oscillatory)", (OSCILLATORY,)),
    _spec("swing_arm_m", "SW", "arm rigid with RS at S, carries pin U and joint W", (UNDULATORY,)),
    _spec("slotted_link_m", "AV", "slotted link from slider A to joint V", (UNDULATORY,)),
    _spec("fin_link_m", "VT", "tail fin link from V through W to the tip T", (UNDULATORY,)),
    _spec("fin_joint_offset_m", "VW", "distance from V to W along the fin link", (UNDULATORY,)),
    _spec("pin_offset_m", "SU", "position of pin U along SW, 0 < SU < SW - VW", (UNDULATORY,)),
)
PARAMETERS_BY_NAME = {spec.name: spec for spec in GEOMETRY_PARAMETERS}


def check_parameter(name: str, value: object) -> float:
    """Return ``value`` as a float if it is a number inside the range of parameter ``name``."""
    spec = PARAMETERS_BY_NAME.get(name)
    if spec is None:
        raise ParameterError(f"unknown geometry parameter {name!r}")
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ParameterError(f"{name} must be a number, got {value!r}")
    number = float(value)
    if not spec.minimum <= number <= spec.maximum:  # also refuses NaN
        raise ParameterError(
            f"{name} = {number!r} is outside [{spec.minimum}, {spec.maximum}] {spec.unit}"
        )
    return number


def geometry_from_parameters(
    values: Mapping[str, object],
) -> OscillatoryGeometry | UndulatoryGeometry:
    """Build the geometry that ``values`` describe; names not given keep their defaults.

    Names of the other mechanism are accepted and ignored (a node declares them all); unknown
    names, wrong types and out-of-range values raise :class:`ParameterError`. Whether the linkage
    assembles is checked by the engine, not here.
    """
    mechanism = values.get(MECHANISM_PARAMETER, OSCILLATORY)
    if mechanism not in MECHANISMS:
        raise ParameterError(f"mechanism must be one of {', '.join(MECHANISMS)}, got {mechanism!r}")
    chosen = {}
    for name, value in values.items():
        if name == MECHANISM_PARAMETER:
            continue
        number = check_parameter(name, value)
        if mechanism in PARAMETERS_BY_NAME[name].mechanisms:
            chosen[name] = number
    if mechanism == OSCILLATORY:
        return OscillatoryGeometry(**chosen)
    return UndulatoryGeometry(**chosen)


def mechanism_of(geometry: OscillatoryGeometry | UndulatoryGeometry) -> str:
    """The mechanism name of a geometry."""
    return UNDULATORY if isinstance(geometry, UndulatoryGeometry) else OSCILLATORY


def parameters_of(geometry: OscillatoryGeometry | UndulatoryGeometry) -> dict[str, object]:
    """The parameter values that describe ``geometry`` (the inverse of geometry_from_parameters)."""
    return {MECHANISM_PARAMETER: mechanism_of(geometry), **dataclasses.asdict(geometry)}


def load_parameter_file(path: str | Path) -> dict[str, object]:
    """Read the parameters of a ROS 2 parameter file (``<node>: ros__parameters: {...}``).

    Parameters of every node entry are merged in file order; non-geometry parameters (those of the
    driver or the monitor) are kept so that callers can pick what they need.
    """
    try:
        with open(path, encoding="utf-8") as stream:
            document = yaml.safe_load(stream)
    except OSError as error:
        raise ParameterError(f"cannot read parameter file {path}: {error.strerror}") from None
    except UnicodeDecodeError as error:
        raise ParameterError(f"{path} is not UTF-8 text: {error.reason}") from None
    except yaml.YAMLError as error:
        raise ParameterError(f"{path} is not valid YAML: {' '.join(str(error).split())}") from None
    if not isinstance(document, dict):
        raise ParameterError(f"{path} is not a ROS 2 parameter file (expected a mapping)")
    merged: dict[str, object] = {}
    for node_name, entry in document.items():
        parameters = entry.get("ros__parameters") if isinstance(entry, dict) else None
        if not isinstance(parameters, dict):
            raise ParameterError(f"{path}: entry {node_name!r} has no ros__parameters mapping")
        merged.update(parameters)
    return merged


def geometry_parameters_in(values: Mapping[str, object]) -> dict[str, object]:
    """The subset of ``values`` that describes geometry (mechanism and lengths)."""
    keep = {MECHANISM_PARAMETER, *PARAMETERS_BY_NAME}
    return {name: value for name, value in values.items() if name in keep}


def geometry_changes(
    current: Mapping[str, object], requested: Mapping[str, object]
) -> dict[str, tuple[object, object]]:
    """The geometry parameters of ``requested`` whose value differs from ``current``: old, new.

    ``ros2 param load`` sets every parameter of a file, changed or not; only these are news.

    >>> geometry_changes({"pivot_offset_m": 0.2, "phase_rad": 0.0},
    ...                  {"pivot_offset_m": 0.2, "phase_rad": 0.3, "frame_id": "x"})
    {'phase_rad': (0.0, 0.3)}
    """
    keep = {MECHANISM_PARAMETER, *PARAMETERS_BY_NAME}
    return {
        name: (current.get(name), value)
        for name, value in requested.items()
        if name in keep and current.get(name) != value
    }


def changes_text(changes: Mapping[str, tuple[object, object]]) -> str:
    """``name old -> new`` for each change, comma separated."""
    return ", ".join(f"{name} {old} -> {new}" for name, (old, new) in changes.items())
