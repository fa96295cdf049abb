"""The motors on the emulated board's two channels: what the PWM set by its firmware moves.

The emulated firmware (:mod:`fishtail_boards.board_firmware`) runs the board's speed loop
(:class:`fishtail_plant.motor.speed_loop.FirmwareSpeedLoop`) and hands the motor of each channel
what the board's ``setMotorSpeeds()`` writes, whenever it writes it: at every PID frame, at
``m 0 0``, ``o``, the auto-stop and power-on. Three motors (``fishtail-fake-board --motor``):

- ``ideal`` (:class:`IdealMotor`, the default): the first-order speed lag of
  :class:`fishtail_plant.motor.first_order.SimulatedMotor`, commanded at each running frame to the
  loop's *target* (ticks per frame as a speed): the board's PID taken as ideal up to that lag.
  While the loop is stopped it follows the PWM (``o``: PWM / 255 of ``max_speed_rad_s``; 0 after
  ``m 0 0`` and the auto-stop). The motor reaches the commanded speed exactly, without the loop's
  dead band or ripple: what the serial tests that check speeds and angles rely on.
- ``first-order`` (:class:`PwmFirstOrderMotor`): the same lag driven by the PWM at every write.
  A first-order lag has no voltage, so the PWM is mapped to its target as the board sees it: a
  linear, load-free motor whose full duty gives ``max_speed_rad_s``. The loop settles within its
  dead band of the target.
- ``dc`` (:class:`DcChannelMotor`): the DC gear motor of :mod:`fishtail_plant.motor.dc_motor` (the
  Pololu 37D defaults) with the gearbox ratio of the board's encoder scale, at duty PWM / 255,
  unloaded or turning a load (``load``, ``load_inertia``: the tail, ``fishtail-fake-board
  --load``): the speed ripple of the loop's integer arithmetic and of the load, as the simulated
  backend's :class:`fishtail_plant.motor.pid_dc_motor.PidDrivenDcMotor` shows it. The other
  motors feel no load.

The encoder counts on the motor shaft, floored as a counter sees it (the firmware wraps them).
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
