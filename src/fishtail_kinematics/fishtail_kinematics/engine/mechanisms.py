"""The tail linkages: a Cardan (Tusi) couple drives a slider-rocker, optionally a second tail joint.

Conventions (see ``docs/kinematics.md``): O = (0, 0) is the ring-gear centre, +x points back
along the body towards the tail, +y to the left, angles counter-clockwise, SI units.

* Mechanism 1 (oscillatory): the Cardan point P = (0, OP), OP = R cos(phi + psi), drives the
  link PR; RS turns about the body pivot S = (OS, 0) and carries the tail ST, so
  theta3 = theta2 - mid-swing.
* Mechanism 2 (undulatory): SW turns with RS; the pin U on SW rides in the slot of AV, whose end A
  slides along the body axis; VT is hinged to AV at V and to SW at W.

Every solver takes either Python floats (the per-message path, ``math`` only) or numpy arrays
(vectorised, no per-sample Python loop) and returns a named tuple of the same kind. Both tails
offer their callers one surface, :class:`Tail` (name, joints, state fields, solving, the points
to draw, the parameters they use), so that no caller needs to know which mechanism it drives.

>>> from fishtail_kinematics.engine.geometry import OscillatoryGeometry
>>> tail = OscillatoryTail(OscillatoryGeometry())
>>> round(math.degrees(tail.swing_range_rad), 2)
53.13
>>> state = tail.solve(0.0, 4.0)
>>> round(state.theta3, 4), round(state.tip_x, 4)
(-0.4636, 0.3342)
"""

from __future__ import annotations

import abc
import math
from collections.abc import Callable
from typing import ClassVar, TypeVar, cast

import numpy as np
import numpy.typing as npt

from fishtail_common.parameters import ParameterSpec
from fishtail_kinematics.engine.errors import (
    AssemblyError,
    InvalidInputError,
    InvalidLengthError,
    PinOffsetError,
    SolverError,
)
from fishtail_kinematics.engine.geometry import (
    GEOMETRY_PARAMETERS,
    OSCILLATORY,
    UNDULATORY,
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
    oscillatory_link_motion,
    undulatory_link_motion,
)
from fishtail_kinematics.engine.linkage_points import (
    LinkagePoints,
    OscillatoryPoints,
    UndulatoryPoints,
    oscillatory_points,
    undulatory_points,
)

# Loop-closure tolerance of the undulatory solver: how far W may sit off its circle about V.
_CLOSURE_TOLERANCE_M = 1e-12
# Samples of the continuation sweep that validates mechanism 2 and seeds its Newton solver.
_CONTINUATION_SAMPLES = 2001
# A degree-10 seed is within ~1e-12 m of the root on the report's geometry, so one Newton step
# reaches rounding level; more steps run only where the closure check asks for them.
_SEED_POLYNOMIAL_DEGREE = 10
_MAX_NEWTON_STEPS = 8


def _check_finite_scalars(phi: float, phi_dot: float) -> None:
    if not (math.isfinite(phi) and math.isfinite(phi_dot)):
        raise InvalidInputError(f"carrier angle {phi!r} and speed {phi_dot!r} must be finite")


_State = TypeVar("_State", OscillatoryState, UndulatoryState)
_Value = TypeVar("_Value", float, FloatArray)


def _zero_dimensional_safe(
    solver: Callable[[FloatArray, FloatArray], _State],
    motor_angle: npt.ArrayLike,
    motor_velocity: npt.ArrayLike,
) -> _State:
    # Non-finite input is refused rather than turned into NaN output. The array paths work in
    # place (out=...), which numpy refuses for 0-d results: solve those as one-element arrays and
    # hand back 0-d arrays.
    phi = np.asarray(motor_angle, float)
    phi_dot = np.asarray(motor_velocity, float)
    for name, values in (("carrier angle", phi), ("carrier speed", phi_dot)):
        if not np.isfinite(values).all():
            bad = np.flatnonzero(~np.isfinite(values.ravel()))
            raise InvalidInputError(
                f"{bad.size} non-finite {name} value(s), the first at flat index {bad[0]}: "
                f"{values.ravel()[bad[0]]!r}"
            )
    if phi.ndim or phi_dot.ndim:
        return solver(phi, phi_dot)
    state = solver(phi.reshape(1), phi_dot.reshape(1))
    return type(state)._make(np.asarray(value).reshape(()) for value in state)


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
    #: The moving bodies, named as in :mod:`~fishtail_kinematics.engine.link_inertia`.
    links: ClassVar[tuple[str, ...]]

    def __init__(self, geometry: Geometry) -> None:
        """Keep ``geometry``; subclasses validate it."""
        self.geometry = geometry

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
        """The state field of the last link's angle to the body axis: theta3 or the fin joint."""
        return cls.fin_joint or "theta3"

    @property
    @abc.abstractmethod
    def drive(self) -> OscillatoryTail:
        """The mechanism-1 drive (the tail itself for mechanism 1): swing range and extremes."""

    @abc.abstractmethod
    def solve(
        self, motor_angle: npt.ArrayLike, motor_velocity: npt.ArrayLike = 0.0
    ) -> LinkageState:
        """Pose and rates for carrier angle phi [rad] and speed phi_dot [rad/s].

        Floats take the scalar path; anything else is treated as arrays and broadcast together.
        """

    @abc.abstractmethod
    def link_points(self, state: LinkageState) -> LinkagePoints:
        """Every joint of ``state`` (solved by this tail) in the frame at O, for drawing."""

    @abc.abstractmethod
    def link_motion(self, state: LinkageState) -> tuple[BodyMotion, ...]:
        """Velocity and acceleration of every body of :attr:`links` at ``state``'s steady speed.

        At a carrier speed of 1 rad/s: the velocity ratios and their derivatives in phi.
        """


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
    link_difference = abs(rocker_link_m - crank_link_m)
    if not link_difference < pivot_offset_m:
        problems.append(
            f"|RS - PR| < OS fails: |RS - PR| = {link_difference:.6f} m is not less than "
            f"OS = {pivot_offset_m:.6f} m (exceeds it by {link_difference - pivot_offset_m:.6f} m)"
        )
    farthest = math.hypot(pivot_offset_m, ring_radius_m)
    reach = rocker_link_m + crank_link_m
    if not farthest < reach:
        problems.append(
            f"OS^2 + R^2 < (RS + PR)^2 fails: sqrt(OS^2 + R^2) = {farthest:.6f} m exceeds "
            f"RS + PR = {reach:.6f} m by {farthest - reach:.6f} m"
        )
    return problems


class OscillatoryTail(Tail):
    """Mechanism 1: carrier angle to theta1, theta2, theta3, the tail tip and all their rates.

    Construction validates the geometry (raises :class:`AssemblyError` naming the failed condition)
    and finds the exact swing extremes of theta2, also where theta2 is not monotone in OP.
    """

    name = OSCILLATORY
    geometry_type = OscillatoryGeometry
    state_fields = OscillatoryState._fields
    joint_names = ("theta1", "theta2", "theta3")
    fin_joint = None
    links = ("carrier", "planet", "crank_link", "rocker_link", "tail_link")
    geometry: OscillatoryGeometry

    def __init__(self, geometry: OscillatoryGeometry) -> None:
        """Validate ``geometry`` and precompute its swing extremes."""
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
        self._OS = g.pivot_offset_m
        self._psi = g.phase_rad
        # Constant part of the numerator of K, so the per-sample path adds only OP^2.
        self._k_constant = self._RS**2 + self._OS**2 - self._PR**2
        self.stationary_slider_positions = self._stationary_slider_positions()
        candidates = [-self._R, self._R, *self.stationary_slider_positions]
        values = [self.theta2_at(op) for op in candidates]
        self.theta2_min = min(values)
        self.theta2_max = max(values)
        self.slider_at_theta2_min = candidates[values.index(self.theta2_min)]
        self.slider_at_theta2_max = candidates[values.index(self.theta2_max)]
        self.theta2_mid = 0.5 * (self.theta2_min + self.theta2_max)
        self._cos_mid = math.cos(self.theta2_mid)
        self._sin_mid = math.sin(self.theta2_mid)
        self.swing_range_rad = self.theta2_max - self.theta2_min

    @property
    def drive(self) -> OscillatoryTail:
        """The tail itself: mechanism 1 is the drive."""
        return self

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
        self, motor_angle: npt.ArrayLike, motor_velocity: npt.ArrayLike = 0.0
    ) -> OscillatoryState:
        """Pose and rates for carrier angle phi [rad] and speed phi_dot [rad/s].

        Floats take the scalar path; anything else is treated as arrays and broadcast together.
        """
        if isinstance(motor_angle, (float, int)) and isinstance(motor_velocity, (float, int)):
            phi, phi_dot = float(motor_angle), float(motor_velocity)
            _check_finite_scalars(phi, phi_dot)
            return self._solve_scalar(phi, phi_dot)
        return _zero_dimensional_safe(self._solve_array, motor_angle, motor_velocity)

    def _solve_scalar(self, phi: float, phi_dot: float) -> OscillatoryState:
        carrier = phi + self._psi
        op = self._R * math.cos(carrier)
        op_dot = -self._R * phi_dot * math.sin(carrier)
        distance = math.hypot(op, self._OS)
        k = (op * op + self._k_constant) / (2.0 * self._RS * distance)
        theta2 = math.atan2(self._OS, op) + math.asin(k)
        sin2 = math.sin(theta2)
        cos2 = math.cos(theta2)
        theta1 = math.atan2(op - self._RS * sin2, self._OS + self._RS * cos2)
        sin1 = math.sin(theta1)
        cos1 = math.cos(theta1)
        # sin(theta1 + theta2) vanishes only when PR and RS are collinear, which assembly excludes.
        denominator = op_dot / (sin1 * cos2 + cos1 * sin2)
        theta2_dot = denominator * sin1 / self._RS
        theta1_dot = denominator * sin2 / self._PR
        theta3 = theta2 - self.theta2_mid
        sin3 = math.sin(theta3)
        cos3 = math.cos(theta3)
        return OscillatoryState(
            phi, phi_dot, op, op_dot, theta1, theta1_dot, theta2, theta2_dot, theta3, theta2_dot,
            self._OS + self._ST * cos3, self._ST * sin3,
            -self._ST * sin3 * theta2_dot, self._ST * cos3 * theta2_dot,
        )  # fmt: skip

    def link_points(self, state: LinkageState) -> OscillatoryPoints:
        """Every joint of ``state`` in the frame at O."""
        return oscillatory_points(self.geometry, state)

    def link_motion(self, state: LinkageState) -> tuple[BodyMotion, ...]:
        """Carrier, planet, PR, RS and ST (``state`` an oscillatory state)."""
        return oscillatory_link_motion(
            self.geometry, self.theta2_mid, cast(OscillatoryState, state)
        )

    def _solve_array(self, phi: FloatArray, phi_dot: FloatArray) -> OscillatoryState:
        return self.solve_array_with_tail_trig(phi, phi_dot)[0]

    def solve_array_with_tail_trig(
        self, phi: FloatArray, phi_dot: FloatArray
    ) -> tuple[OscillatoryState, FloatArray, FloatArray]:
        """The array path, with cos and sin of theta3 (mechanism 2 builds on them)."""
        # np.sin/np.cos/np.hypot cost ~8 ns a sample in float64, the algebra below ~0.5 ns an
        # operation: so only the carrier angle goes through trigonometry, every other sine and
        # cosine comes from the angle-sum identities, and the work is done in place.
        phi, phi_dot = np.broadcast_arrays(phi, phi_dot)
        carrier = phi + self._psi
        cos_carrier = np.cos(carrier)
        sin_carrier = np.sin(carrier, out=carrier)
        op = np.multiply(cos_carrier, self._R, out=cos_carrier)
        op_dot = np.multiply(sin_carrier, phi_dot, out=sin_carrier)
        op_dot *= -self._R
        # alpha = atan2(OS, OP), beta = asin K, theta2 = alpha + beta.
        distance = np.square(op)
        k = distance + self._k_constant
        distance += self._OS**2
        np.sqrt(distance, out=distance)
        k /= distance
        k *= 0.5 / self._RS
        cos_alpha = op / distance
        sin_alpha = np.divide(self._OS, distance, out=distance)
        theta2 = np.arctan2(self._OS, op)
        theta2 += np.arcsin(k)
        cos_beta = 1.0 - k
        cos_beta *= 1.0 + k
        np.sqrt(cos_beta, out=cos_beta)
        sin2 = sin_alpha * cos_beta
        sin2 += cos_alpha * k
        cos2 = np.multiply(cos_alpha, cos_beta, out=cos_alpha)
        cos2 -= np.multiply(sin_alpha, k, out=k)
        # Joint R relative to P, scaled by 1/PR: (cos theta1, -sin theta1).
        cos1 = np.multiply(cos2, self._RS / self._PR, out=cos_beta)
        cos1 += self._OS / self._PR
        sin1 = np.multiply(sin2, -self._RS / self._PR, out=sin_alpha)
        sin1 += op * (1.0 / self._PR)
        theta1 = np.arctan2(sin1, cos1)
        sin_sum = sin1 * cos2
        sin_sum += cos1 * sin2
        rate = np.divide(op_dot, sin_sum, out=sin_sum)
        theta2_dot = rate * sin1
        theta2_dot *= 1.0 / self._RS
        theta1_dot = np.multiply(rate, sin2, out=rate)
        theta1_dot *= 1.0 / self._PR
        theta3 = theta2 - self.theta2_mid
        sin3 = sin2 * self._cos_mid
        sin3 -= cos2 * self._sin_mid
        cos3 = np.multiply(cos2, self._cos_mid, out=cos2)
        cos3 += sin2 * self._sin_mid
        tip_x = cos3 * self._ST
        tip_x += self._OS
        tip_y = sin3 * self._ST
        tip_x_dot = tip_y * theta2_dot
        np.negative(tip_x_dot, out=tip_x_dot)
        tip_y_dot = cos3 * theta2_dot
        tip_y_dot *= self._ST
        state = OscillatoryState(
            phi, phi_dot, op, op_dot, theta1, theta1_dot, theta2, theta2_dot, theta3, theta2_dot,
            tip_x, tip_y, tip_x_dot, tip_y_dot,
        )  # fmt: skip
        return state, cos3, sin3


class UndulatoryTail(Tail):
    """Mechanism 2: the drive of mechanism 1 plus the slotted link AV and the tail VT.

    The loop A-U-V-W is solved for AS by Newton's method, seeded by a polynomial in theta3 fitted
    on construction to a continuation sweep from the straight pose; construction therefore also
    proves that the branch exists over the whole swing, and raises :class:`PinOffsetError`,
    :class:`AssemblyError` or :class:`SolverError` when it does not.

    >>> tail = UndulatoryTail(UndulatoryGeometry())
    >>> state = tail.solve(0.0)
    >>> round(state.theta5, 4)
    -0.5684
    """

    name = UNDULATORY
    geometry_type = UndulatoryGeometry
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
        # |W - V|^2 - VW^2 = (|W - V| - VW)(|W - V| + VW) ~ 2 VW x distance error.
        self._residual_tolerance = 2.0 * self._VW * _CLOSURE_TOLERANCE_M
        self.straight_slider_a_distance = self._AV + self._VW - self._SW
        if self.straight_slider_a_distance <= 0.0:
            raise AssemblyError(
                f"AV + VW > SW fails: the straight pose puts A at AS = "
                f"{self.straight_slider_a_distance:.6f} m, not behind S"
            )
        self._fit_seed()

    @property
    def drive(self) -> OscillatoryTail:
        """The mechanism-1 drive, whose tail link is SW."""
        return self._drive

    # The loop, written relative to S with a = AS: A = (-a, 0), U = SU e(theta3),
    # theta4 = direction A->U, V = A + AV e(theta4), and W = SW e(theta3) must lie at VW from V.
    def _residual_and_slope(self, a: _Value, cos3: _Value, sin3: _Value) -> tuple[_Value, _Value]:
        dx = a + self._SU * cos3
        dy = self._SU * sin3
        # np.hypot is ~15x slower than this and the operands are far from overflow.
        au = np.sqrt(dx * dx + dy * dy) if isinstance(dx, np.ndarray) else math.hypot(dx, dy)
        cos4 = dx / au
        sin4 = dy / au
        ex = self._SW * cos3 + a - self._AV * cos4
        ey = self._SW * sin3 - self._AV * sin4
        residual = ex * ex + ey * ey - self._VW * self._VW
        # d(cos4)/da = sin4^2/AU, d(sin4)/da = -cos4 sin4/AU.
        slope = 2.0 * (ex * (1.0 - self._AV * sin4 * sin4 / au) + ey * self._AV * cos4 * sin4 / au)
        return residual, slope

    def _fit_seed(self) -> None:
        drive = self.drive
        theta3_low = drive.theta2_min - drive.theta2_mid
        theta3_high = drive.theta2_max - drive.theta2_mid
        half = _CONTINUATION_SAMPLES // 2
        sweeps = (np.linspace(0.0, theta3_low, half + 1), np.linspace(0.0, theta3_high, half + 1))
        thetas, solutions = [], []
        for sweep in sweeps:
            a = self.straight_slider_a_distance
            for theta3 in sweep:
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
                thetas.append(theta3)
                solutions.append(a)
        self._seed = np.polyfit(np.array(thetas), np.array(solutions), _SEED_POLYNOMIAL_DEGREE)
        self._seed_coefficients = tuple(float(c) for c in self._seed)

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
        self, motor_angle: npt.ArrayLike, motor_velocity: npt.ArrayLike = 0.0
    ) -> UndulatoryState:
        """Pose and rates for carrier angle phi [rad] and speed phi_dot [rad/s]."""
        if isinstance(motor_angle, (float, int)) and isinstance(motor_velocity, (float, int)):
            return self._solve_scalar(self._drive.solve(float(motor_angle), float(motor_velocity)))
        return _zero_dimensional_safe(self._solve_array_path, motor_angle, motor_velocity)

    def link_points(self, state: LinkageState) -> UndulatoryPoints:
        """Every joint of ``state`` (an undulatory state) in the frame at O."""
        return undulatory_points(self.geometry, cast(UndulatoryState, state))

    def link_motion(self, state: LinkageState) -> tuple[BodyMotion, ...]:
        """The drive, SW, the slider A, AV and VT (``state`` an undulatory state)."""
        return undulatory_link_motion(
            self.geometry, self._drive.theta2_mid, cast(UndulatoryState, state)
        )

    def _solve_array_path(self, phi: FloatArray, phi_dot: FloatArray) -> UndulatoryState:
        return self._solve_array(*self._drive.solve_array_with_tail_trig(phi, phi_dot))

    def _solve_scalar(self, d: OscillatoryState) -> UndulatoryState:
        theta3 = cast(float, d.theta3)
        cos3, sin3 = math.cos(theta3), math.sin(theta3)
        a = 0.0
        for coefficient in self._seed_coefficients:
            a = a * theta3 + coefficient
        # The per-message path: _residual_and_slope inlined, and the last evaluation's W - V
        # reused as VW e(theta5).
        su, sw, av, vw = self._SU, self._SW, self._AV, self._VW
        su_cos3, su_sin3, sw_cos3, sw_sin3 = su * cos3, su * sin3, sw * cos3, sw * sin3
        vw_sq = vw * vw
        slope = residual = 0.0
        for step in range(_MAX_NEWTON_STEPS + 1):
            if step:
                a -= residual / slope
            dx = a + su_cos3
            au = math.hypot(dx, su_sin3)
            cos4 = dx / au
            sin4 = su_sin3 / au
            ex = sw_cos3 + a - av * cos4
            ey = sw_sin3 - av * sin4
            residual = ex * ex + ey * ey - vw_sq
            if step and abs(residual) < self._residual_tolerance:
                break
            lever = av * sin4 / au
            slope = 2.0 * (ex * (1.0 - lever * sin4) + ey * lever * cos4)
        else:
            raise SolverError(
                f"mechanism 2 loop does not close at theta3 = {theta3!r} rad "
                f"(residual {residual:.3e} m^2)"
            )
        cos5 = ex / vw
        sin5 = ey / vw
        rates = self._rates(d.theta3_dot, cos3, sin3, cos4, sin4, cos5, sin5, au)
        theta4 = math.atan2(sin4, cos4)
        theta5 = math.atan2(sin5, cos5)
        return self._assemble(d, theta4, au, a, theta5, cos3, sin3, cos5, sin5, rates)

    def _solve_array(
        self, d: OscillatoryState, cos3: FloatArray, sin3: FloatArray
    ) -> UndulatoryState:
        theta3 = d.theta3
        a = cast(FloatArray, np.polyval(self._seed, theta3))
        residual, slope = self._residual_and_slope(a, cos3, sin3)
        for _ in range(_MAX_NEWTON_STEPS):
            a -= residual / slope
            residual, slope = self._residual_and_slope(a, cos3, sin3)
            # Written so that a NaN residual counts as not converged.
            worst = float(np.max(np.abs(residual), initial=0.0))
            if worst < self._residual_tolerance:
                break
        else:
            raise SolverError(f"mechanism 2 loop residual up to {worst:.3e} m^2 in this batch")
        dx = a + self._SU * cos3
        dy = self._SU * sin3
        au = np.sqrt(dx * dx + dy * dy)
        cos4, sin4 = dx / au, dy / au
        cos5 = (self._SW * cos3 + a - self._AV * cos4) / self._VW
        sin5 = (self._SW * sin3 - self._AV * sin4) / self._VW
        rates = self._rates(d.theta3_dot, cos3, sin3, cos4, sin4, cos5, sin5, au)
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
        # Time derivatives of the four loop equations, solved in closed form (docs/kinematics.md):
        #   AS' [cos5 - (AV/AU) sin4 sin(t4-t5)]
        #       = t3' [SW sin(t3-t5) - (AV SU/AU) sin(t4-t5) cos(t3-t4)]
        #   t4' = (SU t3' cos(t3-t4) - AS' sin4) / AU
        #   AU' = AS' cos4 - SU t3' sin(t3-t4)
        #   t5' = (SW t3' cos(t3-t5) - AV t4' cos(t4-t5) - AS' sin5) / VW
        sin34 = sin3 * cos4 - cos3 * sin4
        cos34 = cos3 * cos4 + sin3 * sin4
        sin35 = sin3 * cos5 - cos3 * sin5
        cos35 = cos3 * cos5 + sin3 * sin5
        sin45 = sin4 * cos5 - cos4 * sin5
        cos45 = cos4 * cos5 + sin4 * sin5
        lever = self._AV / au
        slider_rate = (
            theta3_dot
            * (self._SW * sin35 - lever * self._SU * sin45 * cos34)
            / (cos5 - lever * sin4 * sin45)
        )
        theta4_dot = (self._SU * theta3_dot * cos34 - slider_rate * sin4) / au
        au_rate = slider_rate * cos4 - self._SU * theta3_dot * sin34
        theta5_dot = (
            self._SW * theta3_dot * cos35 - self._AV * theta4_dot * cos45 - slider_rate * sin5
        ) / self._VW
        return theta4_dot, au_rate, slider_rate, theta5_dot

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
        t3_dot = d.theta3_dot
        tip_x = self._OS + self._SW * cos3 + self._WT * cos5
        tip_y = self._SW * sin3 + self._WT * sin5
        tip_x_dot = -self._SW * sin3 * t3_dot - self._WT * sin5 * theta5_dot
        tip_y_dot = self._SW * cos3 * t3_dot + self._WT * cos5 * theta5_dot
        return UndulatoryState(
            d.motor_angle, d.motor_velocity, d.slider_position, d.slider_velocity,
            d.theta1, d.theta1_dot, d.theta2, d.theta2_dot, d.theta3, d.theta3_dot,
            tip_x, tip_y, tip_x_dot, tip_y_dot,
            theta4, theta4_dot, au, au_rate, a, slider_rate, theta5, theta5_dot,
        )  # fmt: skip


#: The tail of each mechanism, by name.
TAIL_TYPES: dict[str, type[Tail]] = {tail.name: tail for tail in (OscillatoryTail, UndulatoryTail)}


def make_tail(geometry: Geometry) -> Tail:
    """The engine for a geometry of either mechanism (validates it)."""
    return TAIL_TYPES[geometry.mechanism](geometry)
