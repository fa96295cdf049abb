"""How each design swims and what it asks of its motor: the cycle-average tier of the search.

The carrier at constant speed Omega; the fish held at its balance speed U (sway and yaw held,
:func:`~fishtail_plant.fish.figures.steady_surge_speed`); the carrier's load from the tail's
power into the water, tau(phi) = P(phi) / Omega (virtual work, exact for the water's forces;
the links' own inertia is left to the verified tier); the motor quasi-static at Omega
(:mod:`~fishtail_plant.motor.duty`). "As fast as the motor sustains" is the speed at which the
required voltage reaches the supply on the mean over a revolution. Every figure is computed for the
whole population at once. The method and its limits: docs/design.md ("Fidelity").
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from fishtail_design.linkages import Linkages
from fishtail_kinematics.engine.carrier_profile import CarrierSpeedProfile
from fishtail_plant.fish.cycle_kernel import HeldCycles
from fishtail_plant.fish.figures import held_tail, steady_surge_speed
from fishtail_plant.fish.fish import FishParameters, FloatArray
from fishtail_plant.fish.steady_turn import strongest_phases
from fishtail_plant.fish.tail_drive import CarrierMotion, TailDrive, constant_carrier_speed
from fishtail_plant.motor.duty import (
    MotorConstants,
    duty,
    paid_per_speed_squared,
    speed_at_supply,
    torque_at_carrier,
)

#: Modulation phases the turning figure scans (their interpolant gives the strongest phases).
TURNING_PHASES = 4
#: Bisections of the quasi-steady yaw rate (2^-40 of its bracket).
_YAW_BISECTIONS = 40


class Performance(NamedTuple):
    """The cycle-average figures of each design, one element per design (NaN: none)."""

    carrier_speed_rad_s: FloatArray
    beat_frequency_hz: FloatArray
    speed_m_s: FloatArray
    body_lengths_per_s: FloatArray
    strouhal_number: FloatArray
    thrust_n: FloatArray
    tail_power_w: FloatArray
    electrical_power_w: FloatArray
    cost_of_transport_j_kg_m: FloatArray
    rms_current_a: FloatArray
    peak_current_a: FloatArray
    peak_load_torque_n_m: FloatArray
    motor_torque_n_m: FloatArray  # the motor's full-duty torque at the carrier at Omega
    holding_speed_rad_s: FloatArray  # the fastest Omega the motor holds at every angle
    #: The fastest mean Omega it sustains: the mean required voltage reaches the supply (the
    #: carrier slows through the load's peaks and the inertia carries it; within a few per cent
    #: of the full-duty run's mean speed).
    sustained_speed_rad_s: FloatArray
    turning_rad_per_beat: FloatArray


def _times(samples: int, speed_rad_s: FloatArray) -> FloatArray:
    """``samples`` times over one revolution of each carrier, shape (samples, N)."""
    return (np.arange(samples)[:, None] / samples) * (2.0 * math.pi / speed_rad_s)


def performance(
    linkages: Linkages,
    fish: FishParameters,
    motor: MotorConstants,
    carrier_speed_rad_s: FloatArray,
    samples: int,
    turning_depth: float | None = None,
    compiled: bool = True,
) -> Performance:
    """The figures of every design at its carrier speed (NaN: as fast as the motor holds it).

    ``turning_depth``: also the quasi-steady turning at that modulation depth (slower).
    ``compiled``: towed by the mechanism's compiled kernel where numba is there (the same
    figures to rounding, tens of times faster); False: by numpy.
    """
    count = linkages.size
    unit = np.ones(count)
    # The load at Omega = 1: the balance speed per carrier speed and tau(phi) / Omega².
    towed = towed_cycles(linkages, fish, unit, samples, compiled)
    per_speed = towed.speed_m_s
    paid = paid_per_speed_squared(towed.power_w, motor.gearbox_efficiency)
    holding = speed_at_supply(motor, paid.max(axis=0))
    sustained = speed_at_supply(motor, paid.mean(axis=0))
    speed = np.where(np.isnan(carrier_speed_rad_s), sustained, carrier_speed_rad_s)
    if np.all(np.asarray(fish.surge_linear_damping_kg_s) == 0.0):
        # Without a linear drag U ∝ Omega, the push ∝ Omega², the power ∝ Omega³ (no scale but
        # the beat's): the unit pass gives every speed.
        swim_speed = per_speed * speed
        thrust = towed.push_n * speed**2
        load = towed.power_w
    else:
        # A design without a speed (it does not assemble or never balances) runs at 1 rad/s
        # for the batch's sake; its figures stay NaN.
        usable = np.isfinite(speed) & (speed > 0.0)
        at_speed = towed_cycles(linkages, fish, np.where(usable, speed, 1.0), samples, compiled)
        swim_speed = np.where(usable, at_speed.speed_m_s, np.nan)
        thrust = at_speed.push_n
        load = at_speed.power_w / speed**3
    tail_power = load.mean(axis=0) * speed**3
    current, voltage = duty(motor, load, speed)
    electrical = (current * voltage).mean(axis=0)
    rms, peak = np.sqrt((current**2).mean(axis=0)), np.abs(current).max(axis=0)
    # Above the holding speed the motor is at full duty and the inertia carries the carrier
    # through the load's peaks: the armature sees the supply and a nearly steady speed, so its
    # current is nearly constant, the mean the load asks for (the verified run has the ripple).
    saturated = speed > holding
    steady = current.mean(axis=0)
    electrical = np.where(saturated, np.asarray(motor.supply_voltage_v) * steady, electrical)
    rms = np.where(saturated, np.abs(steady), rms)
    peak = np.where(saturated, np.abs(steady), peak)
    frequency = speed / (2.0 * math.pi)
    excursion = towed.tip_excursion_m
    turning = np.full(count, np.nan)
    if turning_depth is not None:
        turning = quasi_steady_turning(linkages, fish, speed, swim_speed, samples, turning_depth)
    with np.errstate(invalid="ignore", divide="ignore"):
        return Performance(
            speed, frequency, swim_speed, swim_speed / np.asarray(fish.body_length_m),
            frequency * excursion / swim_speed, thrust, tail_power, electrical,
            electrical / (swim_speed * np.asarray(fish.body_mass_kg)),
            rms, peak,
            np.abs(load).max(axis=0) * speed**2, torque_at_carrier(motor, speed), holding,
            sustained, turning,
        )  # fmt: skip


def towed_cycles(
    linkages: Linkages,
    fish: FishParameters,
    carrier_speed_rad_s: FloatArray,
    samples: int,
    compiled: bool = True,
) -> HeldCycles:
    """Every design at its constant carrier speed, towed at its balance speed, over one beat.

    :func:`~fishtail_plant.fish.figures.steady_surge_speed` and
    :func:`~fishtail_plant.fish.figures.held_tail` at ``samples`` times of the beat; where numba
    is there and ``compiled``, the mechanism's compiled kernel (``linkages.held_cycles``: for
    mechanism 1 :func:`~fishtail_plant.fish.cycle_kernel.held_cycles`, for mechanism 2
    :func:`~fishtail_plant.fish.loop_kernel.held_loop_cycles`), which gives the same to rounding.
    """
    if compiled:
        cycles = linkages.held_cycles(fish, carrier_speed_rad_s, samples)
        if cycles is not None:
            return cycles
    drive = linkages.drive(constant_carrier_speed(carrier_speed_rad_s))
    period = 2.0 * math.pi / carrier_speed_rad_s
    balance = steady_surge_speed(drive, fish, period, samples, strict=False)
    towed = held_tail(drive, fish, _times(samples, carrier_speed_rad_s), balance)
    excursion = np.ptp(np.asarray(towed.tail.tip_y), axis=0)
    return HeldCycles(balance, towed.push_n.mean(axis=0), towed.power_w, excursion)


def _profile_motion(depth: float, phase_rad: float, speed_rad_s: FloatArray) -> CarrierMotion:
    """The modulated carrier at mean speeds Omega: the unit-speed profile's motion, time-scaled."""
    unit = CarrierSpeedProfile(1.0, depth, phase_rad).motion()

    def motion(time_s: object) -> tuple[FloatArray, FloatArray, FloatArray]:
        angle, rate, acceleration = unit(np.asarray(time_s, dtype=float) * speed_rad_s)
        return angle, rate * speed_rad_s, acceleration * speed_rad_s**2

    return motion


def quasi_steady_turning(
    linkages: Linkages,
    fish: FishParameters,
    carrier_speed_rad_s: FloatArray,
    swim_speed_m_s: FloatArray,
    samples: int,
    depth: float,
) -> FloatArray:
    """Heading change per beat [rad] the weaker way round, at modulation ``depth``.

    At each phase the body is held at u = U, v = 0 and turned at the yaw rate r at which the
    tail's mean yaw moment balances the hull's yaw damping (bisected); the strongest left and
    right phases come from the scan's interpolant, and the smaller of the two turns is the
    design's authority (a one-way motor must steer both ways). The time-stepped free body of
    the verified tier measures the same thing with sway and drift.
    """
    count = linkages.size
    period = 2.0 * math.pi / carrier_speed_rad_s
    times = _times(samples, carrier_speed_rad_s)
    phases = np.arange(TURNING_PHASES) * (2.0 * math.pi / TURNING_PHASES)
    damping = np.asarray(fish.yaw_damping_kg_m2)
    linear = np.asarray(fish.yaw_linear_damping_kg_m2_s)
    per_beat = np.empty((TURNING_PHASES, count))
    for index, phase in enumerate(phases):
        drive = linkages.drive(_profile_motion(depth, float(phase), carrier_speed_rad_s))

        def net(rate: FloatArray, drive: TailDrive = drive) -> FloatArray:
            tail = held_tail(drive, fish, times, swim_speed_m_s, rate)
            hull = damping * rate * np.abs(rate) + linear * rate
            return np.asarray(tail.yaw_moment_n_m.mean(axis=0) - hull, dtype=float)

        # The yaw rate lies within the tail's own angular speed, |r| < 2 pi / T.
        bound = 2.0 * math.pi / period
        low, high = -bound, bound
        for _ in range(_YAW_BISECTIONS):
            middle = 0.5 * (low + high)
            above = net(middle) > 0.0
            low, high = np.where(above, middle, low), np.where(above, high, middle)
        per_beat[index] = 0.5 * (low + high) * period
    result = np.full(count, np.nan)
    for design in range(count):
        if np.all(np.isfinite(per_beat[:, design])):
            strongest = strongest_phases(phases, per_beat[:, design], resolution=360)
            result[design] = min(strongest.left_yaw_per_beat_rad,
                                 -strongest.right_yaw_per_beat_rad)  # fmt: skip
    return result
