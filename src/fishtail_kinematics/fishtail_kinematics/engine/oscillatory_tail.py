"""Mechanism 1: the Cardan point P drives the slider-rocker PR-RS, and the tail ST turns with RS.

The shared surface is :class:`~fishtail_kinematics.engine.tail_base.Tail`; the equations:
docs/kinematics.md ("Mechanism 1").
"""

from __future__ import annotations

import copy
import math
from collections.abc import Mapping
from typing import NamedTuple, TypeAlias, cast

import numpy as np
import numpy.typing as npt

from fishtail_kinematics.engine.block_solve import solve_arrays
from fishtail_kinematics.engine.errors import (
    AssemblyError,
)
from fishtail_kinematics.engine.geometry import (
    OSCILLATORY,
    FloatArray,
    LinkageState,
    OscillatoryGeometry,
    OscillatoryState,
    Real,
)
from fishtail_kinematics.engine.link_motion import (
    BodyMotion,
    oscillatory_link_motion,
)
from fishtail_kinematics.engine.linkage_points import (
    OscillatoryPoints,
    oscillatory_points,
)
from fishtail_kinematics.engine.tail_base import (
    Tail,
    assembly_violations,
    check_finite_scalars,
    check_pivot_shift,
    drive_pivot_shift_range,
)

#: What bounds the drive's pivot shifts (the assembly conditions with OS + s for OS).
_DRIVE_LIMITS = "|RS - PR| < OS + shift and (OS + shift)^2 + R^2 < (RS + PR)^2"


class OscillatoryTail(Tail):
    """Mechanism 1: carrier angle to theta1, theta2, theta3, the tail tip and all their rates.

    Construction validates the geometry (raises :class:`AssemblyError` naming the failed condition)
    and finds the exact swing extremes of theta2, also where theta2 is not monotone in OP.
    :meth:`with_pivot_shift` gives the same linkage with S moved along the body axis: theta3 is
    then measured from the shifted swing's mid-line and ``fin_angle`` from the body axis.
    """

    name = OSCILLATORY
    geometry_type = OscillatoryGeometry
    state_type = OscillatoryState
    state_fields = OscillatoryState._fields
    joint_names = ("theta1", "theta2", "theta3")
    fin_joint = None
    links = ("carrier", "planet", "crank_link", "rocker_link", "tail_link")
    geometry: OscillatoryGeometry

    def __init__(self, geometry: OscillatoryGeometry) -> None:
        """Validate ``geometry`` and precompute its swing extremes.

        Raises:
            AssemblyError: the drive cannot assemble over the whole stroke (naming each failed
                condition and its margin).
        """
        super().__init__(geometry)
        g = geometry
        problems = assembly_violations(
            g.ring_radius_m, g.crank_link_m, g.rocker_link_m, g.pivot_offset_m
        )
        if problems:
            raise AssemblyError("linkage cannot assemble over the stroke: " + "; ".join(problems))
        self._R = g.ring_radius_m
        self._PR = g.crank_link_m
        self._RS = g.rocker_link_m
        self._ST = g.tail_link_m
        self._psi = g.phase_rad
        self._place_pivot(g.pivot_offset_m)
        #: theta2 at which the tail link lies along the body axis: the design's mid-swing. The
        #: link is rigid with RS, so a pivot shift keeps it (see :meth:`with_pivot_shift`).
        self.tail_mounting_rad = self.theta2_mid
        self._set_constants()
        self._unshifted = self

    def _place_pivot(self, pivot_offset_m: float) -> None:
        """Put S at (pivot_offset_m, 0) and find the swing's extremes there (a few us)."""
        self._OS = pivot_offset_m
        # Constant part of the numerator of K, so the per-sample path adds only OP^2.
        self._k_constant = self._RS**2 + self._OS**2 - self._PR**2
        self.stationary_slider_positions = self._stationary_slider_positions()
        candidates = [-self._R, self._R, *self.stationary_slider_positions]
        values = [self.theta2_at(op) for op in candidates]
        self.theta2_min = min(values)
        self.theta2_max = max(values)
        self.slider_at_theta2_min = candidates[values.index(self.theta2_min)]
        self.slider_at_theta2_max = candidates[values.index(self.theta2_max)]
        #: Mid-swing at the current pivot: theta3 = theta2 - theta2_mid.
        self.theta2_mid = 0.5 * (self.theta2_min + self.theta2_max)
        self.swing_range_rad = self.theta2_max - self.theta2_min
        self._set_constants()

    def _set_constants(self) -> None:
        mounting = getattr(self, "tail_mounting_rad", self.theta2_mid)
        #: The numbers of the array path (:func:`solve_drive_arrays`).
        self.constants = DriveConstants(
            self._R, self._PR, self._RS, self._ST, self._OS, self._psi, self.theta2_mid,
            mounting, self.theta2_mid == mounting,
        )  # fmt: skip
        #: The float path's numbers (:func:`drive_pose`), derived once.
        self._coefficients = tuple(float(value) for value in drive_coefficients(self.constants))

    @property
    def drive(self) -> OscillatoryTail:
        """The tail itself: mechanism 1 is the drive."""
        return self

    def pivot_shift_range(self) -> tuple[float, float]:
        """The open interval of shifts at which the drive assembles (closed form, see tail_base)."""
        g = self.geometry
        return drive_pivot_shift_range(
            g.ring_radius_m, g.crank_link_m, g.rocker_link_m, g.pivot_offset_m
        )

    def with_pivot_shift(self, pivot_shift_m: float) -> OscillatoryTail:
        """This linkage with S at OS + ``pivot_shift_m``; the tail link keeps its mounting.

        A copy and the swing's extremes at the new pivot, closed form; the unshifted tail itself
        is returned for a zero shift.

        Raises:
            PivotShiftError: a shift that is not finite or outside :meth:`pivot_shift_range`.
        """
        shift = float(pivot_shift_m)
        check_pivot_shift(shift, self.pivot_shift_range(), _DRIVE_LIMITS)
        unshifted = self._unshifted
        if shift == 0.0:
            return unshifted
        tail = copy.copy(unshifted)
        tail._pivot_shift_m = shift
        tail._shifted_geometry = None
        tail._place_pivot(unshifted._OS + shift)
        return tail

    @property
    def monotone(self) -> bool:
        """Whether theta2 is monotone over the stroke (its extremes then sit at OP = -R and R)."""
        return not self.stationary_slider_positions

    def _stationary_slider_positions(self) -> list[float]:
        # d(theta2)/d(OP) vanishes where sin(theta1) = 0, i.e. R lies level with P:
        # cos(theta2) = (PR - OS)/RS and OP = +-RS sin(theta2). With R = P + (PR, 0) the branch
        # condition (S - P) x (R - P) = PR OP > 0 keeps only OP > 0 (theta1 = pi would need
        # RS >= OS + PR, which assembly excludes). Only points strictly inside the stroke matter.
        offset_sq = self._RS**2 - (self._OS - self._PR) ** 2
        if offset_sq <= 0.0:
            return []
        op = math.sqrt(offset_sq)
        return [op] if op < self._R else []

    def theta2_at(self, slider_position: float) -> float:
        """theta2 for a Cardan-point position OP in metres (assembly branch of the spec)."""
        distance = math.hypot(slider_position, self._OS)
        k = (slider_position**2 + self._k_constant) / (2.0 * self._RS * distance)
        return math.atan2(self._OS, slider_position) + math.asin(k)

    def solve(
        self,
        motor_angle: npt.ArrayLike,
        motor_velocity: npt.ArrayLike = 0.0,
        *,
        out: LinkageState | None = None,
        workers: int | None = None,
    ) -> OscillatoryState:
        """Pose and rates for carrier angle phi [rad] and speed phi_dot [rad/s].

        Floats take the scalar path; anything else is treated as arrays and broadcast together,
        in blocks, into ``out`` if given, on up to ``workers`` threads (see :meth:`Tail.solve`).

        Raises:
            InvalidInputError: a non-finite angle or speed, or an unusable ``out``.
        """
        scalars = isinstance(motor_angle, (float, int)) and isinstance(motor_velocity, (float, int))
        if scalars and out is None:
            phi, phi_dot = float(motor_angle), float(motor_velocity)  # type: ignore[arg-type]
            check_finite_scalars(phi, phi_dot)
            return self._solve_scalar(phi, phi_dot)
        return solve_arrays(
            self._solve_array, OscillatoryState, motor_angle, motor_velocity,
            cast(OscillatoryState | None, out), workers,
        )  # fmt: skip

    def _solve_scalar(self, phi: float, phi_dot: float) -> OscillatoryState:
        carrier = phi + self._psi
        (
            op, op_dot, theta1, theta1_dot, theta2, theta2_dot, theta3, tip_x, tip_y, tip_x_dot,
            tip_y_dot, fin_angle, _, _, _, _, _,
        ) = drive_pose(
            math.cos(carrier), math.sin(carrier), phi_dot, *self._coefficients
        )  # fmt: skip
        return OscillatoryState(
            phi, phi_dot, op, op_dot, theta1, theta1_dot, theta2, theta2_dot, theta3, theta2_dot,
            tip_x, tip_y, tip_x_dot, tip_y_dot, fin_angle, theta2_dot,
        )  # fmt: skip

    def link_points(self, state: LinkageState) -> OscillatoryPoints:
        """Every joint of ``state`` in the frame at O (S where the pivot shift puts it)."""
        return oscillatory_points(self.shifted_geometry, state)

    def link_motion(self, state: LinkageState) -> tuple[BodyMotion, ...]:
        """Carrier, planet, PR, RS and ST (``state`` an oscillatory state)."""
        return oscillatory_link_motion(
            cast(OscillatoryGeometry, self.shifted_geometry),
            self.tail_mounting_rad,
            cast(OscillatoryState, state),
        )

    def _solve_array(self, phi: FloatArray, phi_dot: FloatArray) -> OscillatoryState:
        return self.solve_array_with_tail_trig(phi, phi_dot)[0]

    def solve_array_with_tail_trig(
        self, phi: FloatArray, phi_dot: FloatArray
    ) -> tuple[OscillatoryState, FloatArray, FloatArray]:
        """The array path, with cos and sin of the tail link's angle from the body axis.

        That angle is ``fin_angle``, which mechanism 2's SW has.
        """
        return solve_drive_arrays(self.constants, phi, phi_dot)


class DriveConstants(NamedTuple):
    """What mechanism 1's array path needs: floats for one linkage, equal-shaped arrays for many.

    With arrays (one element per linkage) the carrier angles broadcast against them, e.g.
    ``(samples, linkages)`` against ``(linkages,)``. ``mounted_at_mid``: the tail link lies along
    the body axis at mid-swing (no pivot shift), so that its angle from the body axis is theta3.
    """

    ring_radius_m: Real
    crank_link_m: Real
    rocker_link_m: Real
    tail_link_m: Real
    pivot_offset_m: Real
    phase_rad: Real
    theta2_mid: Real
    tail_mounting_rad: Real
    mounted_at_mid: bool


#: The arrays :func:`solve_drive_arrays` computes (its ``out=`` keys): the state's fields but the
#: inputs and the rates that are theta2_dot, and the tail link's cosine and sine.
DRIVE_ARRAY_FIELDS = (
    "slider_position", "slider_velocity", "theta1", "theta1_dot", "theta2", "theta2_dot",
    "theta3", "tip_x", "tip_y", "tip_x_dot", "tip_y_dot", "fin_angle", "cos_fin", "sin_fin",
)  # fmt: skip


def shared_value(value: Real) -> Real:
    """``value``, or its one value where an array holds the same everywhere (a float)."""
    array = np.asarray(value)
    if array.ndim and array.size and bool((array == array.flat[0]).all()):
        return float(array.flat[0])
    return value


class DriveCoefficients(NamedTuple):
    """What mechanism 1's solve derives from a linkage's lengths before it takes any angle.

    Floats for one linkage, arrays for many; in the order :func:`drive_pose` takes them (after
    the carrier's cosine, sine and speed), so that the per-linkage divisions happen once, not at
    every angle.
    """

    ring_radius_m: Real
    pivot_offset_m: Real
    tail_link_m: Real
    theta2_mid: Real
    tail_mounting_rad: Real
    minus_ring_radius_m: Real
    offset_squared: Real  # OS²
    k_constant: Real  # RS² + OS² - PR²
    half_inverse_rocker: Real  # 0.5 / RS
    rocker_over_crank: Real  # RS / PR
    minus_rocker_over_crank: Real
    offset_over_crank: Real  # OS / PR
    inverse_crank: Real  # 1 / PR
    inverse_rocker: Real  # 1 / RS
    cos_mounting: Real
    sin_mounting: Real


def drive_coefficients(c: DriveConstants) -> DriveCoefficients:
    """``c``'s :class:`DriveCoefficients` (numpy's cos/sin of the mounting, for every path)."""
    cos_mounting: Real = np.cos(c.tail_mounting_rad)
    sin_mounting: Real = np.sin(c.tail_mounting_rad)
    if np.ndim(cos_mounting) == 0:
        cos_mounting, sin_mounting = float(cos_mounting), float(sin_mounting)
    return DriveCoefficients(
        c.ring_radius_m, c.pivot_offset_m, c.tail_link_m, c.theta2_mid, c.tail_mounting_rad,
        -c.ring_radius_m, c.pivot_offset_m**2,
        c.rocker_link_m**2 + c.pivot_offset_m**2 - c.crank_link_m**2, 0.5 / c.rocker_link_m,
        c.rocker_link_m / c.crank_link_m, -c.rocker_link_m / c.crank_link_m,
        c.pivot_offset_m / c.crank_link_m, 1.0 / c.crank_link_m, 1.0 / c.rocker_link_m,
        cos_mounting, sin_mounting,
    )  # fmt: skip


#: Scratch arrays :func:`solve_drive_arrays` works in.
DRIVE_SCRATCH = 7


def solve_drive_arrays(
    c: DriveConstants,
    phi: FloatArray,
    phi_dot: FloatArray,
    out: Mapping[str, FloatArray] | None = None,
    scratch: list[FloatArray] | None = None,
    coefficients: DriveCoefficients | None = None,
) -> tuple[OscillatoryState, FloatArray, FloatArray]:
    """Mechanism 1 at carrier angles ``phi`` and speeds ``phi_dot`` (arrays), and the tail trig.

    Returns the state and cos, sin of the tail link's angle from the body axis. Inputs are not
    checked here (a linkage that cannot assemble gives NaN): :class:`OscillatoryTail` checks them.
    The angles, speeds and constants broadcast together; the state's ``motor_angle`` and
    ``motor_velocity`` are the inputs broadcast (read-only views where they are broadcast).
    Where the linkages share one carrier phase, the carrier's cosine and sine are taken of the
    angles as given, before they are broadcast against the linkages: a beat's angles for a
    population cost one call per angle.

    For a caller solving block after block (:class:`~.drive_batch.OscillatoryBatch`): ``out``,
    arrays of the broadcast shape for any of :data:`DRIVE_ARRAY_FIELDS`, written in place
    (``fin_angle`` is ``theta3`` unless the tail link is mounted off mid-swing); ``scratch``,
    :data:`DRIVE_SCRATCH` arrays of that shape to work in instead of fresh memory (whose first
    touch costs more than the arithmetic); ``coefficients``, ``drive_coefficients(c)``.
    """
    targets = out or {}
    d = coefficients or drive_coefficients(c)
    shape = np.broadcast_shapes(np.shape(phi), np.shape(phi_dot), np.shape(c.ring_radius_m))
    spare = list(scratch) if scratch is not None else []

    def work() -> FloatArray:
        return spare.pop() if spare else np.empty(shape)

    def into(name: str, otherwise: FloatArray | None = None) -> FloatArray:
        # The caller's array for ``name``, else ``otherwise`` (a spent temporary), else new.
        target = targets.get(name, otherwise)
        return work() if target is None else target

    # np.sin/np.cos cost ~8 ns a sample in float64, the algebra below ~0.5 ns an operation: so
    # only the carrier angle goes through trigonometry, every other sine and cosine comes from
    # the angle-sum identities, and every operation writes into memory already in the cache.
    phase = shared_value(c.phase_rad)
    angles = np.broadcast_shapes(np.shape(phi), np.shape(phase))
    carrier = np.add(phi, phase, out=np.empty(angles))
    cos_carrier = np.cos(carrier)
    sin_carrier = np.sin(carrier, out=carrier)
    whole = angles == shape
    op = np.multiply(
        cos_carrier, d.ring_radius_m, out=into("slider_position", cos_carrier if whole else None)
    )
    op_dot = np.multiply(sin_carrier, phi_dot, out=sin_carrier if whole else None)
    spent = op_dot if op_dot.shape == shape else None
    op_dot = np.multiply(op_dot, d.minus_ring_radius_m, out=into("slider_velocity", spent))
    # alpha = atan2(OS, OP), beta = asin K, theta2 = alpha + beta.
    distance = np.square(op, out=work())
    k = np.add(distance, d.k_constant, out=work())
    distance += d.offset_squared
    np.sqrt(distance, out=distance)
    k /= distance
    k *= d.half_inverse_rocker
    cos_alpha = np.divide(op, distance, out=work())
    sin_alpha = np.divide(d.pivot_offset_m, distance, out=distance)
    theta2 = np.arctan2(d.pivot_offset_m, op, out=into("theta2"))
    spent = work()
    theta2 += np.arcsin(k, out=spent)
    cos_beta = np.subtract(1.0, k, out=spent)
    other = work()
    cos_beta *= np.add(1.0, k, out=other)
    np.sqrt(cos_beta, out=cos_beta)
    sin2 = np.multiply(sin_alpha, cos_beta, out=other)
    product = work()
    sin2 += np.multiply(cos_alpha, k, out=product)
    cos2 = np.multiply(cos_alpha, cos_beta, out=cos_alpha)
    cos2 -= np.multiply(sin_alpha, k, out=k)
    # Joint R relative to P, scaled by 1/PR: (cos theta1, -sin theta1).
    cos1 = np.multiply(cos2, d.rocker_over_crank, out=cos_beta)
    cos1 += d.offset_over_crank
    sin1 = np.multiply(sin2, d.minus_rocker_over_crank, out=sin_alpha)
    sin1 += np.multiply(op, d.inverse_crank, out=k)
    theta1 = np.arctan2(sin1, cos1, out=into("theta1"))
    sin_sum = np.multiply(sin1, cos2, out=k)
    sin_sum += np.multiply(cos1, sin2, out=product)
    rate = np.divide(op_dot, sin_sum, out=sin_sum)
    theta2_dot = np.multiply(rate, sin1, out=into("theta2_dot"))
    theta2_dot *= d.inverse_rocker
    theta1_dot = np.multiply(rate, sin2, out=into("theta1_dot", rate))
    theta1_dot *= d.inverse_crank
    theta3 = np.subtract(theta2, d.theta2_mid, out=into("theta3"))
    # Unshifted, the body-frame angle is theta3 itself: the same array, no extra pass.
    fin_angle = theta3 if c.mounted_at_mid else np.subtract(
        theta2, d.tail_mounting_rad, out=into("fin_angle")
    )  # fmt: skip
    sin_fin = np.multiply(sin2, d.cos_mounting, out=into("sin_fin"))
    sin_fin -= np.multiply(cos2, d.sin_mounting, out=product)
    cos_fin = np.multiply(cos2, d.cos_mounting, out=into("cos_fin", cos2))
    cos_fin += np.multiply(sin2, d.sin_mounting, out=product)
    tip_x = np.multiply(cos_fin, d.tail_link_m, out=into("tip_x"))
    tip_x += d.pivot_offset_m
    tip_y = np.multiply(sin_fin, d.tail_link_m, out=into("tip_y"))
    tip_x_dot = np.multiply(tip_y, theta2_dot, out=into("tip_x_dot"))
    np.negative(tip_x_dot, out=tip_x_dot)
    tip_y_dot = np.multiply(cos_fin, theta2_dot, out=into("tip_y_dot"))
    tip_y_dot *= d.tail_link_m
    angle, velocity = (
        value if np.shape(value) == shape else np.broadcast_to(value, shape)
        for value in (phi, phi_dot)
    )
    state = OscillatoryState(
        angle, velocity, op, op_dot, theta1, theta1_dot, theta2, theta2_dot, theta3,
        theta2_dot, tip_x, tip_y, tip_x_dot, tip_y_dot, fin_angle, theta2_dot,
    )  # fmt: skip
    return state, cos_fin, sin_fin


#: What :func:`drive_pose` returns, in order (theta3_dot and fin_angle_dot are theta2_dot; the
#: fin angle is the tail link's from the body axis, theta2 minus its mounting; sin_beta is asin's
#: argument K, theta2 = atan2(OS, OP) + asin K, and theta1 = atan2(sin_theta1, cos_theta1)).
DRIVE_POSE_FIELDS = (
    "slider_position", "slider_velocity", "theta1", "theta1_dot", "theta2", "theta2_dot", "theta3",
    "tip_x", "tip_y", "tip_x_dot", "tip_y_dot", "fin_angle", "cos_fin", "sin_fin", "sin_beta",
    "cos_theta1", "sin_theta1",
)  # fmt: skip
#: :func:`drive_pose`'s floats, named by :data:`DRIVE_POSE_FIELDS`.
DrivePose: TypeAlias = tuple[
    float, float, float, float, float, float, float, float, float, float, float, float, float,
    float, float, float, float,
]  # fmt: skip


def drive_pose(
    cos_carrier: float,
    sin_carrier: float,
    phi_dot: float,
    ring_radius_m: float,
    pivot_offset_m: float,
    tail_link_m: float,
    theta2_mid: float,
    tail_mounting_rad: float,
    minus_ring_radius_m: float,
    offset_squared: float,
    k_constant: float,
    half_inverse_rocker: float,
    rocker_over_crank: float,
    minus_rocker_over_crank: float,
    offset_over_crank: float,
    inverse_crank: float,
    inverse_rocker: float,
    cos_mounting: float,
    sin_mounting: float,
) -> DrivePose:
    """Mechanism 1's pose and rates at one carrier angle, from its cosine and sine (phi + psi).

    The scalar formula of the engine, written once: :class:`OscillatoryTail`'s float path calls
    it, and compiled code (numba) calls it as it stands: plain arithmetic and ``math``, the same
    operations in the same order as :func:`solve_drive_arrays`, so that the paths agree to
    rounding. It takes the carrier angle's cosine and sine, not the angle, so that a caller
    stepping a known angle by a small one can use the angle-sum identities, and the linkage as
    its :class:`DriveCoefficients` (``drive_coefficients``), so that no division repeats what
    the lengths alone give. Only cos/sin of the carrier, two square roots, atan2 twice and asin
    once: every other sine and cosine follows from angle-sum identities, and compiled callers
    that use neither angle skip the inverse functions (or take them from asin's and atan2's
    arguments, returned too). Not checked: a linkage that does not assemble gives NaN (raises on
    Python floats, where ``math`` refuses). A plain tuple, in the order of
    :data:`DRIVE_POSE_FIELDS`: the float path runs per message, where building a named tuple
    would cost a tenth of the solve.
    """
    op = cos_carrier * ring_radius_m
    op_dot = sin_carrier * phi_dot * minus_ring_radius_m
    # alpha = atan2(OS, OP), beta = asin K, theta2 = alpha + beta.
    op_squared = op * op
    distance = math.sqrt(op_squared + offset_squared)
    k = (op_squared + k_constant) / distance * half_inverse_rocker
    cos_alpha = op / distance
    sin_alpha = pivot_offset_m / distance
    theta2 = math.atan2(pivot_offset_m, op) + math.asin(k)
    cos_beta = math.sqrt((1.0 - k) * (1.0 + k))
    sin2 = sin_alpha * cos_beta + cos_alpha * k
    cos2 = cos_alpha * cos_beta - sin_alpha * k
    # Joint R relative to P, scaled by 1/PR: (cos theta1, -sin theta1).
    cos1 = cos2 * rocker_over_crank + offset_over_crank
    sin1 = sin2 * minus_rocker_over_crank + op * inverse_crank
    theta1 = math.atan2(sin1, cos1)
    # sin(theta1 + theta2) vanishes only when PR and RS are collinear, which assembly excludes.
    rate = op_dot / (sin1 * cos2 + cos1 * sin2)
    theta2_dot = rate * sin1 * inverse_rocker
    theta1_dot = rate * sin2 * inverse_crank
    sin_fin = sin2 * cos_mounting - cos2 * sin_mounting
    cos_fin = cos2 * cos_mounting + sin2 * sin_mounting
    tip_y = sin_fin * tail_link_m
    return (
        op, op_dot, theta1, theta1_dot, theta2, theta2_dot, theta2 - theta2_mid,
        cos_fin * tail_link_m + pivot_offset_m, tip_y, -(tip_y * theta2_dot),
        cos_fin * theta2_dot * tail_link_m, theta2 - tail_mounting_rad, cos_fin, sin_fin, k, cos1,
        sin1,
    )  # fmt: skip
