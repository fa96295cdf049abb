"""What both tails share: the :class:`Tail` surface, input checks and the drive's assembly.

The mechanisms themselves are :mod:`~fishtail_kinematics.engine.oscillatory_tail` and
:mod:`~fishtail_kinematics.engine.undulatory_tail`; :mod:`~fishtail_kinematics.engine.mechanisms`
is where callers get them (``make_tail``).
"""

from __future__ import annotations

import abc
import dataclasses
import math
from typing import TYPE_CHECKING, ClassVar, TypeVar

import numpy as np
import numpy.typing as npt

from fishtail_common.parameters import ParameterSpec
from fishtail_kinematics.engine.errors import (
    InvalidInputError,
    PivotShiftError,
)
from fishtail_kinematics.engine.geometry import (
    GEOMETRY_PARAMETERS,
    FloatArray,
    Geometry,
    LinkageState,
    OscillatoryGeometry,
    OscillatoryState,
    Real,
    UndulatoryGeometry,
    UndulatoryState,
)
from fishtail_kinematics.engine.link_motion import (
    BodyMotion,
)
from fishtail_kinematics.engine.linkage_points import (
    LinkagePoints,
)

if TYPE_CHECKING:
    from fishtail_kinematics.engine.oscillatory_tail import OscillatoryTail


def check_finite_scalars(phi: float, phi_dot: float) -> None:
    """Refuse a non-finite carrier angle or speed on the float path.

    Raises:
        InvalidInputError: either is NaN or infinite.
    """
    if not (math.isfinite(phi) and math.isfinite(phi_dot)):
        raise InvalidInputError(f"carrier angle {phi!r} and speed {phi_dot!r} must be finite")


ScalarOrArray = TypeVar("ScalarOrArray", float, FloatArray)


class Tail(abc.ABC):
    """One tail mechanism, as its callers (nodes, command line, analysis, drawing) use it.

    The class attributes describe the mechanism without an instance: its :attr:`name` (the
    ``mechanism`` parameter's value), its geometry type, the fields of its states, its joints and
    which joint angle is the fin's (the last link's angle to the body axis).
    """

    name: ClassVar[str]
    geometry_type: ClassVar[type[OscillatoryGeometry] | type[UndulatoryGeometry]]
    #: Every field of a solved state, inputs first.
    state_fields: ClassVar[tuple[str, ...]]
    #: The joint angles published as the tail's joint states; each has a rate ``<name>_dot``.
    joint_names: ClassVar[tuple[str, ...]]
    #: The angle of a second tail joint (the fin link's), if the mechanism has one.
    fin_joint: ClassVar[str | None]
    #: The moving bodies, named as in :mod:`~fishtail_plant.linkage_load.link_inertia`.
    links: ClassVar[tuple[str, ...]]
    #: The named tuple :meth:`solve` returns.
    state_type: ClassVar[type[OscillatoryState] | type[UndulatoryState]]

    def __init__(self, geometry: Geometry) -> None:
        """Keep ``geometry`` (the design, with S unshifted); subclasses validate it."""
        self.geometry = geometry
        self._pivot_shift_m = 0.0
        self._shifted_geometry: Geometry | None = None

    @classmethod
    def parameters(cls) -> tuple[ParameterSpec, ...]:
        """The specs of the geometry parameters this mechanism uses."""
        names = cls.geometry_type.__dataclass_fields__
        return tuple(spec for spec in GEOMETRY_PARAMETERS if spec.name in names)

    @classmethod
    def joint_rate_names(cls) -> tuple[str, ...]:
        """The state fields of the joints' rates, in the order of :attr:`joint_names`."""
        return tuple(f"{name}_dot" for name in cls.joint_names)

    @classmethod
    def fin_angle_field(cls) -> str:
        """The state field of the last link's (ST or VT) angle to the body axis: ``fin_angle``.

        Its rate is ``fin_angle_dot``; both are body-frame, whatever the pivot shift.
        """
        return "fin_angle"

    @classmethod
    def empty_state(cls, shape: int | tuple[int, ...]) -> LinkageState:
        """A state of new (uninitialised) float64 arrays of ``shape``: an ``out`` for :meth:`solve`.

        >>> from fishtail_kinematics.engine.mechanisms import OscillatoryTail
        >>> OscillatoryTail.empty_state((2, 3)).theta1.shape
        (2, 3)
        """
        return cls.state_type._make(np.empty(shape) for _ in cls.state_type._fields)

    @property
    def shifted_geometry(self) -> Geometry:
        """The geometry with S where the pivot shift puts it (``geometry`` itself unshifted).

        For drawing and the links' motion; made on first use (a dataclass copy costs ~30 us).
        """
        if self._pivot_shift_m == 0.0:
            return self.geometry
        if self._shifted_geometry is None:
            self._shifted_geometry = dataclasses.replace(
                self.geometry, pivot_offset_m=self.geometry.pivot_offset_m + self._pivot_shift_m
            )
        return self._shifted_geometry

    @property
    def pivot_shift_m(self) -> float:
        """How far S is shifted from the design along the body axis, m (+ towards the tail)."""
        return self._pivot_shift_m

    @property
    def swing_bias_rad(self) -> float:
        """Angle of the swing's mid-line from the body axis, rad: mid(OS + s) - mid(OS).

        The tail link keeps the mounting it was built with (along the body axis at the design's
        mid-swing), so a shifted pivot turns the mid-line of the swing off the axis. Exactly 0
        without a shift.
        """
        drive = self.drive
        return drive.theta2_mid - drive.tail_mounting_rad

    @abc.abstractmethod
    def with_pivot_shift(self, pivot_shift_m: float) -> Tail:
        """The same mechanism and links with S at (OS + ``pivot_shift_m``, 0).

        The shift is measured from the design (not from this tail's shift); the tail link keeps
        its mounting on the rocker.

        Raises:
            PivotShiftError: a non-finite shift, or one at which the linkage cannot assemble over
                the stroke (naming the feasible range).
        """

    @abc.abstractmethod
    def pivot_shift_range(self) -> tuple[float, float]:
        """The open interval of pivot shifts (m, from the design) at which the linkage works."""

    @property
    @abc.abstractmethod
    def drive(self) -> OscillatoryTail:
        """The mechanism-1 drive (the tail itself for mechanism 1): swing range and extremes."""

    @abc.abstractmethod
    def solve(
        self,
        motor_angle: npt.ArrayLike,
        motor_velocity: npt.ArrayLike = 0.0,
        *,
        out: LinkageState | None = None,
        workers: int | None = None,
    ) -> LinkageState:
        """Pose and rates for carrier angle phi [rad] and speed phi_dot [rad/s].

        Floats take the scalar path; anything else is treated as arrays and broadcast together.
        Large batches are evaluated in cache-sized blocks on up to ``workers`` threads (None:
        one per core this process may use; 1: the calling thread only), with the same results
        to the last bit. ``out``, a state of this tail's type holding float64 arrays of the
        broadcast shape, receives the results and is returned (see
        :mod:`~fishtail_kinematics.engine.block_solve`).

        Raises:
            InvalidInputError: a non-finite angle or speed, or an unusable ``out``.
            SolverError: mechanism 2's loop did not close (a geometry near a toggle pose).
        """

    @abc.abstractmethod
    def link_points(self, state: LinkageState) -> LinkagePoints:
        """Every joint of ``state`` (solved by this tail) in the frame at O, for drawing."""

    @abc.abstractmethod
    def link_motion(self, state: LinkageState) -> tuple[BodyMotion, ...]:
        """Velocity and acceleration of every body of :attr:`links` at ``state``'s steady speed.

        At a carrier speed of 1 rad/s: the velocity ratios and their derivatives in phi.
        """


def assembly_margins(
    ring_radius_m: Real, crank_link_m: Real, rocker_link_m: Real, pivot_offset_m: Real
) -> tuple[Real, Real]:
    """The drive's two assembly conditions as signed margins [m], > 0 where each holds.

    The loop P-R-S closes for every OP in [-R, R] iff |RS - PR| < OS and OS^2 + R^2 < (RS + PR)^2:
    the margins are OS - |RS - PR| and RS + PR - sqrt(OS^2 + R^2). Floats or arrays.

    >>> [round(float(m), 6) for m in assembly_margins(0.1, 0.1, 0.05, 0.2)]
    [0.15, -0.073607]
    """
    inner = pivot_offset_m - np.abs(np.subtract(rocker_link_m, crank_link_m))
    outer = np.add(rocker_link_m, crank_link_m) - np.hypot(pivot_offset_m, ring_radius_m)
    return inner, outer


def assembly_violations(
    ring_radius_m: float, crank_link_m: float, rocker_link_m: float, pivot_offset_m: float
) -> list[str]:
    """Say which assembly conditions of the drive fail, each with its margin; empty if none.

    The loop P-R-S closes for every OP in [-R, R] iff |RS - PR| < OS and OS^2 + R^2 < (RS + PR)^2.

    >>> assembly_violations(0.1, 0.1, 0.234, 0.2)
    []
    >>> print(assembly_violations(0.1, 0.1, 0.05, 0.2)[0])  # doctest: +NORMALIZE_WHITESPACE
    OS^2 + R^2 < (RS + PR)^2 fails: sqrt(OS^2 + R^2) = 0.223607 m exceeds
    RS + PR = 0.150000 m by 0.073607 m
    """
    problems = []
    inner, outer = assembly_margins(ring_radius_m, crank_link_m, rocker_link_m, pivot_offset_m)
    link_difference = abs(rocker_link_m - crank_link_m)
    if not inner > 0.0:
        problems.append(
            f"|RS - PR| < OS fails: |RS - PR| = {link_difference:.6f} m is not less than "
            f"OS = {pivot_offset_m:.6f} m (exceeds it by {link_difference - pivot_offset_m:.6f} m)"
        )
    farthest = math.hypot(pivot_offset_m, ring_radius_m)
    reach = rocker_link_m + crank_link_m
    if not outer > 0.0:
        problems.append(
            f"OS^2 + R^2 < (RS + PR)^2 fails: sqrt(OS^2 + R^2) = {farthest:.6f} m exceeds "
            f"RS + PR = {reach:.6f} m by {farthest - reach:.6f} m"
        )
    return problems


def drive_pivot_shift_range(
    ring_radius_m: float, crank_link_m: float, rocker_link_m: float, pivot_offset_m: float
) -> tuple[float, float]:
    """The open interval of shifts s of S at which the drive assembles over the whole stroke.

    The assembly conditions with OS + s for OS: |RS - PR| < OS + s and
    (OS + s)^2 + R^2 < (RS + PR)^2. Empty (low >= high) when no position of S assembles.

    >>> [round(x, 6) for x in drive_pivot_shift_range(0.1, 0.1, 0.233926, 0.2)]
    [-0.066074, 0.118601]
    """
    reach_sq = (rocker_link_m + crank_link_m) ** 2 - ring_radius_m**2
    farthest = math.sqrt(reach_sq) if reach_sq > 0.0 else 0.0
    return abs(rocker_link_m - crank_link_m) - pivot_offset_m, farthest - pivot_offset_m


def check_pivot_shift(shift_m: float, feasible: tuple[float, float], limits: str) -> None:
    """Refuse a non-finite shift, or one outside the open interval ``feasible``.

    ``limits`` says what bounds the interval; the message names the interval in metres.

    Raises:
        PivotShiftError: the shift is refused.
    """
    low, high = feasible
    where = f"the feasible range is {low:.6f} m < shift < {high:.6f} m ({limits})"
    if not math.isfinite(shift_m):
        raise PivotShiftError(f"pivot shift must be finite, got {shift_m!r} m; {where}")
    if not low < shift_m < high:
        raise PivotShiftError(f"pivot shift {shift_m:.6f} m cannot be assembled: {where}")
