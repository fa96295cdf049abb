"""The model's formulas, written once for both ways they are evaluated.

Plain arithmetic on the arguments (no branches on values, no containers), so that numpy
evaluates them on a batch of fish (:class:`~fishtail_plant.fish.model.SwimModel`) and numba
compiles them as they stand into the integrator's loop (:mod:`~fishtail_plant.fish.fused`) and
the cycle kernel (:mod:`~fishtail_plant.fish.cycle_kernel`). The fin's angle th enters as its
cosine and sine, which the caller computes once for every formula (or, from the engine, gets
from angle-sum identities without a call). Frames, symbols and signs: docs/swimming-dynamics.md.

>>> force_x, force_y, moment, tangential, normal, tip_x, tip_y = tip_force(
...     1.0, 0.0, 0.2, 0.0, 0.0, 0.5, 1.0, 0.0, 0.0, 0.0, 0.0)
>>> [float(value) + 0.0 for value in (force_x, force_y, moment)]  # fin moving left: ½ m w² ahead
[0.125, 0.0, 0.0]
"""

from __future__ import annotations

from typing import Any, TypeAlias

import numpy as np

#: A float, or a float array with one element per fish: the formulas broadcast like numpy. (Any,
#: because the type system cannot say "whatever the arithmetic of the arguments gives".)
Value: TypeAlias = Any


def tip_force(
    fin_mass: Value,
    origin_offset: Value,
    tip_x: Value,
    tip_y: Value,
    tip_x_dot: Value,
    tip_y_dot: Value,
    cos_fin: Value,
    sin_fin: Value,
    u: Value,
    v: Value,
    r: Value,
) -> tuple[Value, Value, Value, Value, Value, Value, Value]:
    """Lighthill's F_T = ½ m w² t - m u_t w n at the tip and M_T = x_T F_y - y_T F_x about C.

    v_T = (u - r y_T, v + r x_T) + (-Tx_dot, Ty_dot), u_t = v_T . t, w = v_T . n. Returns the
    force (x, y), its moment, u_t, w and the tip (x_T, y_T) in the body frame.
    """
    body_tip_x = -origin_offset - tip_x
    body_tip_y = tip_y
    velocity_x = u - r * body_tip_y - tip_x_dot
    velocity_y = v + r * body_tip_x + tip_y_dot
    tangential = velocity_x * cos_fin - velocity_y * sin_fin
    normal = velocity_x * sin_fin + velocity_y * cos_fin
    along = 0.5 * fin_mass * normal * normal
    across = -fin_mass * tangential * normal
    force_x = along * cos_fin + across * sin_fin
    force_y = -along * sin_fin + across * cos_fin
    moment = body_tip_x * force_y - body_tip_y * force_x
    return force_x, force_y, moment, tangential, normal, body_tip_x, body_tip_y


def hull_force(
    drag_factor: Value,
    lift_factor: Value,
    yaw_damping: Value,
    surge_linear: Value,
    sway_linear: Value,
    sway_quadratic: Value,
    yaw_linear: Value,
    u: Value,
    v: Value,
    r: Value,
) -> tuple[Value, Value, Value]:
    """Drag -½ rho S C_D V (u, v), lift ½ rho S C_L beta V (v, -u) while u > 0, Fossen's damping.

    Damping: -(X_u u, Y_v v + Y_|v|v |v| v, N_r r + K_D r|r|). beta = atan(v/u), which for u > 0
    is atan2(v, u): finite for every (u, v), and the factor (u > 0) switches the lift off going
    backwards or from rest without a division by zero. Zero damping coefficients add exact zeros.
    """
    speed = np.hypot(u, v)
    sideslip = np.arctan2(v, u) * (u > 0.0)
    drag = drag_factor * speed
    lift = lift_factor * sideslip * speed
    return (
        -drag * u + lift * v - surge_linear * u,
        -drag * v - lift * u - (sway_linear + sway_quadratic * np.abs(v)) * v,
        -yaw_damping * r * np.abs(r) - yaw_linear * r,
    )


def fin_drag(
    drag_factor: Value,
    chord: Value,
    origin_offset: Value,
    tip_x: Value,
    tip_y: Value,
    tip_x_dot: Value,
    tip_y_dot: Value,
    cos_fin: Value,
    sin_fin: Value,
    fin_rate: Value,
    u: Value,
    v: Value,
    r: Value,
) -> tuple[Value, Value, Value, Value]:
    """The fin plate's resistive force -k |w| w n per unit chord, k = ½ rho C_n d, integrated.

    The plate runs from T forward to T + c t; its normal velocity is w(s) = w_T + s (r - th_dot)
    at a distance s from T, so the integrals I0 = ∫|w| w ds and I1 = ∫ s |w| w ds are exact
    piecewise polynomials, split where w changes sign. Returns the force (x, y), its moment
    about C and its moment about T. A chord or a factor of 0 gives zeros.
    """
    body_tip_x = -origin_offset - tip_x
    body_tip_y = tip_y
    velocity_x = u - r * body_tip_y - tip_x_dot
    velocity_y = v + r * body_tip_x + tip_y_dot
    start = velocity_x * sin_fin + velocity_y * cos_fin
    slope = r - fin_rate
    end = start + slope * chord
    # Whether w keeps its sign over the plate; if not, it changes sign at s0 = c w0 / (w0 - w1).
    same = 1.0 * (start * end >= 0.0)
    sign = same * np.sign(start + end) + (1.0 - same) * np.sign(start)
    crossing = same * chord + (1.0 - same) * chord * start / (start - end + same)
    square_start, product, square_slope = start * start, start * slope, slope * slope
    # Q(s) = ∫0^s w² and P(s) = ∫0^s s w²: I = sign (2 F(s0) - F(c)) for either.
    zeroth_crossing = crossing * (
        square_start + crossing * (product + crossing * square_slope / 3.0)
    )
    zeroth_chord = chord * (square_start + chord * (product + chord * square_slope / 3.0))
    first_crossing = crossing * crossing * (
        0.5 * square_start + crossing * (2.0 * product / 3.0 + 0.25 * crossing * square_slope)
    )
    first_chord = chord * chord * (
        0.5 * square_start + chord * (2.0 * product / 3.0 + 0.25 * chord * square_slope)
    )
    zeroth = sign * (2.0 * zeroth_crossing - zeroth_chord)
    first = sign * (2.0 * first_crossing - first_chord)
    normal_force = -drag_factor * zeroth
    moment_about_tip = -drag_factor * first
    moment = (body_tip_x * cos_fin - body_tip_y * sin_fin) * normal_force + moment_about_tip
    return normal_force * sin_fin, normal_force * cos_fin, moment, moment_about_tip


def fin_recoil(
    fin_mass: Value,
    chord: Value,
    origin_offset: Value,
    tip_x: Value,
    tip_y: Value,
    tip_x_dot: Value,
    tip_y_dot: Value,
    cos_fin: Value,
    sin_fin: Value,
    fin_rate: Value,
    tip_x_ddot: Value,
    tip_y_ddot: Value,
    fin_acceleration: Value,
    u: Value,
    v: Value,
    r: Value,
) -> tuple[Value, Value, Value, Value, Value, Value, Value]:
    """-m c d/dt(w_c n) (inertial) at mid-chord M = T + (c/2) t, for a plate of chord c.

    d/dt(w_c n) = w_c_dot n + w_c (th_dot - r) t, and w_c_dot = g . (u̇, v̇, ṙ) + the rest, with
    g = (n_x, n_y, x_M n_y - y_M n_x): the first part is the added mass m c g g^T. Returns g, the
    added mass m c and the rest (x, y, moment). A chord of 0 gives zeros.
    """
    half_chord = 0.5 * chord
    mid_x = -origin_offset - tip_x + half_chord * cos_fin
    mid_y = tip_y - half_chord * sin_fin
    mid_x_dot = -tip_x_dot - half_chord * sin_fin * fin_rate
    mid_y_dot = tip_y_dot - half_chord * cos_fin * fin_rate
    mid_x_ddot = -tip_x_ddot - half_chord * (
        cos_fin * fin_rate * fin_rate + sin_fin * fin_acceleration
    )
    mid_y_ddot = tip_y_ddot - half_chord * (
        -sin_fin * fin_rate * fin_rate + cos_fin * fin_acceleration
    )
    velocity_x = u - r * mid_y + mid_x_dot
    velocity_y = v + r * mid_x + mid_y_dot
    normal = velocity_x * sin_fin + velocity_y * cos_fin
    tangential = velocity_x * cos_fin - velocity_y * sin_fin
    normal_rate_rest = (
        (-r * mid_y_dot + mid_x_ddot) * sin_fin
        + (r * mid_x_dot + mid_y_ddot) * cos_fin
        + fin_rate * tangential
    )
    mass = fin_mass * chord
    direction_z = mid_x * cos_fin - mid_y * sin_fin
    tangent_z = -mid_x * sin_fin - mid_y * cos_fin
    turning = normal * (fin_rate - r)
    return (
        sin_fin, cos_fin, direction_z, mass,
        -mass * (normal_rate_rest * sin_fin + turning * cos_fin),
        -mass * (normal_rate_rest * cos_fin - turning * sin_fin),
        -mass * (normal_rate_rest * direction_z + turning * tangent_z),
    )  # fmt: skip


def tip_power(force_x: Value, force_y: Value, tip_x_dot: Value, tip_y_dot: Value) -> Value:
    """Rate at which the tail works against a force at the tip: -F . (-Tx_dot, Ty_dot).

    The tip's velocity relative to the body is (-Tx_dot, Ty_dot) in the body frame (the tail
    frame's x points backward).
    """
    return force_x * tip_x_dot - force_y * tip_y_dot


def fin_drag_power(
    force_x: Value,
    force_y: Value,
    moment_about_tip: Value,
    tip_x_dot: Value,
    tip_y_dot: Value,
    fin_rate: Value,
) -> Value:
    """Rate at which the tail works against the plate's drag (resultant at T, moment about T).

    T moves in the body at (-Tx_dot, Ty_dot) and the plate turns at -th_dot in the body frame.
    """
    return force_x * tip_x_dot - force_y * tip_y_dot + moment_about_tip * fin_rate


def recoil_power(
    chord: Value,
    cos_fin: Value,
    sin_fin: Value,
    tip_x_dot: Value,
    tip_y_dot: Value,
    fin_rate: Value,
    force_x: Value,
    force_y: Value,
) -> Value:
    """Rate at which the tail works against a force at mid-chord M (the recoil).

    M moves in the body at (-Tx_dot, Ty_dot) - (c/2) th_dot (sin th, cos th).
    """
    half_chord = 0.5 * chord
    mid_x_dot = -tip_x_dot - half_chord * sin_fin * fin_rate
    mid_y_dot = tip_y_dot - half_chord * cos_fin * fin_rate
    return -(force_x * mid_x_dot + force_y * mid_y_dot)


def coupling(
    surge_mass: Value, sway_mass: Value, u: Value, v: Value, r: Value
) -> tuple[Value, Value, Value]:
    """The Coriolis and Munk terms (m2 v r, -m1 u r, (m1 - m2) u v) of the equations of motion."""
    return sway_mass * v * r, -surge_mass * u * r, (surge_mass - sway_mass) * u * v


def accelerations(
    surge_mass: Value,
    sway_mass: Value,
    yaw_inertia: Value,
    force_x: Value,
    force_y: Value,
    moment: Value,
    added_mass: Value,
    direction_x: Value,
    direction_y: Value,
    direction_z: Value,
) -> tuple[Value, Value, Value]:
    """(u̇, v̇, ṙ) = (D + k g g^T)^-1 (F_x, F_y, M_z), D = diag(m1, m2, J), by Sherman-Morrison.

    (D + k g g^T)^-1 b = D^-1 b - k D^-1 g (g . D^-1 b) / (1 + k g . D^-1 g): D is positive and
    k >= 0, so the denominator is at least 1; k = 0 gives D^-1 b to the last bit.
    """
    scaled_x, scaled_y, scaled_z = force_x / surge_mass, force_y / sway_mass, moment / yaw_inertia
    unit_x, unit_y = direction_x / surge_mass, direction_y / sway_mass
    unit_z = direction_z / yaw_inertia
    projection = direction_x * scaled_x + direction_y * scaled_y + direction_z * scaled_z
    norm = direction_x * unit_x + direction_y * unit_y + direction_z * unit_z
    factor = added_mass * projection / (1.0 + added_mass * norm)
    return scaled_x - factor * unit_x, scaled_y - factor * unit_y, scaled_z - factor * unit_z


def held_surge_acceleration(
    surge_mass: Value, force_x: Value, added_mass: Value, direction_x: Value
) -> Value:
    """u̇ with sway and yaw held by a guide: the fin's added mass acts along x only."""
    return force_x / (surge_mass + added_mass * direction_x * direction_x)


def pose_rates(psi: Value, u: Value, v: Value, r: Value) -> tuple[Value, Value, Value]:
    """(Ẋ, Ẏ, ψ̇) = (u cos ψ - v sin ψ, u sin ψ + v cos ψ, r)."""
    cos_psi, sin_psi = np.cos(psi), np.sin(psi)
    return u * cos_psi - v * sin_psi, u * sin_psi + v * cos_psi, r
