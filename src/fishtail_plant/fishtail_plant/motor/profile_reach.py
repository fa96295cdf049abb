r"""Which carrier speed profiles a DC motor can follow at all: the duty each one asks for.

A profile φ̇(φ) = Ω (1 + δ cos(φ − φ₀)) / √(1 − δ²) (fishtail_kinematics' CarrierSpeedProfile) is
a periodic motion of the carrier. Followed exactly, at every angle it has a speed ω and an
acceleration α = ω dω/dφ, and :class:`~fishtail_plant.motor.dc_motor.DcMotor`'s equation of
motion, solved for the armature instead of the speed, says which duty gives that α at that ω
against the load: the gearbox torque the motion needs (motoring, or driven back through the
gearbox's efficiency, as the model decides), the friction, the current through R, the back-EMF.
The profile is within the motor's reach where that duty stays within [-1, 1] over the whole
revolution (PWM ±255); no controller gets it beyond that, whatever its gains, rate or lead.

>>> from fishtail_plant.motor.dc_motor import DcMotorParameters
>>> motor = DcMotorParameters()
>>> duty = profile_duty(motor, mean_speed_rad_s=10.0, depth=0.0, phase_rad=0.0)
>>> round(float(duty.min()), 3) == round(float(duty.max()), 3)   # no load: a constant duty
True
>>> round(float(deepest_depth(motor, 23.56, 0.0)), 2)   # 3.75 Hz, no load: the rotor's inertia
0.24
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from fishtail_kinematics.engine.carrier_profile import MAX_DEPTH
from fishtail_plant.motor.dc_motor import (
    DcMotorParameters,
    LoadInertia,
    LoadTorque,
    zero_load,
    zero_load_inertia,
)

FloatArray = npt.NDArray[np.float64]
#: Angles a revolution is evaluated at.
SAMPLES = 360


def profile_duty(
    parameters: DcMotorParameters,
    mean_speed_rad_s: float,
    depth: float,
    phase_rad: float,
    load: LoadTorque = zero_load,
    load_inertia: LoadInertia = zero_load_inertia,
    samples: int = SAMPLES,
) -> FloatArray:
    """The duty (armature voltage / supply) that moves the carrier exactly along the profile.

    At ``samples`` carrier angles 2 pi i / samples, i = 0..samples-1, in the motor's steady
    periodic motion. Beyond [-1, 1] somewhere: the profile is beyond the supply.
    """
    p = parameters
    angles = np.arange(samples) * (2.0 * math.pi / samples)
    scale = mean_speed_rad_s / math.sqrt(1.0 - depth * depth)
    speed = scale * (1.0 + depth * np.cos(angles - phase_rad))
    acceleration = speed * (-scale * depth * np.sin(angles - phase_rad))
    torque = np.array([load(float(a), float(w)) for a, w in zip(angles, speed, strict=True)])
    inertia = np.array([load_inertia(float(a)) for a in angles])
    n, k, eta = p.gear_ratio, p.torque_constant_n_m_a, p.gearbox_efficiency
    rotor = p.rotor_inertia_kg_m2 * n * n
    # DcMotor._acceleration solved for the drive torque: the motor drives the load through the
    # gearbox (losses on the load's side) or the load drives the gearbox back.
    motoring = inertia * acceleration + torque >= 0.0
    drive = np.where(
        motoring,
        acceleration * (rotor + inertia / eta) + torque / eta,
        acceleration * (rotor + eta * inertia) + eta * torque,
    )
    viscous = p.viscous_friction_n_m_s * n * n
    friction = viscous * speed + p.coulomb_friction_n_m * n * np.sign(speed)
    current = (drive + friction) / (n * k)
    duty: FloatArray = (current * p.resistance_ohm + k * n * speed) / p.supply_voltage_v
    return duty


def within_supply(duty: FloatArray) -> bool:
    """Whether a revolution's duties all lie within [-1, 1]."""
    return bool(np.max(np.abs(duty)) <= 1.0)


def deepest_depth(
    parameters: DcMotorParameters,
    mean_speed_rad_s: float,
    phase_rad: float,
    load: LoadTorque = zero_load,
    load_inertia: LoadInertia = zero_load_inertia,
    steps: int = 90,
) -> float | None:
    """The deepest δ (on a grid of ``steps`` up to 0.9) whose profile stays within the supply.

    Only depths reached from 0 without leaving the supply count (the band that contains the flat
    profile); None if even the flat profile (δ = 0) is beyond it.
    """
    deepest = None
    for i in range(steps + 1):
        depth = MAX_DEPTH * i / steps
        duty = profile_duty(parameters, mean_speed_rad_s, depth, phase_rad, load, load_inertia)
        if not within_supply(duty):
            break
        deepest = depth
    return deepest


def fastest_mean(
    parameters: DcMotorParameters,
    depth: float,
    phase_rad: float,
    load: LoadTorque = zero_load,
    load_inertia: LoadInertia = zero_load_inertia,
    tolerance_rad_s: float = 0.01,
) -> float:
    """The fastest mean speed Ω [rad/s] at which the profile of ``depth`` stays within the supply.

    By bisection, assuming that what is within the supply at some Ω is within it at every
    slower one (true of loads that grow with the speed); 0 if none.
    """

    def fits(mean: float) -> bool:
        duty = profile_duty(parameters, mean, depth, phase_rad, load, load_inertia)
        return within_supply(duty)

    low, high = 0.0, 2.0 * parameters.no_load_speed_rad_s
    if not fits(1e-3):
        return 0.0
    while high - low > tolerance_rad_s:
        middle = 0.5 * (low + high)
        if fits(middle):
            low = middle
        else:
            high = middle
    return low
