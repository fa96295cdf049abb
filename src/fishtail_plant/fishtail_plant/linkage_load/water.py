"""The water's force on the tail, for the carrier's load, with the fish held.

The fish held by a guide, at rest or towed straight at a forward speed U, so that the motor's
load in water needs no free-body simulation: Lighthill's reactive force at the trailing edge
(:func:`~fishtail_plant.fish.formulas.tip_force`) and, for a fin plate of chord c, its resistive
drag and its recoil, turned into the tail frame as a force at T and a moment on the last link.
Angles, speeds and per-fish values broadcast together. Signs, the power it costs and why
Lighthill's part averages to zero held at rest: docs/motor-load.md ("The water's reaction").

>>> import numpy as np
>>> from fishtail_kinematics.engine.geometry import OscillatoryGeometry
>>> from fishtail_kinematics.engine.mechanisms import OscillatoryTail
>>> tail = OscillatoryTail(OscillatoryGeometry())
>>> angles = np.linspace(0.0, 2 * np.pi, 64, endpoint=False)
>>> def power_on_tail(w):
...     force = w.force_x_n * w.tip_velocity_x_m_s + w.force_y_n * w.tip_velocity_y_m_s
...     return force + w.fin_moment_n_m * w.fin_rate_rad_s
>>> swimming = water_force_on_tail(tail, FishParameters(), angles, 4.0, surge_speed_m_s=0.17)
>>> bool(power_on_tail(swimming).mean() < 0.0)   # the water resists: the carrier works on it
True
>>> no_plate = FishParameters(fin_chord_m=0.0, fin_normal_drag_coefficient=0.0)
>>> at_rest = water_force_on_tail(tail, no_plate, angles, 4.0)
>>> abs(float(power_on_tail(at_rest).mean())) < 1e-15   # Lighthill's alone: docs/motor-load.md
True
>>> held = water_force_on_tail(tail, FishParameters(), angles, 4.0)   # the default fin plate
>>> bool(power_on_tail(held).mean() < 0.0)   # its drag dissipates: the carrier pays for it
True
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from fishtail_kinematics.engine.mechanisms import Tail
from fishtail_plant.errors import SwimInputError
from fishtail_plant.fish.fish import FishParameters, FloatArray
from fishtail_plant.fish.model import fin_drag, fin_recoil, trailing_edge_force
from fishtail_plant.fish.tail_drive import EngineTailDrive, TailSample, constant_carrier_speed
from fishtail_plant.linkage_load.carrier_load import CarrierLoad, CarrierLoadModel, finite_values


class WaterForce(NamedTuple):
    """The water's force on the tail at T and its moment on the last link; broadcast shape.

    Tail frame (x back, y left, z up). The tip's velocity and the last link's rate (relative to
    the body) come with it: the power on the tail, force . velocity + moment x rate, is
    negative on average.
    """

    force_x_n: FloatArray
    force_y_n: FloatArray
    tip_velocity_x_m_s: FloatArray
    tip_velocity_y_m_s: FloatArray
    fin_moment_n_m: FloatArray
    fin_rate_rad_s: FloatArray


def _finite_speed(surge_speed_m_s: npt.ArrayLike) -> FloatArray:
    speed = np.asarray(surge_speed_m_s, dtype=float)
    if not np.isfinite(speed).all():
        raise SwimInputError(f"the forward speed must be finite, got {speed.ravel().tolist()}")
    return speed


def water_force_on_tail(
    tail: Tail,
    fish: FishParameters,
    motor_angle: npt.ArrayLike,
    motor_velocity: npt.ArrayLike,
    surge_speed_m_s: npt.ArrayLike = 0.0,
    motor_acceleration: npt.ArrayLike = 0.0,
) -> WaterForce:
    """The water's force on the tail, the fish held at forward speed U (v = r = 0).

    ``motor_angle`` [rad], ``motor_velocity`` [rad/s] and ``motor_acceleration`` [rad/s²] are
    the carrier's (the recoil of a fin with chord depends on the tail's accelerations);
    ``surge_speed_m_s`` is U (0: held at rest).

    Raises:
        SwimInputError: a non-finite U.
        InvalidInputError: a non-finite carrier angle, speed or acceleration (the engine's).
    """
    speed = _finite_speed(surge_speed_m_s)
    angle = np.asarray(motor_angle, dtype=float)
    velocity = np.asarray(motor_velocity, dtype=float)
    state = tail.solve(angle, velocity)
    fin_field = tail.fin_angle_field()
    sample = TailSample(
        *(np.asarray(value, dtype=float) for value in (
            state.tip_x, state.tip_y, state.tip_x_dot, state.tip_y_dot,
            getattr(state, fin_field), getattr(state, f"{fin_field}_dot"),
        ))
    )  # fmt: skip
    held = np.zeros(())
    flow = trailing_edge_force(fish, sample, speed, held, held)
    force_x, force_y = flow.force.x, flow.force.y
    moment_about_tip: FloatArray = np.zeros(())
    if fish.has_fin_drag:
        plate = fin_drag(fish, sample, speed, held, held)
        force_x, force_y = force_x + plate.force.x, force_y + plate.force.y
        moment_about_tip = moment_about_tip + plate.moment_about_tip
    if np.any(np.asarray(fish.fin_chord_m) > 0.0):
        drive = EngineTailDrive(tail, constant_carrier_speed(0.0))
        acceleration = drive.acceleration_at(
            angle,
            velocity,
            np.asarray(finite_values("carrier acceleration", motor_acceleration), np.float64),
        )
        # The body is held: its accelerations, the recoil's added-mass part, are zero.
        recoil = fin_recoil(fish, sample, acceleration, speed, held, held).rest
        force_x, force_y = force_x + recoil.x, force_y + recoil.y
        tip_x, tip_y = flow.tip_body_x, flow.tip_body_y
        moment_about_tip = moment_about_tip + recoil.z - (tip_x * recoil.y - tip_y * recoil.x)
    shape = np.broadcast_shapes(
        np.shape(force_x), np.shape(force_y), np.shape(moment_about_tip), np.shape(sample.tip_x)
    )

    def full(value: npt.ArrayLike) -> FloatArray:
        return np.broadcast_to(np.asarray(value, dtype=float), shape)

    # The tail frame is the body frame mirrored in y: x and moments change sign.
    return WaterForce(
        full(-np.asarray(force_x)), full(force_y), full(sample.tip_x_dot), full(sample.tip_y_dot),
        full(-np.asarray(moment_about_tip)), full(sample.fin_rate),
    )  # fmt: skip


def fin_added_inertia(
    tail: Tail, fish: FishParameters, motor_angle: npt.ArrayLike
) -> FloatArray:
    """The fin plate's added mass reduced to the carrier, m c (n . dM/dphi)² [kg m²].

    M is the plate's mid-chord: its normal velocity is w_c = phi_dot (n . dM/dphi) + U n_x, so
    the recoil -m c w_c_dot n pushes back on the carrier with this inertia times phi_ddot.
    """
    state = tail.solve(np.asarray(motor_angle, dtype=float), 1.0)
    fin_field = tail.fin_angle_field()
    angle = np.asarray(getattr(state, fin_field), dtype=float)
    fin_ratio = np.asarray(getattr(state, f"{fin_field}_dot"), dtype=float)
    # Body frame: dT/dphi = (-Tx', Ty'), and the mid-chord adds (c/2) dt/dphi = -(c/2) theta' n.
    ratio = (
        -np.sin(angle) * np.asarray(state.tip_x_dot)
        + np.cos(angle) * np.asarray(state.tip_y_dot)
        - 0.5 * np.asarray(fish.fin_chord_m) * fin_ratio
    )
    mass = np.asarray(fish.fin_added_mass_per_length_kg_m) * np.asarray(fish.fin_chord_m)
    return np.asarray(mass * ratio * ratio, dtype=float)


def carrier_load_in_water(
    model: CarrierLoadModel,
    fish: FishParameters,
    motor_angle: npt.ArrayLike,
    motor_velocity: npt.ArrayLike,
    motor_acceleration: npt.ArrayLike = 0.0,
    surge_speed_m_s: npt.ArrayLike = 0.0,
) -> CarrierLoad:
    """The carrier's torque and power for the links' inertia and the water, the fish held.

    The external part is the water's (:func:`water_force_on_tail`: Lighthill's force, and for a
    fin with chord its drag and recoil), the inertial part the links'.

    Raises:
        SwimInputError: as :func:`water_force_on_tail`.
        InvalidInputError: a non-finite carrier angle, speed or acceleration.
    """
    water = water_force_on_tail(
        model.tail, fish, motor_angle, motor_velocity, surge_speed_m_s, motor_acceleration
    )
    return model.load(
        motor_angle, motor_velocity, motor_acceleration,
        water.force_x_n, water.force_y_n, water.fin_moment_n_m,
    )  # fmt: skip
