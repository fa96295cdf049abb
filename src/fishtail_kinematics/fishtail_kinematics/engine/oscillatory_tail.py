"""Mechanism 1: the Cardan point P drives the slider-rocker PR-RS, and the tail ST turns with RS.

The shared surface is :class:`~fishtail_kinematics.engine.tail_base.Tail`; the equations:
docs/kinematics.md ("Mechanism 1").
"""

from __future__ import annotations

import copy
import math
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
        self._cos_mounting, self._sin_mounting = math.cos(mounting), math.sin(mounting)
        #: The numbers of the array path (:func:`solve_drive_arrays`).
        self.constants = DriveConstants(
            self._R, self._PR, self._RS, self._ST, self._OS, self._psi, self.theta2_mid,
            mounting, self.theta2_mid == mounting,
        )  # fmt: skip

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
            tip_y_dot, fin_angle, _, _,
        ) = drive_pose(
            math.cos(carrier), math.sin(carrier), phi_dot, self._R, self._PR, self._RS, self._ST,
            self._OS, self.theta2_mid, self.tail_mounting_rad, self._cos_mounting,
            self._sin_mounting,
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


def solve_drive_arrays(
    c: DriveConstants, phi: FloatArray, phi_dot: FloatArray
) -> tuple[OscillatoryState, FloatArray, FloatArray]:
    """Mechanism 1 at carrier angles ``phi`` and speeds ``phi_dot`` (arrays), and the tail trig.

    Returns the state and cos, sin of the tail link's angle from the body axis. Inputs are not
    checked here (a linkage that cannot assemble gives NaN): :class:`OscillatoryTail` checks them.
    """
    k_constant = c.rocker_link_m**2 + c.pivot_offset_m**2 - c.crank_link_m**2
    cos_mounting, sin_mounting = np.cos(c.tail_mounting_rad), np.sin(c.tail_mounting_rad)
    # np.sin/np.cos/np.hypot cost ~8 ns a sample in float64, the algebra below ~0.5 ns an
    # operation: so only the carrier angle goes through trigonometry, every other sine and
    # cosine comes from the angle-sum identities, and the work is done in place.
    phi, phi_dot = np.broadcast_arrays(phi, phi_dot)
    carrier = phi + c.phase_rad
    cos_carrier = np.cos(carrier)
    sin_carrier = np.sin(carrier, out=carrier)
    op = np.multiply(cos_carrier, c.ring_radius_m, out=cos_carrier)
    op_dot = np.multiply(sin_carrier, phi_dot, out=sin_carrier)
    op_dot *= -c.ring_radius_m
    # alpha = atan2(OS, OP), beta = asin K, theta2 = alpha + beta.
    distance = np.square(op)
    k = distance + k_constant
    distance += c.pivot_offset_m**2
    np.sqrt(distance, out=distance)
    k /= distance
    k *= 0.5 / c.rocker_link_m
    cos_alpha = op / distance
    sin_alpha = np.divide(c.pivot_offset_m, distance, out=distance)
    theta2 = np.arctan2(c.pivot_offset_m, op)
    theta2 += np.arcsin(k)
    cos_beta = 1.0 - k
    cos_beta *= 1.0 + k
    np.sqrt(cos_beta, out=cos_beta)
    sin2 = sin_alpha * cos_beta
    sin2 += cos_alpha * k
    cos2 = np.multiply(cos_alpha, cos_beta, out=cos_alpha)
    cos2 -= np.multiply(sin_alpha, k, out=k)
    # Joint R relative to P, scaled by 1/PR: (cos theta1, -sin theta1).
    cos1 = np.multiply(cos2, c.rocker_link_m / c.crank_link_m, out=cos_beta)
    cos1 += c.pivot_offset_m / c.crank_link_m
    sin1 = np.multiply(sin2, -c.rocker_link_m / c.crank_link_m, out=sin_alpha)
    sin1 += op * (1.0 / c.crank_link_m)
    theta1 = np.arctan2(sin1, cos1)
    sin_sum = sin1 * cos2
    sin_sum += cos1 * sin2
    rate = np.divide(op_dot, sin_sum, out=sin_sum)
    theta2_dot = rate * sin1
    theta2_dot *= 1.0 / c.rocker_link_m
    theta1_dot = np.multiply(rate, sin2, out=rate)
    theta1_dot *= 1.0 / c.crank_link_m
    theta3 = theta2 - c.theta2_mid
    # Unshifted, the body-frame angle is theta3 itself: the same array, no extra pass.
    fin_angle = theta3 if c.mounted_at_mid else theta2 - c.tail_mounting_rad
    sin_fin = sin2 * cos_mounting
    sin_fin -= cos2 * sin_mounting
    cos_fin = np.multiply(cos2, cos_mounting, out=cos2)
    cos_fin += sin2 * sin_mounting
    tip_x = cos_fin * c.tail_link_m
    tip_x += c.pivot_offset_m
    tip_y = sin_fin * c.tail_link_m
    tip_x_dot = tip_y * theta2_dot
    np.negative(tip_x_dot, out=tip_x_dot)
    tip_y_dot = cos_fin * theta2_dot
    tip_y_dot *= c.tail_link_m
    state = OscillatoryState(
        phi, phi_dot, op, op_dot, theta1, theta1_dot, theta2, theta2_dot, theta3, theta2_dot,
        tip_x, tip_y, tip_x_dot, tip_y_dot, fin_angle, theta2_dot,
    )  # fmt: skip
    return state, cos_fin, sin_fin


#: What :func:`drive_pose` returns, in order (theta3_dot and fin_angle_dot are theta2_dot; the
#: fin angle is the tail link's from the body axis, theta2 minus its mounting).
DRIVE_POSE_FIELDS = (
    "slider_position", "slider_velocity", "theta1", "theta1_dot", "theta2", "theta2_dot", "theta3",
    "tip_x", "tip_y", "tip_x_dot", "tip_y_dot", "fin_angle", "cos_fin", "sin_fin",
)  # fmt: skip
#: :func:`drive_pose`'s floats, named by :data:`DRIVE_POSE_FIELDS`.
DrivePose: TypeAlias = tuple[
    float, float, float, float, float, float, float, float, float, float, float, float, float,
    float,
]  # fmt: skip


def drive_pose(
    cos_carrier: float,
    sin_carrier: float,
    phi_dot: float,
    ring_radius_m: float,
    crank_link_m: float,
    rocker_link_m: float,
    tail_link_m: float,
    pivot_offset_m: float,
    theta2_mid: float,
    tail_mounting_rad: float,
    cos_mounting: float,
    sin_mounting: float,
) -> DrivePose:
    """Mechanism 1's pose and rates at one carrier angle, from its cosine and sine (phi + psi).

    The scalar formula of the engine, written once: :class:`OscillatoryTail`'s float path calls
    it, and compiled code (numba) calls it as it stands: plain arithmetic and ``math``, the same
    operations in the same order as :func:`solve_drive_arrays`, so that the paths agree to
    rounding. It takes the carrier angle's cosine and sine, not the angle, so that a caller
    stepping a known angle by a small one can use the angle-sum identities; the mounting's are
    the linkage's constants. Only cos/sin of the carrier, two square roots, atan2 twice and asin
    once: every other sine and cosine follows from angle-sum identities, and compiled callers
    that use neither angle skip the inverse functions. Not checked: a linkage that does not
    assemble gives NaN (raises on Python floats, where ``math`` refuses). A plain tuple, in the
    order of :data:`DRIVE_POSE_FIELDS`: the float path runs per message, where building a named
    tuple would cost a tenth of the solve.
    """
    os_, rs, pr = pivot_offset_m, rocker_link_m, crank_link_m
    op = cos_carrier * ring_radius_m
    op_dot = sin_carrier * phi_dot * -ring_radius_m
    # alpha = atan2(OS, OP), beta = asin K, theta2 = alpha + beta.
    op_squared = op * op
    distance = math.sqrt(op_squared + os_**2)
    k = (op_squared + (rs**2 + os_**2 - pr**2)) / distance * (0.5 / rs)
    cos_alpha = op / distance
    sin_alpha = os_ / distance
    theta2 = math.atan2(os_, op) + math.asin(k)
    cos_beta = math.sqrt((1.0 - k) * (1.0 + k))
    sin2 = sin_alpha * cos_beta + cos_alpha * k
    cos2 = cos_alpha * cos_beta - sin_alpha * k
    # Joint R relative to P, scaled by 1/PR: (cos theta1, -sin theta1).
    cos1 = cos2 * (rs / pr) + os_ / pr
    sin1 = sin2 * (-rs / pr) + op * (1.0 / pr)
    theta1 = math.atan2(sin1, cos1)
    # sin(theta1 + theta2) vanishes only when PR and RS are collinear, which assembly excludes.
    rate = op_dot / (sin1 * cos2 + cos1 * sin2)
    theta2_dot = rate * sin1 * (1.0 / rs)
    theta1_dot = rate * sin2 * (1.0 / pr)
    sin_fin = sin2 * cos_mounting - cos2 * sin_mounting
    cos_fin = cos2 * cos_mounting + sin2 * sin_mounting
    tip_y = sin_fin * tail_link_m
    return (
        op, op_dot, theta1, theta1_dot, theta2, theta2_dot, theta2 - theta2_mid,
        cos_fin * tail_link_m + os_, tip_y, -(tip_y * theta2_dot),
        cos_fin * theta2_dot * tail_link_m, theta2 - tail_mounting_rad, cos_fin, sin_fin,
    )  # fmt: skip
