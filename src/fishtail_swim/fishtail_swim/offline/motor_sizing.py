r"""Motor sizing: how fast a DC gear motor turns the tail, and what it draws doing so.

``fishtail-swim motor``: the tail's load (:class:`~fishtail_plant.linkage_load.tail_load.TailLoad`)
against :class:`~fishtail_plant.motor.dc_motor.DcMotor`, quasi-statically at constant carrier
speeds (the table and two limits at full duty, each one quadratic) and time-stepped
(:mod:`.full_duty_run`), then the verdict: sustains, stalls, or cannot start the tail. The
equations, how the levels differ and the worked example: docs/motor-load.md ("Choosing a motor").

>>> from fishtail_plant.motor.dc_motor import DcMotorParameters
>>> motor = DcMotorParameters.from_stall_and_no_load(
...     supply_voltage_v=12.0, stall_torque_n_m=1.0, no_load_speed_rad_s=20.0, gear_ratio=30.0)
>>> free = LoadSamples(np.zeros(8), np.zeros(8))  # no load: both limits are the no-load speed
>>> [round(speed, 9) for speed in quasi_static_limits(motor, free)]
[20.0, 20.0]
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from fishtail_plant.errors import SwimError
from fishtail_plant.fish.fish import FloatArray
from fishtail_plant.linkage_load.tail_load import TailLoad
from fishtail_plant.motor.dc_motor import DcMotorParameters
from fishtail_plant.motor.duty import (
    MotorConstants,
    duty,
    paid_per_speed_squared,
    speed_at_supply,
    torque_at_carrier,
)
from fishtail_plant.motor.full_duty_run import (
    DEFAULT_RUN_LIMITS,
    FullDutyRun,
    RunLimits,
    run_at_full_duty,
)
from fishtail_swim.offline.held_fish_table import HeldFishRows, held_linkage_rows
from fishtail_swim.offline.motor_load_table import SAMPLES_PER_REVOLUTION

#: Beat frequencies [Hz] of the table when none are given (one beat per carrier revolution).
DEFAULT_FREQUENCIES_HZ = (0.5, 1.0, 1.5, 2.0, 2.5, 3.0)
#: A row's verdict on holding its constant speed: the supply's voltage suffices at every angle;
#: it does not; the peak load is beyond the motor's stall torque at the carrier (which no duty at
#: this supply gives at any speed).
OK, OVER_THE_SUPPLY, OVER_THE_STALL = "ok", "over the supply", "over the stall"


#: Revolutions the full-duty run needs at least before it can count as settled.
_SETTLING_REVOLUTIONS = 4


class UnsettledRunError(SwimError):
    """The full-duty run cannot settle within its limits: no verdict is given."""


class LoadSamples(NamedTuple):
    """The tail's load over one revolution, at evenly spaced carrier angles from 0."""

    #: c(φ) = τ_L / ω² [N m s²/rad²]: the load torque at 1 rad/s.
    per_speed_squared_n_m_s2: FloatArray
    #: J(φ) [kg m²], the inertia reduced to the carrier: the links', and in water the fin's
    #: added mass.
    inertia_kg_m2: FloatArray


def sample_load(load: TailLoad, samples: int = SAMPLES_PER_REVOLUTION) -> LoadSamples:
    """c(φ) and J(φ) of ``load`` at ``samples`` angles (the engine's values, not the table's)."""
    if load.surroundings == "none":
        return LoadSamples(np.zeros(samples), np.zeros(samples))
    angles = np.arange(samples) * (2.0 * math.pi / samples)
    exact = load.exact(angles, 1.0)
    return LoadSamples(
        np.asarray(exact.torque_n_m, dtype=float),
        np.asarray(exact.reduced_inertia_kg_m2, dtype=float),
    )


def torque_at_carrier_n_m(parameters: DcMotorParameters, speed_rad_s: npt.ArrayLike) -> FloatArray:
    """The motor's torque at the carrier at full duty, steady: its torque-speed line (motoring)."""
    return torque_at_carrier(MotorConstants.of(parameters), speed_rad_s)


class QuasiStaticRows(NamedTuple):
    """One element per beat frequency, at the constant carrier speed 2 π f."""

    beat_frequency_hz: FloatArray
    carrier_speed_rad_s: FloatArray
    peak_torque_n_m: FloatArray  # max |τ_L| at the carrier
    rms_torque_n_m: FloatArray
    peak_current_a: FloatArray  # max |i|
    rms_current_a: FloatArray
    mean_supply_power_w: FloatArray  # V_req i: the supply's power at the duty V_req / V
    peak_voltage_v: FloatArray
    mean_voltage_v: FloatArray
    verdict: tuple[str, ...]


def quasi_static_rows(
    parameters: DcMotorParameters, load: LoadSamples, frequencies_hz: npt.ArrayLike
) -> QuasiStaticRows:
    """Torque, current, power and the voltage needed over a revolution at each beat frequency."""
    p = parameters
    frequencies = np.atleast_1d(np.asarray(frequencies_hz, dtype=float))
    speeds = 2.0 * math.pi * frequencies
    c = load.per_speed_squared_n_m_s2[:, None]
    torque = c * speeds**2
    current, voltage = duty(MotorConstants.of(p), c, speeds)
    peak_torque = np.abs(torque).max(axis=0)
    peak_voltage = voltage.max(axis=0)
    # A row at a limit itself (within rounding) is within it.
    stall, supply = (limit * (1.0 + 1e-9) for limit in (p.stall_torque_n_m, p.supply_voltage_v))
    verdict = tuple(
        OVER_THE_STALL if peak > stall else OVER_THE_SUPPLY if volts > supply else OK
        for peak, volts in zip(peak_torque, peak_voltage, strict=True)
    )  # fmt: skip
    return QuasiStaticRows(
        frequencies,
        speeds,
        peak_torque,
        np.sqrt(np.mean(torque**2, axis=0)),
        np.abs(current).max(axis=0),
        np.sqrt(np.mean(current**2, axis=0)),
        np.mean(voltage * current, axis=0),
        peak_voltage,
        voltage.mean(axis=0),
        verdict,
    )


class QuasiStaticLimits(NamedTuple):
    """The carrier speeds [rad/s] at which full duty just suffices (0: the motor cannot turn)."""

    #: The peak of the required voltage reaches the supply: held at a constant speed.
    constant_speed_rad_s: float
    #: Its mean over the revolution reaches the supply: a flywheel carries the peaks.
    mean_rad_s: float


def quasi_static_limits(parameters: DcMotorParameters, load: LoadSamples) -> QuasiStaticLimits:
    """The constant-speed and on-the-mean limits at full duty (docs/motor-load.md, "Method")."""
    paid = paid_per_speed_squared(load.per_speed_squared_n_m_s2, parameters.gearbox_efficiency)
    constants = MotorConstants.of(parameters)
    return QuasiStaticLimits(
        float(speed_at_supply(constants, paid.max())),
        float(speed_at_supply(constants, paid.mean())),
    )


class MotorSizing(NamedTuple):
    """Everything ``fishtail-swim motor`` prints and draws for one motor and one tail."""

    parameters: DcMotorParameters
    load: LoadSamples
    rows: QuasiStaticRows
    limits: QuasiStaticLimits
    run: FullDutyRun
    #: max |τ_L(φ, 0)| [N m]: what the motor must overcome to start (0 for the tail's load).
    load_at_rest_n_m: float
    verdict: str
    #: The fish held still at the rows' beat frequencies (the tail's power then is the fin's drag
    #: for mechanism 1), or None for a load without water.
    held: HeldFishRows | None = None


def size_motor(
    parameters: DcMotorParameters,
    load: TailLoad,
    frequencies_hz: npt.ArrayLike = DEFAULT_FREQUENCIES_HZ,
    limits: RunLimits = DEFAULT_RUN_LIMITS,
    progress: Callable[[float], None] | None = None,
) -> MotorSizing:
    """The table, both quasi-static limits, the full-duty run and the verdict for ``load``.

    Raises:
        UnsettledRunError: a run that would need more than ``limits.max_steps`` steps to settle
            (said before running, from the on-the-mean speed and the motor's step), or that
            reached a limit of ``limits`` without settling, turning or stopping.
    """
    samples = sample_load(load)
    rows = quasi_static_rows(parameters, samples, frequencies_hz)
    quasi_static = quasi_static_limits(parameters, samples)
    start = quasi_static.mean_rad_s if math.isfinite(quasi_static.mean_rad_s) else 0.0
    _check_run_length(parameters, start, limits)
    run = run_at_full_duty(parameters, load.torque, load.inertia, start, limits, progress)
    if run.started and run.stopped_at_rad is None and not run.settled:
        raise UnsettledRunError(
            f"the full-duty run did not settle: {run.revolutions} revolutions in "
            f"{run.simulated_s:.4g} s simulated, steps of {parameters.step_s:.3g} s, reached its "
            f"limit ({limits.max_steps} steps, {limits.max_revolutions} revolutions or "
            f"{limits.max_simulated_s:g} s): no verdict; check the motor's figures"
        )
    angles = np.arange(samples.inertia_kg_m2.size) * (2.0 * math.pi / samples.inertia_kg_m2.size)
    at_rest = max(abs(load.torque(float(angle), 0.0)) for angle in angles)
    slowest = float(np.min(rows.beat_frequency_hz))
    held = None
    if load.surroundings.startswith("water"):
        held = held_linkage_rows(load.model.tail, load.fish, rows.carrier_speed_rad_s)
    return MotorSizing(
        parameters, samples, rows, quasi_static, run, at_rest,
        verdict(parameters, run, slowest, at_rest), held,
    )  # fmt: skip


def _check_run_length(parameters: DcMotorParameters, speed_rad_s: float, limits: RunLimits) -> None:
    """Refuse a run whose settling would take more steps than the limit, before running it.

    Raises:
        UnsettledRunError: _SETTLING_REVOLUTIONS revolutions at ``speed_rad_s`` (the on-the-mean
            speed) over ``limits.max_steps`` steps of the motor's step.
    """
    if speed_rad_s <= 0.0:  # the run finds out at once whether it starts
        return
    step = parameters.step_s
    needed = _SETTLING_REVOLUTIONS * 2.0 * math.pi / speed_rad_s / step
    if needed > limits.max_steps:
        raise UnsettledRunError(
            f"the full-duty run would need about {needed:.3g} steps to settle, over its limit of "
            f"{limits.max_steps}: the motor's step is {step:.3g} s (0.1 of its mechanical time "
            f"constant, rotor inertia R / k^2) and a revolution at {speed_rad_s:.3g} rad/s takes "
            f"{2.0 * math.pi / speed_rad_s:.3g} s; check the motor's figures"
        )


def verdict(
    parameters: DcMotorParameters, run: FullDutyRun, slowest_hz: float, load_at_rest_n_m: float
) -> str:
    """One sentence: cannot start the tail, stalls (at what), or sustains what beat frequency."""
    p = parameters
    stall = p.stall_torque_n_m
    if not run.started:
        if stall <= 0.0:
            return (
                f"cannot start the tail: the motor cannot turn itself at {p.supply_voltage_v:g} V "
                f"(its friction, {p.coulomb_friction_n_m:.3g} N m at the shaft, takes all of "
                f"k V / R = {p.torque_constant_n_m_a * p.stall_current_a:.3g} N m)"
            )
        return (
            f"cannot start the tail: peak load {load_at_rest_n_m:.3g} N m at rest > stall "
            f"{stall:.3g} N m at the carrier"
        )
    if run.stopped_at_rad is not None:
        return (
            f"stalls: at full duty the carrier stops at phi = "
            f"{run.stopped_at_rad % (2.0 * math.pi):.3f} rad, in revolution {run.revolutions + 1}"
        )
    frequency = run.mean_speed_rad_s / (2.0 * math.pi)
    # The RMS current heats the winding: its share of the stall current says how hard it works.
    current = (
        f"RMS current {run.rms_current_a:.3g} A, "
        f"{100.0 * run.rms_current_a / p.stall_current_a:.0f} % of the stall current"
    )
    if frequency < slowest_hz:
        return (
            f"stalls at {frequency:#.3g} Hz: at full duty the tail holds the carrier to "
            f"{run.mean_speed_rad_s:.3g} rad/s, below the slowest beat asked for "
            f"({slowest_hz:g} Hz); {current}"
        )
    return (
        f"sustains {frequency:#.3g} Hz at full duty ({p.supply_voltage_v:g} V, PWM 255): mean "
        f"carrier speed {run.mean_speed_rad_s:.3g} rad/s; {current}"
    )
