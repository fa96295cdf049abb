"""What describes a tail linkage: its lengths (with their parameter specs) and its solved states.

Every geometry value is also a ROS parameter of the kinematics node and a flag of the command
line, so :data:`GEOMETRY_PARAMETERS` holds their specs once, with defaults taken from the
dataclasses (each number written once) and the report's symbols in :data:`GEOMETRY_SYMBOLS`.
Conventions, lengths and defaults: docs/kinematics.md.

>>> OscillatoryGeometry().mechanism, UndulatoryGeometry().mechanism
('oscillatory', 'undulatory')
>>> [spec.name for spec in GEOMETRY_PARAMETERS if "undulatory" not in mechanisms_of(spec.name)]
['tail_link_m']
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, ClassVar, NamedTuple, TypeAlias

import numpy as np
import numpy.typing as npt

from fishtail_common.parameters import ParameterSpec
from fishtail_kinematics.engine.errors import InvalidLengthError

FloatArray: TypeAlias = npt.NDArray[np.floating[Any]]
#: A solver's input or output: a float on the per-message path, an array on the batch path.
Real: TypeAlias = float | FloatArray

OSCILLATORY = "oscillatory"
UNDULATORY = "undulatory"
MECHANISMS = (OSCILLATORY, UNDULATORY)

#: Report values (metres). RS is the exactly symmetric rocker, sqrt(PR^2 + OS*sqrt(OS^2 + R^2)).
REPORT_RING_RADIUS_M = 0.1
REPORT_CRANK_LINK_M = 0.1
REPORT_PIVOT_OFFSET_M = 0.2
REPORT_SYMMETRIC_ROCKER_LINK_M = math.sqrt(
    REPORT_CRANK_LINK_M**2
    + REPORT_PIVOT_OFFSET_M * math.hypot(REPORT_PIVOT_OFFSET_M, REPORT_RING_RADIUS_M)
)


def _check_lengths(values: dict[str, float]) -> None:
    for name, value in values.items():
        if not math.isfinite(value):
            raise InvalidLengthError(f"{name} must be finite, got {value!r}")
        if name != "phase_rad" and value <= 0.0:
            raise InvalidLengthError(f"{name} must be positive, got {value!r} m")


@dataclasses.dataclass(frozen=True)
class OscillatoryGeometry:
    """Lengths of mechanism 1 in metres, and the carrier phase psi in radians.

    Report symbols: ring_radius_m = R, crank_link_m = PR, rocker_link_m = RS, tail_link_m = ST,
    pivot_offset_m = OS, phase_rad = psi.

    Raises:
        InvalidLengthError: a value that is not finite, or a length that is not positive.
    """

    mechanism: ClassVar[str] = OSCILLATORY

    ring_radius_m: float = REPORT_RING_RADIUS_M
    crank_link_m: float = REPORT_CRANK_LINK_M
    rocker_link_m: float = REPORT_SYMMETRIC_ROCKER_LINK_M
    tail_link_m: float = 0.15
    pivot_offset_m: float = REPORT_PIVOT_OFFSET_M
    phase_rad: float = 0.0

    def __post_init__(self) -> None:
        """Reject non-finite and non-positive values at once."""
        for field in dataclasses.fields(self):
            object.__setattr__(self, field.name, float(getattr(self, field.name)))
        _check_lengths(dataclasses.asdict(self))

    @property
    def tail_extent_m(self) -> float:
        """How far the tail can reach beyond the pivot S: ST."""
        return self.tail_link_m


@dataclasses.dataclass(frozen=True)
class UndulatoryGeometry:
    """Lengths of mechanism 2 in metres, and the carrier phase psi in radians.

    Report symbols: swing_arm_m = SW, slotted_link_m = AV, fin_link_m = VT,
    fin_joint_offset_m = VW, pin_offset_m = SU (not in the report; SW/2 by default); the drive
    (R, PR, RS, OS, psi) is that of mechanism 1.

    Raises:
        InvalidLengthError: a value that is not finite, or a length that is not positive.
    """

    mechanism: ClassVar[str] = UNDULATORY

    ring_radius_m: float = REPORT_RING_RADIUS_M
    crank_link_m: float = REPORT_CRANK_LINK_M
    rocker_link_m: float = REPORT_SYMMETRIC_ROCKER_LINK_M
    pivot_offset_m: float = REPORT_PIVOT_OFFSET_M
    phase_rad: float = 0.0
    swing_arm_m: float = 0.16
    slotted_link_m: float = 0.24
    fin_link_m: float = 0.2
    fin_joint_offset_m: float = 0.06
    pin_offset_m: float = 0.08

    def __post_init__(self) -> None:
        """Reject non-finite and non-positive values at once."""
        for field in dataclasses.fields(self):
            object.__setattr__(self, field.name, float(getattr(self, field.name)))
        _check_lengths(dataclasses.asdict(self))

    @property
    def tail_extent_m(self) -> float:
        """How far the tail can reach beyond the pivot S, at most: SW + VT."""
        return self.swing_arm_m + self.fin_link_m

    def drive(self) -> OscillatoryGeometry:
        """The mechanism-1 drive of this linkage (its tail link is SW)."""
        return OscillatoryGeometry(
            ring_radius_m=self.ring_radius_m,
            crank_link_m=self.crank_link_m,
            rocker_link_m=self.rocker_link_m,
            tail_link_m=self.swing_arm_m,
            pivot_offset_m=self.pivot_offset_m,
            phase_rad=self.phase_rad,
        )


Geometry: TypeAlias = OscillatoryGeometry | UndulatoryGeometry
#: The geometry type of each mechanism.
GEOMETRY_TYPES: dict[str, type[OscillatoryGeometry] | type[UndulatoryGeometry]] = {
    OSCILLATORY: OscillatoryGeometry,
    UNDULATORY: UndulatoryGeometry,
}


class OscillatoryState(NamedTuple):
    """Pose and rates of mechanism 1 (floats or equally shaped arrays); SI units, radians.

    theta3 is measured from the swing's current mid-line (0 at mid-swing); ``fin_angle`` is the
    tail link's angle from the body axis, theta3 plus the swing bias of a shifted pivot
    (``Tail.swing_bias_rad``). Without a shift the two are equal, and on the array path
    ``fin_angle`` may then be the very array ``theta3`` is (as ``theta3_dot`` and
    ``fin_angle_dot`` are ``theta2_dot``): treat a solved state's arrays as read-only.
    """

    motor_angle: Real
    motor_velocity: Real
    slider_position: Real  # OP
    slider_velocity: Real
    theta1: Real
    theta1_dot: Real
    theta2: Real
    theta2_dot: Real
    theta3: Real
    theta3_dot: Real
    tip_x: Real
    tip_y: Real
    tip_x_dot: Real
    tip_y_dot: Real
    fin_angle: Real  # the tail link ST from the body axis: theta3 + swing bias
    fin_angle_dot: Real


class UndulatoryState(NamedTuple):
    """Pose and rates of mechanism 2; the first fields mean what they mean in mechanism 1.

    The second loop (theta4, AU, AS, theta5) is solved from SW's angle to the body axis, theta3
    plus the swing bias of a shifted pivot, so theta4 and theta5 are body-frame angles;
    ``fin_angle`` and ``fin_angle_dot`` are theta5 and its rate (the same arrays on the array path).
    """

    motor_angle: Real
    motor_velocity: Real
    slider_position: Real
    slider_velocity: Real
    theta1: Real
    theta1_dot: Real
    theta2: Real
    theta2_dot: Real
    theta3: Real
    theta3_dot: Real
    tip_x: Real
    tip_y: Real
    tip_x_dot: Real
    tip_y_dot: Real
    theta4: Real
    theta4_dot: Real
    pin_u_distance: Real  # AU
    pin_u_distance_rate: Real
    slider_a_distance: Real  # AS
    slider_a_distance_rate: Real
    theta5: Real
    theta5_dot: Real
    fin_angle: Real  # the fin link VT from the body axis: theta5
    fin_angle_dot: Real


LinkageState: TypeAlias = OscillatoryState | UndulatoryState
#: The solver's inputs, the first fields of every state.
INPUT_FIELDS = ("motor_angle", "motor_velocity")

# ---- the geometry as parameters

_MIN_LENGTH_M = 1e-4
_MAX_LENGTH_M = 10.0


def mechanisms_of(name: str) -> tuple[str, ...]:
    """The mechanisms whose geometry has the field ``name``."""
    return tuple(
        mechanism
        for mechanism, geometry_type in GEOMETRY_TYPES.items()
        if any(field.name == name for field in dataclasses.fields(geometry_type))
    )


def _parameter(name: str, meaning: str) -> ParameterSpec:
    # The default comes from the geometry dataclass so that each number is written once.
    geometry_type = GEOMETRY_TYPES[mechanisms_of(name)[0]]
    default = next(f.default for f in dataclasses.fields(geometry_type) if f.name == name)
    assert isinstance(default, float)
    description = f"{GEOMETRY_SYMBOLS[name]}: {meaning}"
    if name == "phase_rad":
        return ParameterSpec(name, default, description, "rad", -math.pi, math.pi)
    return ParameterSpec(name, default, description, "m", _MIN_LENGTH_M, _MAX_LENGTH_M)


#: The report's symbol of each geometry parameter.
GEOMETRY_SYMBOLS = {
    "ring_radius_m": "R",
    "crank_link_m": "PR",
    "rocker_link_m": "RS",
    "pivot_offset_m": "OS",
    "phase_rad": "psi",
    "tail_link_m": "ST",
    "swing_arm_m": "SW",
    "slotted_link_m": "AV",
    "fin_link_m": "VT",
    "fin_joint_offset_m": "VW",
    "pin_offset_m": "SU",
}
GEOMETRY_PARAMETERS: tuple[ParameterSpec, ...] = (
    _parameter("ring_radius_m", "ring-gear radius; the planet's radius is half of it"),
    _parameter("crank_link_m", "link from the Cardan point P to joint R"),
    _parameter("rocker_link_m", "link from joint R to the body pivot S"),
    _parameter("pivot_offset_m", "distance from the ring-gear centre O to the pivot S"),
    _parameter("phase_rad", "carrier phase: OP = R cos(motor angle + phase)"),
    _parameter("tail_link_m", "tail link, rigid with RS at S (oscillatory)"),
    _parameter("swing_arm_m", "arm rigid with RS at S, carries pin U and joint W"),
    _parameter("slotted_link_m", "slotted link from slider A to joint V"),
    _parameter("fin_link_m", "tail fin link from V through W to the tip T"),
    _parameter("fin_joint_offset_m", "distance from V to W along the fin link"),
    _parameter("pin_offset_m", "position of pin U along SW, 0 < SU < SW - VW"),
)
GEOMETRY_PARAMETERS_BY_NAME = {spec.name: spec for spec in GEOMETRY_PARAMETERS}
