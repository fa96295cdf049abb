"""The DC motor at full duty turning the tail, revolution by revolution until its motion repeats.

The time-stepped level of :mod:`fishtail_swim.offline.motor_sizing`: the highest beat frequency
the motor sustains (:class:`fishtail_plant.motor.dc_motor.DcMotor` at PWM 255 with the tail's
load), and its current. How a revolution is timed and when the run ends: docs/motor-load.md
("Choosing a motor", "Method").

>>> from fishtail_plant.motor.dc_motor import DcMotorParameters
>>> motor = DcMotorParameters.from_stall_and_no_load(
...     supply_voltage_v=12.0, stall_torque_n_m=1.0, no_load_speed_rad_s=20.0, gear_ratio=30.0)
>>> run = run_at_full_duty(motor, lambda phi, omega: 0.0, lambda phi: 0.0)
>>> run.settled, round(run.mean_speed_rad_s, 4)    # unloaded, from rest: the no-load speed
(True, 20.0)
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

from fishtail_plant.motor.dc_motor import DcMotor, DcMotorParameters, LoadInertia, LoadTorque


class RunLimits(NamedTuple):
    """How long the full-duty run may go on and when it counts as settled."""

    #: Successive revolutions' times agree to this fraction: the motion is periodic.
    settle_tolerance: float = 1e-4
    #: Revolutions averaged once settled (the first, with the start's transient, never counts).
    averaged_revolutions: int = 2
    max_revolutions: int = 200
    max_simulated_s: float = 600.0
    #: 2-6 s of stepping (10-30 us a step with the tail's load); the report's motors settle
    #: within 15 000 steps, a rotor 300 times the default's included.
    max_steps: int = 200_000


DEFAULT_RUN_LIMITS = RunLimits()


class FullDutyRun(NamedTuple):
    """The DcMotor at full duty with the tail's load: figures of the last revolutions.

    ``started`` is False when the carrier does not move forward from rest at φ = 0 (then nothing
    else was run); ``stopped_at_rad`` is the angle at which it stuck after moving (None while it
    kept turning). Without ``settled`` the figures are those of the last revolutions run (the run
    reached a limit of :class:`RunLimits`).
    """

    started: bool
    stopped_at_rad: float | None
    settled: bool
    revolutions: int  # whole revolutions completed
    averaged_revolutions: int  # the last ones, which the figures below describe
    simulated_s: float
    mean_speed_rad_s: float
    min_speed_rad_s: float
    max_speed_rad_s: float
    peak_current_a: float
    rms_current_a: float
    mean_supply_power_w: float
    peak_carrier_torque_n_m: float


class _Revolution:
    """Integrals and extremes over one revolution (or the part of one run so far)."""

    def __init__(self) -> None:
        self.duration_s = 0.0
        self.charge_c = 0.0  # ∫ i dt
        self.current_squared_a2_s = 0.0  # ∫ i² dt
        self.min_speed = math.inf
        self.max_speed = 0.0
        self.peak_current = 0.0
        self.peak_torque = 0.0

    def add(self, dt: float, current: tuple[float, float]) -> None:
        """A stretch of ``dt`` with the current going linearly from current[0] to current[1]."""
        first, last = current
        self.duration_s += dt
        self.charge_c += 0.5 * dt * (first + last)
        self.current_squared_a2_s += dt * (first * first + first * last + last * last) / 3.0

    def sample(self, speed: float, current: float, torque: float) -> None:
        """One state of the run, for the extremes."""
        self.min_speed = min(self.min_speed, speed)
        self.max_speed = max(self.max_speed, speed)
        self.peak_current = max(self.peak_current, abs(current))
        self.peak_torque = max(self.peak_torque, abs(torque))


def _summary(
    parameters: DcMotorParameters,
    revolutions: list[_Revolution],
    *,
    started: bool,
    stopped_at_rad: float | None,
    settled: bool,
    completed: int,
    simulated_s: float,
    angle_rad: float,
) -> FullDutyRun:
    duration = sum(revolution.duration_s for revolution in revolutions)
    if duration > 0.0:
        # Whole revolutions give the mean speed; a run that completed none, its angle over time.
        turned = 2.0 * math.pi * len(revolutions) if completed else angle_rad
        mean_speed = turned / duration
        rms_current = math.sqrt(sum(r.current_squared_a2_s for r in revolutions) / duration)
        mean_current = sum(r.charge_c for r in revolutions) / duration
    else:  # stuck from the start: the stall current flows
        mean_speed, rms_current = 0.0, parameters.stall_current_a
        mean_current = parameters.stall_current_a
    return FullDutyRun(
        started=started,
        stopped_at_rad=stopped_at_rad,
        settled=settled,
        revolutions=completed,
        averaged_revolutions=len(revolutions) if completed else 0,
        simulated_s=simulated_s,
        mean_speed_rad_s=mean_speed,
        min_speed_rad_s=min(r.min_speed for r in revolutions),
        max_speed_rad_s=max(r.max_speed for r in revolutions),
        peak_current_a=max(r.peak_current for r in revolutions),
        rms_current_a=rms_current,
        mean_supply_power_w=parameters.supply_voltage_v * mean_current,
        peak_carrier_torque_n_m=max(r.peak_torque for r in revolutions),
    )


def _settled(durations: list[float], tolerance: float) -> bool:
    """The revolutions' time is within ``tolerance`` of its limit, extrapolated geometrically.

    Near the periodic motion successive changes of the revolution's time shrink by a ratio
    rho < 1 (a slow approach, such as a heavy rotor's, has rho near 1), so the change still to
    come is about |last change| rho / (1 - rho); rho is taken as at most 0.99.
    """
    if len(durations) < 4:  # three revolutions after the first, which holds the start's transient
        return False
    first, second, last = durations[-3:]
    change, before = last - second, second - first
    if change == 0.0:
        return True
    ratio = min(abs(change / before), 0.99) if before != 0.0 else 0.99
    return abs(change) * ratio / (1.0 - ratio) <= tolerance * last


def _crossing(
    angle_0: float, angle_1: float, slope_0: float, slope_1: float, boundary: float
) -> float:
    """The fraction s of a step at which the angle's cubic Hermite passes ``boundary``.

    The cubic through both ends with their rates (speed times step) keeps the revolutions' times
    from jittering with where the step grid falls: with the default motor and the report's tails
    they repeat to 2e-10 (mechanism 1) and 5e-7 (mechanism 2, whose gearbox switches between
    driving and being driven within steps), against 3e-6 and 5e-6 with a straight line; that
    jitter would hold up the settling test.
    """
    s = (boundary - angle_0) / (angle_1 - angle_0)
    for _ in range(4):  # Newton from the straight line's answer
        value = ((2 * s**3 - 3 * s**2 + 1) * angle_0 + (s**3 - 2 * s**2 + s) * slope_0
                 + (3 * s**2 - 2 * s**3) * angle_1 + (s**3 - s**2) * slope_1
                 - boundary)  # fmt: skip
        rate = ((6 * s**2 - 6 * s) * (angle_0 - angle_1) + (3 * s**2 - 4 * s + 1) * slope_0
                + (3 * s**2 - 2 * s) * slope_1)  # fmt: skip
        if rate <= 0.0:
            break
        s = min(max(s - value / rate, 0.0), 1.0)
    return s


def starts_from_rest(
    parameters: DcMotorParameters, load: LoadTorque, load_inertia: LoadInertia
) -> bool:
    """Whether the carrier, at rest at φ = 0, moves forward at full duty (the model's breakaway).

    A load that pushes back harder than the motor drives it backward: it does not start either.
    """
    motor = DcMotor(parameters, load, load_inertia)
    motor.set_duty(1.0)
    motor.advance(parameters.step_s)
    return motor.angle_rad > 0.0


def run_at_full_duty(
    parameters: DcMotorParameters,
    load: LoadTorque,
    load_inertia: LoadInertia,
    start_speed_rad_s: float = 0.0,
    limits: RunLimits = DEFAULT_RUN_LIMITS,
    progress: Callable[[float], None] | None = None,
) -> FullDutyRun:
    """Run the motor at duty 1 from φ = 0 until its revolutions settle (or a limit is reached).

    The periodic motion it settles to does not depend on the start; a start near it (such as the
    on-the-mean speed) only shortens the way there, which for a heavy rotor is long from rest.
    """
    if not starts_from_rest(parameters, load, load_inertia):
        at_rest = _Revolution()
        at_rest.sample(0.0, parameters.stall_current_a, 0.0)
        return _summary(
            parameters, [at_rest], started=False, stopped_at_rad=None, settled=True,
            completed=0, simulated_s=0.0, angle_rad=0.0,
        )  # fmt: skip
    motor = DcMotor(parameters, load, load_inertia, speed_rad_s=start_speed_rad_s)
    motor.set_duty(1.0)
    step = parameters.step_s
    max_steps = min(limits.max_steps, math.ceil(limits.max_simulated_s / step))
    finished: list[_Revolution] = []
    durations: list[float] = []
    current = _Revolution()
    i_before = motor.current_at(motor.speed_rad_s)
    current.sample(motor.speed_rad_s, i_before, motor.outputs().carrier_torque_n_m)
    boundary = 2.0 * math.pi
    settled = False
    stopped_at: float | None = None
    steps = 0
    while steps < max_steps and not settled and len(finished) < limits.max_revolutions:
        angle_before, speed_before = motor.angle_rad, motor.speed_rad_s
        motor.advance(step)
        steps += 1
        if motor.speed_rad_s == 0.0 and speed_before == 0.0 and motor.angle_rad == angle_before:
            # Stuck at rest: the state and the duty no longer change, so neither will it.
            stopped_at = motor.angle_rad
            break
        i_after = motor.current_at(motor.speed_rad_s)
        if motor.angle_rad >= boundary:  # one step covers far less than a revolution
            fraction = _crossing(
                angle_before, motor.angle_rad, speed_before * step, motor.speed_rad_s * step,
                boundary,
            )  # fmt: skip
            i_cross = i_before + fraction * (i_after - i_before)
            current.add(fraction * step, (i_before, i_cross))
            finished.append(current)
            durations.append(current.duration_s)
            current = _Revolution()
            current.add((1.0 - fraction) * step, (i_cross, i_after))
            boundary += 2.0 * math.pi
            settled = _settled(durations, limits.settle_tolerance)
        else:
            current.add(step, (i_before, i_after))
        current.sample(motor.speed_rad_s, i_after, motor.outputs().carrier_torque_n_m)
        i_before = i_after
        if progress is not None and steps % 4096 == 0:
            progress(steps / max_steps)
    # The first revolution holds the start's transient: it is averaged only when it is all there is.
    usable = finished[1:] if len(finished) > 1 else finished
    averaged = usable[-limits.averaged_revolutions :] if usable else [current]
    return _summary(
        parameters, averaged, started=True, stopped_at_rad=stopped_at, settled=settled,
        completed=len(finished), simulated_s=steps * step, angle_rad=motor.angle_rad,
    )  # fmt: skip
