"""Forces on the fish and its equations of motion in the horizontal plane.

:class:`SwimModel` is the right-hand side a batch of fish is integrated with: Lighthill's
reactive force at the trailing edge, the hull's drag, lift and damping, and the recoil and the
resistive drag of a fin with chord, on states (X, Y, psi, u, v, r), one row of an (N, 6) array
per fish. The formulas themselves are :mod:`fishtail_plant.fish.formulas`; this module gives
them the fish, the tail and the state. Frames, forces and equations: docs/swimming-dynamics.md.

>>> from fishtail_plant.fish.tail_drive import SinusoidalTailDrive
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

from fishtail_plant.errors import SwimInputError
from fishtail_plant.fish import formulas
from fishtail_plant.fish.fish import FishParameters, FloatArray
from fishtail_plant.fish.tail_drive import TailAcceleration, TailDrive, TailSample

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


def fin_direction(tail: TailSample) -> tuple[FloatArray, FloatArray]:
    """The fin angle's cosine and sine: how the formulas take it."""
    return np.cos(tail.fin_angle), np.sin(tail.fin_angle)


def trailing_edge_force(
    fish: FishParameters, tail: TailSample, u: FloatArray, v: FloatArray, r: FloatArray
) -> TrailingEdgeFlow:
    """F_T = ½ m w² t - m u_t w n at the tip T, and M_T = x_T F_y - y_T F_x about C.

    v_T = (u - r y_T, v + r x_T) + (-Tx_dot, Ty_dot), u_t = v_T . t, w = v_T . n.
    """
    force_x, force_y, moment, tangential, normal, tip_x, tip_y = formulas.tip_force(
        fish.fin_added_mass_per_length_kg_m, fish.tail_origin_offset_m,
        tail.tip_x, tail.tip_y, tail.tip_x_dot, tail.tip_y_dot, *fin_direction(tail), u, v, r,
    )  # fmt: skip
    return TrailingEdgeFlow(
        GeneralisedForce(force_x, force_y, moment), tangential, normal, tip_x, tip_y
    )


def body_force(
    fish: FishParameters, u: FloatArray, v: FloatArray, r: FloatArray
) -> GeneralisedForce:
    """Drag -½ rho S C_D V (u, v), lift ½ rho S C_L beta V (v, -u) while u > 0, and damping.

    Fossen's damping: -(X_u u, Y_v v + Y_|v|v |v| v, N_r r + K_D r|r|).
    """
    return GeneralisedForce(
        *formulas.hull_force(
            fish.drag_factor_kg_m, fish.lift_factor_kg_m, fish.yaw_damping_kg_m2,
            fish.surge_linear_damping_kg_s, fish.sway_linear_damping_kg_s,
            fish.sway_quadratic_damping_kg_m, fish.yaw_linear_damping_kg_m2_s, u, v, r,
        )  # fmt: skip
    )


class FinDrag(NamedTuple):
    """The fin plate's resistive force (body x, y), its moment about C and its moment about T."""

    force: GeneralisedForce
    moment_about_tip: FloatArray


def fin_drag(
    fish: FishParameters, tail: TailSample, u: FloatArray, v: FloatArray, r: FloatArray
) -> FinDrag:
    """-½ rho C_n d |w| w n per unit chord, integrated over the plate from T to T + c t."""
    force_x, force_y, moment, moment_about_tip = formulas.fin_drag(
        fish.fin_drag_factor_kg_m2, fish.fin_chord_m, fish.tail_origin_offset_m,
        tail.tip_x, tail.tip_y, tail.tip_x_dot, tail.tip_y_dot, *fin_direction(tail),
        tail.fin_rate, u, v, r,
    )  # fmt: skip
    return FinDrag(GeneralisedForce(force_x, force_y, moment), moment_about_tip)


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
    """-m c d/dt(w_c n) (inertial) at mid-chord M = T + (c/2) t, for a plate of chord c."""
    direction_x, direction_y, direction_z, mass, rest_x, rest_y, rest_z = formulas.fin_recoil(
        fish.fin_added_mass_per_length_kg_m, fish.fin_chord_m, fish.tail_origin_offset_m,
        tail.tip_x, tail.tip_y, tail.tip_x_dot, tail.tip_y_dot, *fin_direction(tail),
        tail.fin_rate, acceleration.tip_x_ddot, acceleration.tip_y_ddot,
        acceleration.fin_acceleration, u, v, r,
    )  # fmt: skip
    return Recoil(
        (direction_x, direction_y, direction_z),
        np.asarray(mass, dtype=float),
        GeneralisedForce(rest_x, rest_y, rest_z),
    )


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
        self.has_fin_drag = fish.has_fin_drag

    def forces(
        self, time_s: npt.ArrayLike, state: FloatArray
    ) -> tuple[TrailingEdgeFlow, GeneralisedForce, TailSample]:
        """The trailing-edge flow and force, the body's force, and the tail sample."""
        u, v, r = state[..., SURGE], state[..., SWAY], state[..., YAW_RATE]
        tail = self.drive.sample(time_s)
        return trailing_edge_force(self.fish, tail, u, v, r), body_force(self.fish, u, v, r), tail

    def derivatives(self, time_s: npt.ArrayLike, state: FloatArray) -> FloatArray:
        """d(state)/dt for states of shape (..., N, 6) at ``time_s``.

        Raises:
            SwimInputError: a state without 6 columns.
        """
        if state.shape[-1] != STATE_SIZE:
            raise SwimInputError(f"a state has {STATE_SIZE} columns, got shape {state.shape}")
        fish = self.fish
        u, v, r, psi = state[..., SURGE], state[..., SWAY], state[..., YAW_RATE], state[..., PSI]
        flow, body, tail = self.forces(time_s, state)
        m1, m2, inertia = fish.surge_mass_kg, fish.sway_mass_kg, fish.yaw_inertia_kg_m2
        coupling = formulas.coupling(m1, m2, u, v, r)
        total = [c + f + b for c, f, b in zip(coupling, flow.force, body, strict=True)]
        if self.has_fin_drag:
            plate = fin_drag(fish, tail, u, v, r).force
            total = [f + extra for f, extra in zip(total, plate, strict=True)]
        if self.has_recoil:
            recoil = fin_recoil(fish, tail, self.drive.acceleration(time_s), u, v, r)
            total = [f + extra for f, extra in zip(total, recoil.rest, strict=True)]
            added_mass, direction = recoil.added_mass_kg, recoil.direction
        else:
            added_mass, direction = np.zeros(()), (np.zeros(()), np.zeros(()), np.zeros(()))
        if self.hold_sway_yaw:
            # The guide's reactions cancel sway and yaw.
            surge = formulas.held_surge_acceleration(m1, total[0], added_mass, direction[0])
            rates_of_velocity = (surge, np.zeros_like(u), np.zeros_like(u))
        else:
            force_x, force_y, moment = total
            rates_of_velocity = formulas.accelerations(
                m1, m2, inertia, force_x, force_y, moment, added_mass, *direction
            )
        rates = np.empty(np.broadcast_shapes(state.shape, (*u.shape, STATE_SIZE)))
        rates[..., X], rates[..., Y], rates[..., PSI] = formulas.pose_rates(psi, u, v, r)
        rates[..., SURGE], rates[..., SWAY], rates[..., YAW_RATE] = rates_of_velocity
        return rates
