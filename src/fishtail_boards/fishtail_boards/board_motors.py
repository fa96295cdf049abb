"""The motors on the emulated board's two channels: what the PWM set by its firmware moves.

Each channel's motor gets what the emulated firmware's ``setMotorSpeeds()`` writes, whenever it
writes it, and counts its encoder on the motor shaft. Three motors (``fishtail-fake-board
--motor``), from the exact speeds the serial tests check to the loop's real ripple:
:class:`IdealMotor` (the default; the first-order lag following the loop's target),
:class:`PwmFirstOrderMotor` (that lag driven by the PWM) and :class:`DcChannelMotor` (the DC gear
motor at duty PWM / 255, optionally turning the tail). What each shows: docs/serial.md ("The
emulated board").
"""

from __future__ import annotations

import dataclasses
import math
from typing import Protocol

from fishtail_plant.motor.board_units import PWM_MAX, Scale
from fishtail_plant.motor.dc_motor import (
    DcMotor,
    DcMotorParameters,
    LoadInertia,
    LoadTorque,
    zero_load,
    zero_load_inertia,
)
from fishtail_plant.motor.first_order import MotorParameters, SimulatedMotor

MOTOR_KINDS = ("ideal", "first-order", "dc")


class BoardMotor(Protocol):
    """One channel's motor and encoder, as the emulated board drives and reads it."""

    @property
    def speed_rad_s(self) -> float:
        """The carrier speed now."""

    @property
    def target_rad_s(self) -> float:
        """The carrier speed the motor is driven towards (at no load for the DC motor)."""

    def drive(self, pwm: int, target_ticks_per_frame: int, running: bool) -> None:
        """The board wrote ``pwm`` (-255..255); the loop's target and whether it runs."""

    def advance(self, dt_s: float) -> None:
        """Move the motor on by ``dt_s`` seconds."""

    def encoder_counts(self) -> int:
        """The encoder's count on the motor shaft (not wrapped)."""


class IdealMotor(SimulatedMotor):
    """The first-order lag following the loop's target while it runs, else the PWM."""

    def __init__(self, parameters: MotorParameters, scale: Scale) -> None:
        """At rest; ``scale`` turns the loop's ticks per frame into a carrier speed."""
        super().__init__(parameters)
        self.scale = scale

    def drive(self, pwm: int, target_ticks_per_frame: int, running: bool) -> None:
        """At a running frame the target speed; otherwise the PWM's share of the top speed."""
        if running:
            self.command(self.scale.speed_from_ticks(target_ticks_per_frame))
        else:
            self.command(pwm / PWM_MAX * self.parameters.max_speed_rad_s)


class PwmFirstOrderMotor(SimulatedMotor):
    """The first-order lag with the PWM mapped linearly to its target speed."""

    def drive(self, pwm: int, target_ticks_per_frame: int, running: bool) -> None:
        """The PWM's share of the top speed (negative: 0, the model is one-way)."""
        self.command(pwm / PWM_MAX * self.parameters.max_speed_rad_s)


class DcChannelMotor:
    """A :class:`DcMotor` at duty PWM / 255, with an encoder on the motor shaft."""

    def __init__(
        self,
        parameters: DcMotorParameters,
        scale: Scale,
        load: LoadTorque = zero_load,
        load_inertia: LoadInertia = zero_load_inertia,
    ) -> None:
        """At rest, duty 0, turning ``load`` (the DC motor's; none by default)."""
        self.motor = DcMotor(parameters, load, load_inertia)
        self.scale = scale

    @property
    def speed_rad_s(self) -> float:
        """The carrier speed now."""
        return self.motor.speed_rad_s

    @property
    def target_rad_s(self) -> float:
        """The no-load carrier speed at the present duty."""
        return self.motor.duty * self.motor.parameters.no_load_speed_rad_s

    def drive(self, pwm: int, target_ticks_per_frame: int, running: bool) -> None:
        """The armature sees PWM / 255 of the supply."""
        self.motor.set_duty(pwm / PWM_MAX)

    def advance(self, dt_s: float) -> None:
        """Integrate the motor over ``dt_s``."""
        if dt_s > 0.0:
            self.motor.advance(dt_s)

    def encoder_counts(self) -> int:
        """Floor of the motor-shaft count (the carrier angle times ratio and resolution)."""
        return math.floor(self.scale.counts_from_angle(self.motor.angle_rad))


def make_motor(
    kind: str,
    scale: Scale,
    time_constant_s: float,
    max_speed_rad_s: float,
    load: LoadTorque = zero_load,
    load_inertia: LoadInertia = zero_load_inertia,
) -> BoardMotor:
    """One channel's motor of ``kind`` (see :data:`MOTOR_KINDS`) for an encoder of ``scale``.

    ``load`` and ``load_inertia`` are what the ``dc`` motor turns (ignored by the others).

    Raises:
        ValueError: an unknown ``kind``, or a time constant or top speed the lag refuses.
    """
    if kind == "dc":
        # The Pololu 37D's armature and friction behind the gearbox the encoder scale says.
        parameters = dataclasses.replace(DcMotorParameters(), gear_ratio=scale.gear_ratio)
        return DcChannelMotor(parameters, scale, load, load_inertia)
    lag = MotorParameters(
        time_constant_s=time_constant_s,
        max_speed_rad_s=max_speed_rad_s,
        counts_per_revolution=scale.counts_per_revolution,
        gear_ratio=scale.gear_ratio,
    )
    if kind == "ideal":
        return IdealMotor(lag, scale)
    if kind == "first-order":
        return PwmFirstOrderMotor(lag)
    raise ValueError(f"motor must be one of {MOTOR_KINDS}, got {kind!r}")
