"""Mechanism 2: mechanism 1's drive, plus the slotted link AV and the second tail joint VT.

The shared surface is :class:`~fishtail_kinematics.engine.tail_base.Tail`; the equations:
docs/kinematics.md ("Mechanism 2").
"""

from __future__ import annotations

import bisect
import copy
import math
from typing import cast

import numpy as np
import numpy.typing as npt

from fishtail_kinematics.engine.arm_sweep import ArmSweep, last_working_shift
from fishtail_kinematics.engine.block_solve import solve_arrays
from fishtail_kinematics.engine.errors import (
    AssemblyError,
    InvalidLengthError,
    PinOffsetError,
    PivotShiftError,
    SolverError,
)
from fishtail_kinematics.engine.geometry import (
    UNDULATORY,
    FloatArray,
    LinkageState,
    OscillatoryState,
    Real,
    UndulatoryGeometry,
    UndulatoryState,
)
from fishtail_kinematics.engine.link_motion import (
    BodyMotion,
    undulatory_link_motion,
)
from fishtail_kinematics.engine.linkage_points import (
    UndulatoryPoints,
    undulatory_points,
)
from fishtail_kinematics.engine.loop_pose import (
    LOOP_NEWTON_STEPS,
    loop_closure,
    loop_rates,
    loop_residual_and_slope,
    loop_tip,
    residual_tolerance,
)
from fishtail_kinematics.engine.oscillatory_tail import OscillatoryTail
from fishtail_kinematics.engine.tail_base import (
    ScalarOrArray,
    Tail,
    check_pivot_shift,
)

# Samples of the continuation sweep that validates mechanism 2 and seeds its Newton solver. The
# seed interpolates them linearly: within about 1e-7 m of the branch's root on the report's
# geometry (h^2/8 of AS's curvature), so two Newton steps reach rounding level, and never farther
# from it than the branch bends between two samples, so the solve stays on the branch (a single
# polynomial over the swing, fitted to the same samples, was up to 1 cm off on random designs).
_CONTINUATION_SAMPLES = 2001
# Samples of a shifted swing's branch the seed keeps (the sweep's own steps, at most this many).
_SHIFTED_SEED_SAMPLES = 4096
# The feasible pivot shifts of mechanism 2: grid steps from zero to each end of the drive's
# interval, and the bisection's tolerance where the second loop first fails.
_RANGE_GRID = 64
_RANGE_TOLERANCE_M = 1e-9
_LIMITS = (
    "the drive's |RS - PR| < OS + shift and (OS + shift)^2 + R^2 < (RS + PR)^2, and the second "
    "loop on the straight pose's branch over SW's swing, found numerically"
)


class UndulatoryTail(Tail):
    """Mechanism 2: the drive of mechanism 1 plus the slotted link AV and the tail VT.

    The loop A-U-V-W is solved for AS by Newton's method, seeded by interpolating in theta3 a
    continuation sweep from the straight pose made on construction; construction therefore also
    proves that the branch exists over the whole swing.

    Raises:
        PinOffsetError: the pin U outside 0 < SU < SW - VW.
        InvalidLengthError: VW not shorter than VT, or a length the geometry refuses.
        AssemblyError: the drive or the second loop cannot assemble over the whole swing.
        SolverError: the loop does not close to tolerance (at or near a toggle pose).

    >>> tail = UndulatoryTail(UndulatoryGeometry())
    >>> state = tail.solve(0.0)
    >>> round(state.theta5, 4)
    -0.5684
    """

    name = UNDULATORY
    geometry_type = UndulatoryGeometry
    state_type = UndulatoryState
    state_fields = UndulatoryState._fields
    joint_names = ("theta1", "theta2", "theta3", "theta4", "theta5")
    fin_joint = "theta5"
    links = (
        "carrier", "planet", "crank_link", "rocker_link",
        "swing_arm", "slider", "slotted_link", "fin_link",
    )  # fmt: skip
    geometry: UndulatoryGeometry

    def __init__(self, geometry: UndulatoryGeometry) -> None:
        """Validate ``geometry`` over the whole swing and fit the solver's seed."""
        super().__init__(geometry)
        g = geometry
        limit = g.swing_arm_m - g.fin_joint_offset_m
        if not 0.0 < g.pin_offset_m < limit:
            raise PinOffsetError(
                f"0 < SU < SW - VW fails: SU = {g.pin_offset_m:.6f} m, "
                f"SW - VW = {limit:.6f} m (outside by "
                f"{max(-g.pin_offset_m, g.pin_offset_m - limit):.6f} m)"
            )
        if not g.fin_joint_offset_m < g.fin_link_m:
            raise InvalidLengthError(
                f"VW < VT fails: VW = {g.fin_joint_offset_m:.6f} m, VT = {g.fin_link_m:.6f} m"
            )
        self._drive = OscillatoryTail(g.drive())
        self._SU = g.pin_offset_m
        self._SW = g.swing_arm_m
        self._AV = g.slotted_link_m
        self._VW = g.fin_joint_offset_m
        self._WT = g.fin_link_m - g.fin_joint_offset_m
        self._OS = g.pivot_offset_m
        # Each sample stops at the tolerance on its own (so a sample's result does not depend on
        # its batch); the tip T lies beyond W, VT/VW times as far off, and rounding sits some
        # 1000x below at the report's sizes.
        self._residual_tolerance = float(residual_tolerance(self._VW))
        self.straight_slider_a_distance = self._AV + self._VW - self._SW
        if self.straight_slider_a_distance <= 0.0:
            raise AssemblyError(
                f"AV + VW > SW fails: the straight pose puts A at AS = "
                f"{self.straight_slider_a_distance:.6f} m, not behind S"
            )
        self._fit_seed()
        self._unshifted = self
        # Built when a pivot shift is first asked for: the branch beyond the design's swing.
        self._arm_sweep: ArmSweep | None = None
        self._shift_range: tuple[float, float] | None = None

    @property
    def drive(self) -> OscillatoryTail:
        """The mechanism-1 drive, whose tail link is SW."""
        return self._drive

    def pivot_shift_range(self) -> tuple[float, float]:
        """The open interval of shifts at which both loops work over the whole stroke.

        The drive's interval is closed form; within it the second loop must follow SW's swing at
        the shift (:meth:`_arm_swing`) on the branch of the straight pose. That is found
        numerically: the shifts on a grid of :data:`_RANGE_GRID` steps out from zero to each end
        of the drive's interval, and bisection where the first one fails, to
        :data:`_RANGE_TOLERANCE_M`. Computed once per design geometry (docs/kinematics.md gives
        the cost).
        """
        unshifted = self._unshifted
        if unshifted._shift_range is None:
            drive_range = unshifted._drive.pivot_shift_range()
            unshifted._shift_range = (
                unshifted._shift_limit(drive_range[0]),
                unshifted._shift_limit(drive_range[1]),
            )
        return unshifted._shift_range

    def with_pivot_shift(self, pivot_shift_m: float) -> UndulatoryTail:
        """This linkage with S at OS + ``pivot_shift_m``; SW keeps its mounting on the rocker.

        The second loop is the design's (it depends on SW's body-frame angle only, see
        :mod:`~fishtail_kinematics.engine.arm_sweep`); its branch is followed over the shifted
        swing and the solver's seed refitted there. The unshifted tail itself is returned for
        zero.

        Raises:
            PivotShiftError: a shift that is not finite or outside :meth:`pivot_shift_range`.
        """
        shift = float(pivot_shift_m)
        unshifted = self._unshifted
        feasible = unshifted.pivot_shift_range()
        check_pivot_shift(shift, feasible, _LIMITS)
        if shift == 0.0:
            return unshifted
        drive = unshifted._drive.with_pivot_shift(shift)
        low, high = unshifted._arm_swing(drive)
        reason = unshifted._sweep().cover(low, high)
        if reason is not None:
            # Only within the bisection's tolerance of an end of the feasible range.
            raise PivotShiftError(
                f"pivot shift {shift:.6f} m: the second loop cannot follow SW over "
                f"[{low:.6f}, {high:.6f}] rad from the body axis ({reason}); the feasible range "
                f"is {feasible[0]:.6f} m < shift < {feasible[1]:.6f} m ({_LIMITS})"
            )
        tail = copy.copy(unshifted)
        tail._pivot_shift_m = shift
        tail._shifted_geometry = None
        tail._drive = drive
        tail._OS = unshifted._OS + shift
        tail._set_seed(*unshifted._sweep().samples(low, high, _SHIFTED_SEED_SAMPLES))
        return tail

    def _arm_swing(self, drive: OscillatoryTail) -> tuple[float, float]:
        """SW's extreme angles from the body axis over the stroke of a (shifted) drive."""
        return (
            drive.theta2_min - drive.tail_mounting_rad,
            drive.theta2_max - drive.tail_mounting_rad,
        )

    def _sweep(self) -> ArmSweep:
        if self._arm_sweep is None:
            self._arm_sweep = ArmSweep(self._pose_on_branch, self.straight_slider_a_distance)
        return self._arm_sweep

    def _second_loop_works(self, shift: float) -> bool:
        drive = self._drive.with_pivot_shift(shift)
        return self._sweep().cover(*self._arm_swing(drive)) is None

    def _shift_limit(self, drive_limit: float) -> float:
        """How far towards ``drive_limit`` (an end of the drive's open interval) shifts work."""
        return last_working_shift(
            self._second_loop_works, drive_limit, _RANGE_GRID, _RANGE_TOLERANCE_M
        )

    # The loop, written relative to S with a = AS: A = (-a, 0), U = SU e(theta3),
    # theta4 = direction A->U, V = A + AV e(theta4), and W = SW e(theta3) must lie at VW from V.
    def _residual_and_slope(
        self, a: ScalarOrArray, cos3: ScalarOrArray, sin3: ScalarOrArray
    ) -> tuple[ScalarOrArray, ScalarOrArray]:
        return cast(
            tuple[ScalarOrArray, ScalarOrArray],
            loop_residual_and_slope(a, cos3, sin3, self._SU, self._SW, self._AV, self._VW),
        )

    def _fit_seed(self) -> None:
        drive = self.drive
        theta3_low = drive.theta2_min - drive.theta2_mid
        theta3_high = drive.theta2_max - drive.theta2_mid
        half = _CONTINUATION_SAMPLES // 2
        sweeps = (np.linspace(0.0, theta3_low, half + 1), np.linspace(0.0, theta3_high, half + 1))
        thetas, solutions = [], []
        for first, sweep in enumerate(sweeps):
            a = self.straight_slider_a_distance
            # The straight pose once: the second sweep starts from it again.
            for theta3 in sweep[first:]:
                a = self._pose_on_branch(float(theta3), a)
                thetas.append(theta3)
                solutions.append(a)
        self._set_seed(np.array(thetas), np.array(solutions))

    def _set_seed(self, arm_angles: FloatArray, slider_distances: FloatArray) -> None:
        order = np.argsort(arm_angles, kind="stable")
        self._seed_angles = np.ascontiguousarray(arm_angles[order])
        self._seed_distances = np.ascontiguousarray(slider_distances[order])
        # The scalar path's copies: bisect and float arithmetic on lists beat numpy per call.
        self._seed_angle_list: list[float] = self._seed_angles.tolist()
        self._seed_distance_list: list[float] = self._seed_distances.tolist()

    def _seed_at(self, theta3: float) -> float:
        """The seed AS at one arm angle: np.interp's value (its formula), from the lists."""
        angles, distances = self._seed_angle_list, self._seed_distance_list
        if theta3 <= angles[0]:
            return distances[0]
        if theta3 >= angles[-1]:
            return distances[-1]
        right = bisect.bisect_right(angles, theta3)
        left = right - 1
        slope = (distances[right] - distances[left]) / (angles[right] - angles[left])
        return slope * (theta3 - angles[left]) + distances[left]

    def _pose_on_branch(self, theta3: float, a: float) -> float:
        """AS for SW at ``theta3`` from the body axis, continued from the nearby AS = ``a``.

        Raises AssemblyError (toggle pose, pin out of the slot, A past S) or SolverError.
        """
        cos3, sin3 = math.cos(theta3), math.sin(theta3)
        for _ in range(50):
            residual, slope = self._residual_and_slope(a, cos3, sin3)
            if not abs(slope) > 1e-9:
                raise AssemblyError(
                    f"mechanism 2 reaches a toggle pose at theta3 = {theta3:.6f} rad "
                    f"(loop slope {slope:.3e}): the linkage locks"
                )
            a -= residual / slope
            if abs(residual) < 1e-15:
                break
        residual, _ = self._residual_and_slope(a, cos3, sin3)
        if not abs(residual) < 1e-12:
            raise SolverError(
                f"mechanism 2 loop does not close at theta3 = {theta3:.6f} rad "
                f"(residual {residual:.3e} m^2)"
            )
        self._check_pose(theta3, a, cos3, sin3)
        return a

    def _check_pose(self, theta3: float, a: float, cos3: float, sin3: float) -> None:
        au = math.hypot(a + self._SU * cos3, self._SU * sin3)
        if not 0.0 < au < self._AV:
            raise AssemblyError(
                f"pin U leaves the slot of AV at theta3 = {theta3:.6f} rad: AU = {au:.6f} m, "
                f"slot 0..{self._AV:.6f} m"
            )
        if not a > 0.0:
            raise AssemblyError(
                f"slider A passes S at theta3 = {theta3:.6f} rad: AS = {a:.6f} m must stay > 0"
            )

    def solve(
        self,
        motor_angle: npt.ArrayLike,
        motor_velocity: npt.ArrayLike = 0.0,
        *,
        out: LinkageState | None = None,
        workers: int | None = None,
    ) -> UndulatoryState:
        """Pose and rates for carrier angle phi [rad] and speed phi_dot [rad/s].

        Floats take the scalar path; anything else is treated as arrays and broadcast together,
        in blocks, into ``out`` if given, on up to ``workers`` threads (see :meth:`Tail.solve`).

        Raises:
            InvalidInputError: a non-finite angle or speed, or an unusable ``out``.
            SolverError: the loop did not close to tolerance.
        """
        scalars = isinstance(motor_angle, (float, int)) and isinstance(motor_velocity, (float, int))
        if scalars and out is None:
            return self._solve_scalar(self._drive.solve(float(motor_angle), float(motor_velocity)))  # type: ignore[arg-type]
        return solve_arrays(
            self._solve_array_path, UndulatoryState, motor_angle, motor_velocity,
            cast(UndulatoryState | None, out), workers,
        )  # fmt: skip

    def link_points(self, state: LinkageState) -> UndulatoryPoints:
        """Every joint of ``state`` (an undulatory state) in the frame at O."""
        return undulatory_points(
            cast(UndulatoryGeometry, self.shifted_geometry),
            cast(UndulatoryState, state),
            self.swing_bias_rad,
        )

    def link_motion(self, state: LinkageState) -> tuple[BodyMotion, ...]:
        """The drive, SW, the slider A, AV and VT (``state`` an undulatory state)."""
        return undulatory_link_motion(
            cast(UndulatoryGeometry, self.shifted_geometry),
            self._drive.tail_mounting_rad,
            cast(UndulatoryState, state),
            self.swing_bias_rad,
        )

    def _solve_array_path(self, phi: FloatArray, phi_dot: FloatArray) -> UndulatoryState:
        return self._solve_array(*self._drive.solve_array_with_tail_trig(phi, phi_dot))

    def _solve_scalar(self, d: OscillatoryState) -> UndulatoryState:
        # The loop turns with SW's angle to the body axis (theta3 + the swing bias).
        theta3 = cast(float, d.fin_angle)
        cos3, sin3 = math.cos(theta3), math.sin(theta3)
        a = self._seed_at(theta3)
        su, sw, vw = self._SU, self._SW, self._VW
        a, au, cos4, sin4, ex, ey, residual, _, closed = loop_closure(
            a, su * cos3, su * sin3, sw * cos3, sw * sin3, self._AV, vw * vw,
            self._residual_tolerance,
        )  # fmt: skip
        if not closed:
            raise SolverError(
                f"mechanism 2 loop does not close at theta3 = {theta3!r} rad "
                f"(residual {residual:.3e} m^2)"
            )
        # The last evaluation's W - V is VW e(theta5).
        cos5 = ex / vw
        sin5 = ey / vw
        rates = self._rates(d.fin_angle_dot, cos3, sin3, cos4, sin4, cos5, sin5, au)
        theta4 = math.atan2(sin4, cos4)
        theta5 = math.atan2(sin5, cos5)
        return self._assemble(d, theta4, au, a, theta5, cos3, sin3, cos5, sin5, rates)

    def _solve_array(
        self, d: OscillatoryState, cos3: FloatArray, sin3: FloatArray
    ) -> UndulatoryState:
        # cos3, sin3 and the seed's variable are those of SW's angle to the body axis.
        a = cast(FloatArray, np.interp(d.fin_angle, self._seed_angles, self._seed_distances))
        residual, slope = self._residual_and_slope(a, cos3, sin3)
        step = residual / slope
        for _ in range(LOOP_NEWTON_STEPS):
            a -= step
            residual, slope = self._residual_and_slope(a, cos3, sin3)
            # Written so that a NaN residual counts as not converged.
            open_loop = ~(np.abs(residual) < self._residual_tolerance)
            if not open_loop.any():
                break
            # Only the samples still open take another step (a - 0 is a), so that each sample's
            # result is the same whatever batch or block it is solved in.
            step = np.divide(residual, slope, out=np.zeros_like(residual), where=open_loop)
        else:
            worst = float(np.max(np.abs(residual), initial=0.0))
            raise SolverError(f"mechanism 2 loop residual up to {worst:.3e} m^2 in this batch")
        dx = a + self._SU * cos3
        dy = self._SU * sin3
        au = np.sqrt(dx * dx + dy * dy)
        cos4, sin4 = dx / au, dy / au
        cos5 = (self._SW * cos3 + a - self._AV * cos4) / self._VW
        sin5 = (self._SW * sin3 - self._AV * sin4) / self._VW
        rates = self._rates(d.fin_angle_dot, cos3, sin3, cos4, sin4, cos5, sin5, au)
        theta4 = np.arctan2(sin4, cos4)
        theta5 = np.arctan2(sin5, cos5)
        return self._assemble(d, theta4, au, a, theta5, cos3, sin3, cos5, sin5, rates)

    def _rates(
        self,
        theta3_dot: Real,
        cos3: Real,
        sin3: Real,
        cos4: Real,
        sin4: Real,
        cos5: Real,
        sin5: Real,
        au: Real,
    ) -> tuple[Real, Real, Real, Real]:
        # Time derivatives of the four loop equations, solved in closed form (docs/kinematics.md).
        return loop_rates(
            theta3_dot, cos3, sin3, cos4, sin4, cos5, sin5, au, self._SU, self._SW, self._AV,
            self._VW,
        )  # fmt: skip

    def _assemble(
        self,
        d: OscillatoryState,
        theta4: Real,
        au: Real,
        a: Real,
        theta5: Real,
        cos3: Real,
        sin3: Real,
        cos5: Real,
        sin5: Real,
        rates: tuple[Real, Real, Real, Real],
    ) -> UndulatoryState:
        theta4_dot, au_rate, slider_rate, theta5_dot = rates
        t3_dot = d.fin_angle_dot
        tip_x, tip_y, tip_x_dot, tip_y_dot = loop_tip(
            self._OS, self._SW, self._WT, cos3, sin3, cos5, sin5, t3_dot, theta5_dot
        )
        return UndulatoryState(
            d.motor_angle, d.motor_velocity, d.slider_position, d.slider_velocity,
            d.theta1, d.theta1_dot, d.theta2, d.theta2_dot, d.theta3, d.theta3_dot,
            tip_x, tip_y, tip_x_dot, tip_y_dot,
            theta4, theta4_dot, au, au_rate, a, slider_rate, theta5, theta5_dot,
            theta5, theta5_dot,
        )  # fmt: skip
