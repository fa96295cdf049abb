"""Forces on the fish and its equations of motion in the horizontal plane.

Frames (docs/swimming-dynamics.md): body ``base_link`` (REP 103: origin at the centre of mass C,
x forward, y left), tail frame at O (x backward, y left, z down) with O at x_b = -l_O, so a tail
point (x_t, y_t) is at (-l_O - x_t, y_t) in the body and a tail velocity (xd_t, yd_t) is
(-xd_t, yd_t). The fin's forward tangent t = (cos th, -sin th) and its normal n = (sin th, cos th).

State of each fish, one row of an (N, 6) array: X, Y, psi (world), u, v, r (body).

    (M_rb + m c g g^T) (u̇, v̇, ṙ) = (m2 v r, -m1 u r, (m1 - m2) u v) + F_T + F_body + F_rec'

with M_rb = diag(m1, m2, J); F_T Lighthill's reactive force at the trailing edge with its moment
about C; F_body drag, lift and yaw damping; F_rec' the recoil of a fin of chord c without its
body-acceleration part, which is the rank-one added mass m c g g^T (g the generalised direction of
the fin's normal at mid-chord) and is inverted by the Sherman-Morrison formula, per fish.

>>> from fishtail_swim.dynamics.tail_drive import SinusoidalTailDrive
>>> drive = SinusoidalTailDrive(0.2, 0.0, 0.3, 6.0)
>>> model = SwimModel(FishParameters(), drive)
>>> rates = model.derivatives(0.0, np.zeros((1, 6)))
>>> rates.shape, bool(rates[0, 3] > 0)   # from rest the first stroke pushes the fish forward
((1, 6), True)
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from fishtail_swim.dynamics.errors import SwimInputError
from fishtail_swim.dynamics.fish import FishParameters, FloatArray
from fishtail_swim.dynamics.tail_drive import TailAcceleration, TailDrive, TailSample

#: Columns of a state array.
X, Y, PSI, SURGE, SWAY, YAW_RATE = range(6)
STATE_SIZE = 6


class GeneralisedForce(NamedTuple):
    """A force (body x, y) and its moment about C (z up): one element per fish."""

    x: FloatArray
    y: FloatArray
    z: FloatArray


class TrailingEdgeFlow(NamedTuple):
    """Lighthill's reactive force at the tip and the flow quantities it comes from."""

    force: GeneralisedForce
    tangential_velocity: FloatArray
    normal_velocity: FloatArray
    tip_body_x: FloatArray
    tip_body_y: FloatArray


def trailing_edge_force(
    fish: FishParameters, tail: TailSample, u: FloatArray, v: FloatArray, r: FloatArray
) -> TrailingEdgeFlow:
    """F_T = ½ m w² t - m u_t w n at the tip T, and M_T = x_T F_y - y_T F_x about C.

    v_T = (u - r y_T, v + r x_T) + (-Tx_dot, Ty_dot), u_t = v_T . t, w = v_T . n.
    """
    tip_x = -fish.tail_origin_offset_m - tail.tip_x
    tip_y = tail.tip_y
    cos_fin, sin_fin = np.cos(tail.fin_angle), np.sin(tail.fin_angle)
    velocity_x = u - r * tip_y - tail.tip_x_dot
    velocity_y = v + r * tip_x + tail.tip_y_dot
    tangential = velocity_x * cos_fin - velocity_y * sin_fin
    normal = velocity_x * sin_fin + velocity_y * cos_fin
    mass = fish.fin_added_mass_per_length_kg_m
    along = 0.5 * mass * normal * normal
    across = -mass * tangential * normal
    force_x = along * cos_fin + across * sin_fin
    force_y = -along * sin_fin + across * cos_fin
    moment = tip_x * force_y - tip_y * force_x
    return TrailingEdgeFlow(
        GeneralisedForce(force_x, force_y, moment), tangential, normal, tip_x, tip_y
    )


def body_force(
    fish: FishParameters, u: FloatArray, v: FloatArray, r: FloatArray
) -> GeneralisedForce:
    """Drag -½ rho S C_D V (u, v), lift ½ rho S C_L beta V (v, -u) while u > 0, -K_D r|r|."""
    speed = np.hypot(u, v)
    forward = u > 0.0
    # beta = atan(v/u) only where the lift acts; elsewhere any finite value (it is multiplied by 0).
    sideslip = np.where(forward, np.arctan(v / np.where(forward, u, 1.0)), 0.0)
    drag = fish.drag_factor_kg_m * speed
    lift = fish.lift_factor_kg_m * sideslip * speed
    return GeneralisedForce(
        -drag * u + lift * v, -drag * v - lift * u, -fish.yaw_damping_kg_m2 * r * np.abs(r)
    )


class Recoil(NamedTuple):
    """The fin's recoil, split so that its body-acceleration part is added mass.

    F_rec = -m c (g . nu_dot) g + rest.
    """

    direction: tuple[FloatArray, FloatArray, FloatArray]
    added_mass_kg: FloatArray
    rest: GeneralisedForce


def fin_recoil(
    fish: FishParameters,
    tail: TailSample,
    acceleration: TailAcceleration,
    u: FloatArray,
    v: FloatArray,
    r: FloatArray,
) -> Recoil:
    """-m c d/dt(w_c n) (inertial) at mid-chord M = T + (c/2) t, for a plate of chord c.

    d/dt(w_c n) = w_c_dot n + w_c (th_dot - r) t, and w_c_dot = g . (u̇, v̇, ṙ) + the rest, with
    g = (n_x, n_y, x_M n_y - y_M n_x): the first part is added mass m c g g^T.
    """
    half_chord = 0.5 * fish.fin_chord_m
    cos_fin, sin_fin = np.cos(tail.fin_angle), np.sin(tail.fin_angle)
    rate, fin_acceleration = tail.fin_rate, acceleration.fin_acceleration
    mid_x = -fish.tail_origin_offset_m - tail.tip_x + half_chord * cos_fin
    mid_y = tail.tip_y - half_chord * sin_fin
    mid_x_dot = -tail.tip_x_dot - half_chord * sin_fin * rate
    mid_y_dot = tail.tip_y_dot - half_chord * cos_fin * rate
    mid_x_ddot = -acceleration.tip_x_ddot - half_chord * (
        cos_fin * rate * rate + sin_fin * fin_acceleration
    )
    mid_y_ddot = acceleration.tip_y_ddot - half_chord * (
        -sin_fin * rate * rate + cos_fin * fin_acceleration
    )
    velocity_x = u - r * mid_y + mid_x_dot
    velocity_y = v + r * mid_x + mid_y_dot
    normal = velocity_x * sin_fin + velocity_y * cos_fin
    tangential = velocity_x * cos_fin - velocity_y * sin_fin
    normal_rate_rest = (
        (-r * mid_y_dot + mid_x_ddot) * sin_fin
        + (r * mid_x_dot + mid_y_ddot) * cos_fin
        + rate * tangential
    )
    mass = fish.fin_added_mass_per_length_kg_m * fish.fin_chord_m
    direction = (sin_fin, cos_fin, mid_x * cos_fin - mid_y * sin_fin)
    tangent = (cos_fin, -sin_fin, -mid_x * sin_fin - mid_y * cos_fin)
    turning = normal * (rate - r)
    pairs = zip(direction, tangent, strict=True)
    rest = GeneralisedForce(*(-mass * (normal_rate_rest * g + turning * t) for g, t in pairs))
    return Recoil(direction, np.asarray(mass, dtype=float), rest)


class SwimModel:
    """A batch of fish and their tails: the right-hand side of the equations of motion.

    ``hold_sway_yaw`` holds v = r = 0 (the fish is guided along a straight line; only the surge
    equation is integrated): check 5's time-stepped steady surge speed.
    """

    def __init__(self, fish: FishParameters, drive: TailDrive, hold_sway_yaw: bool = False) -> None:
        """Keep the fish, their tail drive and whether sway and yaw are held."""
        self.fish = fish
        self.drive = drive
        self.hold_sway_yaw = hold_sway_yaw
        self.has_recoil = bool(np.any(np.asarray(fish.fin_chord_m) > 0.0))

    def forces(
        self, time_s: npt.ArrayLike, state: FloatArray
    ) -> tuple[TrailingEdgeFlow, GeneralisedForce, TailSample]:
        """The trailing-edge flow and force, the body's force, and the tail sample."""
        u, v, r = state[..., SURGE], state[..., SWAY], state[..., YAW_RATE]
        tail = self.drive.sample(time_s)
        return trailing_edge_force(self.fish, tail, u, v, r), body_force(self.fish, u, v, r), tail

    def derivatives(self, time_s: npt.ArrayLike, state: FloatArray) -> FloatArray:
        """d(state)/dt for states of shape (..., N, 6) at ``time_s``."""
        if state.shape[-1] != STATE_SIZE:
            raise SwimInputError(f"a state has {STATE_SIZE} columns, got shape {state.shape}")
        fish = self.fish
        u, v, r, psi = state[..., SURGE], state[..., SWAY], state[..., YAW_RATE], state[..., PSI]
        flow, body, tail = self.forces(time_s, state)
        m1, m2, inertia = fish.surge_mass_kg, fish.sway_mass_kg, fish.yaw_inertia_kg_m2
        total = [
            m2 * v * r + flow.force.x + body.x,
            -m1 * u * r + flow.force.y + body.y,
            (m1 - m2) * u * v + flow.force.z + body.z,
        ]
        diagonal = [np.broadcast_to(m1, u.shape), np.broadcast_to(m2, u.shape),
                    np.broadcast_to(inertia, u.shape)]  # fmt: skip
        if self.has_recoil:
            recoil = fin_recoil(fish, tail, self.drive.acceleration(time_s), u, v, r)
            total = [f + extra for f, extra in zip(total, recoil.rest, strict=True)]
            accelerations = _rank_one_solve(diagonal, recoil.added_mass_kg, recoil.direction, total)
        else:
            accelerations = [f / d for f, d in zip(total, diagonal, strict=True)]
        if self.hold_sway_yaw:
            # The guide's reactions cancel sway and yaw; the fin's added mass acts along x only.
            surge_mass = diagonal[0]
            if self.has_recoil:
                surge_mass = surge_mass + recoil.added_mass_kg * recoil.direction[0] ** 2
            accelerations = [total[0] / surge_mass, np.zeros_like(u), np.zeros_like(u)]
        rates = np.empty(np.broadcast_shapes(state.shape, (*u.shape, STATE_SIZE)))
        cos_psi, sin_psi = np.cos(psi), np.sin(psi)
        rates[..., X] = u * cos_psi - v * sin_psi
        rates[..., Y] = u * sin_psi + v * cos_psi
        rates[..., PSI] = r
        rates[..., SURGE], rates[..., SWAY], rates[..., YAW_RATE] = accelerations
        return rates


def _rank_one_solve(
    diagonal: list[FloatArray],
    mass: FloatArray,
    direction: tuple[FloatArray, FloatArray, FloatArray],
    force: list[FloatArray],
) -> list[FloatArray]:
    # (D + k g g^T)^-1 b = D^-1 b - k D^-1 g (g . D^-1 b) / (1 + k g . D^-1 g): D is positive and
    # k >= 0, so the denominator is at least 1.
    scaled_force = [f / d for f, d in zip(force, diagonal, strict=True)]
    scaled_direction = [g / d for g, d in zip(direction, diagonal, strict=True)]
    projection = sum(g * f for g, f in zip(direction, scaled_force, strict=True))
    norm = sum(g * h for g, h in zip(direction, scaled_direction, strict=True))
    factor = mass * projection / (1.0 + mass * norm)
    return [f - factor * h for f, h in zip(scaled_force, scaled_direction, strict=True)]
