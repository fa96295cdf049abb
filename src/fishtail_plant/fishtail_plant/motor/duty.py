r"""A DC gear motor turning a periodic load at constant carrier speed: current, voltage, limits.

Quasi-static: the carrier turns at ω and the load torque at angle φ is c(φ) ω² (c from the tail's
load over a revolution). The motor pays e c = c / η driving the load and c η driven by it, plus
its friction: τ_m = e c ω² / N + b N ω + τ_c at the shaft, i = τ_m / k, and the armature needs
V = R i + k N ω. Every function takes floats or arrays that broadcast (samples of φ along the
first axis, then any number of motors, gear ratios or speeds), so that one formula serves the
motor table of ``fishtail-swim motor`` and a synthesis' whole population. Equations:
docs/motor-load.md ("Method").

>>> from fishtail_plant.motor.dc_motor import DcMotorParameters
>>> constants = MotorConstants.of(DcMotorParameters())
>>> round(float(speed_at_supply(constants, 0.0)), 3)   # no load: the no-load speed at the carrier
34.565
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from fishtail_plant.fish.fish import FloatArray
from fishtail_plant.motor.dc_motor import DcMotorParameters


class MotorConstants(NamedTuple):
    """A motor's constants as floats or arrays (one element per design); SI units, at the shaft."""

    resistance_ohm: npt.ArrayLike
    torque_constant_n_m_a: npt.ArrayLike
    supply_voltage_v: npt.ArrayLike
    gear_ratio: npt.ArrayLike
    gearbox_efficiency: npt.ArrayLike
    viscous_friction_n_m_s: npt.ArrayLike
    coulomb_friction_n_m: npt.ArrayLike

    @classmethod
    def of(
        cls,
        parameters: DcMotorParameters,
        gear_ratio: npt.ArrayLike | None = None,
        gearbox_efficiency: npt.ArrayLike | None = None,
    ) -> MotorConstants:
        """``parameters``' constants, with other gear ratios and efficiencies when given."""
        p = parameters
        return cls(
            p.resistance_ohm, p.torque_constant_n_m_a, p.supply_voltage_v,
            p.gear_ratio if gear_ratio is None else np.asarray(gear_ratio, dtype=float),
            p.gearbox_efficiency if gearbox_efficiency is None
            else np.asarray(gearbox_efficiency, dtype=float),
            p.viscous_friction_n_m_s, p.coulomb_friction_n_m,
        )  # fmt: skip


def paid_per_speed_squared(
    per_speed_squared: npt.ArrayLike, efficiency: npt.ArrayLike
) -> FloatArray:
    """The load's torque as the motor pays for it, e c: c / η driving the tail, c η driven by it."""
    c = np.asarray(per_speed_squared, dtype=float)
    return np.asarray(np.where(c > 0.0, c / efficiency, c * np.asarray(efficiency)), dtype=float)


class Duty(NamedTuple):
    """The motor at each sample of the load: armature current [A] and the voltage it needs [V]."""

    current_a: FloatArray
    voltage_v: FloatArray


def duty(
    motor: MotorConstants, per_speed_squared: npt.ArrayLike, speed_rad_s: npt.ArrayLike
) -> Duty:
    """Current and voltage at constant carrier speed ω against the load c(φ) ω² (broadcast)."""
    m = motor
    speed = np.asarray(speed_rad_s, dtype=float)
    n, k = np.asarray(m.gear_ratio, dtype=float), np.asarray(m.torque_constant_n_m_a, dtype=float)
    shaft_torque = (
        paid_per_speed_squared(per_speed_squared, m.gearbox_efficiency) * speed**2 / n
        + np.asarray(m.viscous_friction_n_m_s) * n * speed
        + np.asarray(m.coulomb_friction_n_m)
    )
    current = shaft_torque / k
    return Duty(current, np.asarray(m.resistance_ohm) * current + k * n * speed)


def speed_at_supply(motor: MotorConstants, paid: npt.ArrayLike) -> FloatArray:
    """The ω > 0 at which a ω² + β ω + γ = V for the paid load e c; 0 if friction takes all of V.

    a = R e c / (k N), β = R b N / k + k N, γ = R τ_c / k. ``paid`` is e c at the angle that
    matters: its largest value (held at constant speed) or its mean (a flywheel carries the
    peaks). inf where a < 0 reaches past every supply limit.
    """
    m = motor
    k, n, r = (np.asarray(value, dtype=float)
               for value in (m.torque_constant_n_m_a, m.gear_ratio, m.resistance_ohm))  # fmt: skip
    a = r * np.asarray(paid, dtype=float) / (k * n)
    beta = r * np.asarray(m.viscous_friction_n_m_s) * n / k + k * n
    headroom = np.asarray(m.supply_voltage_v) - r * np.asarray(m.coulomb_friction_n_m) / k
    discriminant = beta * beta + 4.0 * a * headroom
    with np.errstate(invalid="ignore", divide="ignore"):
        # The smaller positive root, without the cancellation of -β + sqrt(...) for small a.
        root = 2.0 * headroom / (beta + np.sqrt(discriminant))
    speed = np.where(discriminant < 0.0, np.inf, root)
    return np.asarray(np.where(headroom <= 0.0, 0.0, speed), dtype=float)


def torque_at_carrier(motor: MotorConstants, speed_rad_s: npt.ArrayLike) -> FloatArray:
    """The motor's steady torque at the carrier at full duty (its torque-speed line, motoring)."""
    m = motor
    speed = np.asarray(speed_rad_s, dtype=float)
    k, n = np.asarray(m.torque_constant_n_m_a, dtype=float), np.asarray(m.gear_ratio, dtype=float)
    at_shaft = (k * (np.asarray(m.supply_voltage_v) - k * n * speed) / np.asarray(m.resistance_ohm)
                - np.asarray(m.viscous_friction_n_m_s) * n * speed
                - np.asarray(m.coulomb_friction_n_m))  # fmt: skip
    return np.asarray(np.asarray(m.gearbox_efficiency) * n * at_shaft, dtype=float)
