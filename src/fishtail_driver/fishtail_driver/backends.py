"""Motor backends behind one small interface: start, set speed, read the encoder, stop, close.

The node owns the timing and the watchdog; a backend only talks to its motor and says what it
needs of the node (:meth:`MotorBackend.watchdog_refusal`, :meth:`MotorBackend.set_command_hold`,
:attr:`MotorBackend.max_sample_rate_hz`). Here: the interface and the simulated backend, which runs
any :class:`SimMotor` (:mod:`fishtail_plant.motor.first_order`,
:mod:`fishtail_plant.motor.pid_dc_motor`); the board's is :mod:`fishtail_driver.serial_backend`.
No rclpy.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from typing import Protocol

from fishtail_common.interface import Level
from fishtail_kinematics.engine.carrier_profile import CarrierSpeedProfile


@dataclasses.dataclass(frozen=True)
class EncoderSample:
    """Carrier angle (unwrapped, rad) and speed (rad/s) at a monotonic time (s).

    ``effort_n_m`` is the torque on the carrier where a model knows it (None: unknown).
    """

    monotonic_s: float
    angle_rad: float
    velocity_rad_s: float
    effort_n_m: float | None = None


@dataclasses.dataclass(frozen=True)
class StopOutcome:
    """What became of the stop command sent when the backend closed."""

    #: The motor is known to have received it (the board acknowledged it; the sim always).
    confirmed: bool
    #: It left this process (it may still have been lost on the way).
    sent: bool
    #: For the log, e.g. "stop acknowledged by the board" or why it could not be sent.
    detail: str


class MotorBackend(Protocol):
    """What the driver node needs of a motor."""

    name: str
    #: What the motor is, for DiagnosticStatus.hardware_id (the port path for serial).
    hardware_id: str

    @property
    def max_sample_rate_hz(self) -> float:
        """New encoder samples come at most this often (inf: whenever read() is called)."""

    def watchdog_refusal(self, cmd_timeout_sec: float) -> str | None:
        """Why the node's command watchdog may not be set to ``cmd_timeout_sec``, or None."""

    def set_command_hold(self, hold_s: float | None) -> None:
        """Keep a non-zero speed alive only while the last set_speed() is at most this old."""

    def start(self) -> None:
        """Connect; raise an exception naming the cause if the motor cannot be reached."""

    def set_speed(self, speed_rad_s: float) -> None:
        """Command a steady carrier speed (>= 0, already validated by the node)."""

    def set_profile(self, profile: CarrierSpeedProfile, speed_rad_s: float) -> None:
        """Command ``profile``, whose speed at the last angle measured is ``speed_rad_s``.

        Unless :attr:`profile_on_board`, the node calls it again at every sample with the
        profile's speed at the angle measured (it follows the profile on the host).
        """

    @property
    def profile_on_board(self) -> bool:
        """Whether the motor's board follows the profile in force by itself."""

    def read(self) -> EncoderSample | None:
        """The latest encoder sample, or None when none is available right now."""

    def stop(self) -> None:
        """Command the motor to stop (speed 0). Must not raise."""

    def close(self) -> StopOutcome:
        """Stop the motor and release its resources; says whether the stop got through.

        Must not raise; safe to call twice.
        """

    def status(self) -> tuple[int, str, dict[str, str]]:
        """Diagnostic level (0 OK, 1 WARN, 2 ERROR), message and key values."""


class SimMotor(Protocol):
    """A simulated motor with its encoder, as the simulated backend runs it."""

    #: What the model is, for diagnostics ("first_order", "dc").
    model_name: str

    @property
    def target_rad_s(self) -> float:
        """The carrier speed commanded."""

    @property
    def speed_rad_s(self) -> float:
        """The carrier speed now."""

    @property
    def effort_n_m(self) -> float | None:
        """The torque on the carrier now, or None when the model has none."""

    def command(self, speed_rad_s: float) -> None:
        """A new carrier speed command (finite; negative means 0)."""

    def advance(self, dt_s: float) -> None:
        """Move the model on by ``dt_s`` seconds."""

    def encoder_counts(self) -> int:
        """The encoder's count on the motor shaft."""

    def measured_angle_rad(self) -> float:
        """The carrier angle as the encoder reports it."""

    def status_values(self) -> dict[str, str]:
        """Figures of this model for diagnostics, beyond speed, target and counts."""


class SimBackend:
    """A simulated motor, advanced to the wall (monotonic) clock at every read."""

    name = "sim"
    hardware_id = "sim"

    def __init__(self, motor: SimMotor, clock: Callable[[], float] = time.monotonic) -> None:
        """Run ``motor``; ``clock`` is injectable for tests."""
        self.motor = motor
        self._clock = clock
        self._last_s: float | None = None

    #: Every read() advances the model: a new sample each time.
    max_sample_rate_hz = math.inf

    def watchdog_refusal(self, cmd_timeout_sec: float) -> str | None:
        """Any timeout, 0 (no watchdog) included: nothing real moves."""
        return None

    def set_command_hold(self, hold_s: float | None) -> None:
        """Nothing to keep alive: the model holds its command until the next one."""

    def start(self) -> None:
        """Nothing to connect to."""
        self._last_s = self._clock()

    def _advance(self) -> float:
        now = self._clock()
        if self._last_s is not None:
            self.motor.advance(now - self._last_s)
        self._last_s = now
        return now

    def set_speed(self, speed_rad_s: float) -> None:
        """Bring the model up to now, then change its command."""
        self._advance()
        self.motor.command(speed_rad_s)

    def read(self) -> EncoderSample:
        """Quantised angle as the encoder reports it; velocity and effort from the model."""
        now = self._advance()
        motor = self.motor
        return EncoderSample(now, motor.measured_angle_rad(), motor.speed_rad_s, motor.effort_n_m)

    def set_profile(self, profile: CarrierSpeedProfile, speed_rad_s: float) -> None:
        """The model follows the speed the node computes at every sample."""
        self.set_speed(speed_rad_s)

    #: The node follows profiles for the model.
    profile_on_board = False

    def stop(self) -> None:
        """Command zero speed."""
        self.set_speed(0.0)

    def close(self) -> StopOutcome:
        """Stop the model; nothing to release."""
        self.set_speed(0.0)
        return StopOutcome(confirmed=True, sent=True, detail="simulated motor stopped")

    def status(self) -> tuple[int, str, dict[str, str]]:
        """Always OK: the model cannot fail."""
        motor = self.motor
        return (
            Level.OK,
            "simulated motor running",
            {
                "motor_model": motor.model_name,
                "target_speed_rad_s": f"{motor.target_rad_s:.4f}",
                "speed_rad_s": f"{motor.speed_rad_s:.4f}",
                "encoder_counts": str(motor.encoder_counts()),
                **motor.status_values(),
            },
        )
