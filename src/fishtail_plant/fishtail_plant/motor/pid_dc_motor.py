"""The DC gear motor on one channel of the motor board, under the firmware's speed loop.

What the simulated backend runs with ``motor_model: dc``: a speed command reaches
:class:`~fishtail_plant.motor.speed_loop.FirmwareSpeedLoop` as the serial backend's ``m`` would
(:meth:`~fishtail_plant.motor.board_units.Scale.ticks_per_frame`), and between PID frames the
:mod:`~fishtail_plant.motor.dc_motor` runs at the duty the loop set. It has the interface of
:class:`~fishtail_plant.motor.first_order.SimulatedMotor` (the driver's ``SimMotor``), plus the
carrier torque as the effort and the current and powers in its status.
How the backend uses it: docs/motor-load.md ("In the simulated backend").

>>> from fishtail_plant.motor.dc_motor import DcMotor, DcMotorParameters
>>> drive = PidDrivenDcMotor(DcMotor(DcMotorParameters()), Scale(64, 30.0))
>>> drive.command(4.0)
>>> drive.loop.set_points[0].target_ticks_per_frame   # 4 rad/s * 1920 / 2 pi * 0.033 s = 40.3
40
"""

from __future__ import annotations

import math

from fishtail_plant.motor.board_units import PWM_MAX, Scale
from fishtail_plant.motor.dc_motor import DcMotor
from fishtail_plant.motor.speed_loop import FirmwareSpeedLoop, FrameTimer, PidGains


class PidDrivenDcMotor:
    """A :class:`DcMotor` with its encoder, driven by the firmware's speed loop on a frame grid."""

    #: For diagnostics.
    model_name = "dc"

    def __init__(self, motor: DcMotor, scale: Scale, gains: PidGains | None = None) -> None:
        """At the motor's present state; the loop powered on (stopped, PWM 0) at time 0."""
        self.motor = motor
        self.scale = scale
        self.loop = FirmwareSpeedLoop((self.encoder_counts(),), gains)
        self.timer = FrameTimer(scale.frame_ms, start_s=0.0)
        self.time_s = 0.0
        self.target_rad_s = 0.0
        self._apply_pwm()

    def _apply_pwm(self) -> None:
        self.motor.set_duty(self.loop.pwm[0] / PWM_MAX)

    def command(self, speed_rad_s: float) -> None:
        """A carrier speed target (negative: 0, the motor is one-way), sent as ``m ticks``.

        Raises:
            ValueError: a non-finite speed.
        """
        if not math.isfinite(speed_rad_s):
            raise ValueError(f"speed command must be finite, got {speed_rad_s!r}")
        self.target_rad_s = max(speed_rad_s, 0.0)
        ticks, _ = self.scale.ticks_per_frame(self.target_rad_s)
        self.loop.command((ticks,), (self.encoder_counts(),))
        self._apply_pwm()

    def advance(self, dt_s: float) -> None:
        """Move on by ``dt_s`` seconds, running the PID frames that fall within it."""
        if not dt_s > 0.0:
            return
        end_s = self.time_s + dt_s
        for frame_s in self.timer.due(end_s):
            self.motor.advance(frame_s - self.time_s)
            self.time_s = frame_s
            self.loop.frame((self.encoder_counts(),))
            self._apply_pwm()
        self.motor.advance(end_s - self.time_s)
        self.time_s = end_s

    @property
    def speed_rad_s(self) -> float:
        """The carrier speed (the model's, not estimated from counts)."""
        return self.motor.speed_rad_s

    def encoder_counts(self) -> int:
        """Encoder count on the motor shaft (floor, as a counter sees it; not wrapped)."""
        return math.floor(self.scale.counts_from_angle(self.motor.angle_rad))

    def measured_angle_rad(self) -> float:
        """The carrier angle as the encoder reports it (quantised)."""
        return self.scale.angle_from_counts(self.encoder_counts())

    @property
    def effort_n_m(self) -> float:
        """Torque of the gearbox on the carrier."""
        return self.motor.outputs().carrier_torque_n_m

    def status_values(self) -> dict[str, str]:
        """The motor's electrical and mechanical figures and the loop's state."""
        outputs = self.motor.outputs()
        point = self.loop.set_points[0]
        return {
            "current_a": f"{outputs.current_a:.4f}",
            "supply_power_w": f"{outputs.supply_power_w:.4f}",
            "mechanical_power_w": f"{outputs.mechanical_power_w:.4f}",
            "carrier_torque_n_m": f"{outputs.carrier_torque_n_m:.5f}",
            "pwm": str(self.loop.pwm[0]),
            "target_ticks_per_frame": str(point.target_ticks_per_frame),
            "pid_running": str(self.loop.moving).lower(),
        }


#: The step the start-up check commands, as a share of the top speed, and how long it watches.
_CHECK_SHARE = 0.25
_CHECK_SECONDS = 2.0


def unstable_speed_loop(
    motor: DcMotor, scale: Scale, gains: PidGains, top_speed_rad_s: float
) -> str | None:
    """Why the firmware's loop cannot hold this unloaded motor steady, or None if it can.

    The firmware's gains are PWM counts per encoder tick, so the same gains that hold a motor
    with a 64-count encoder make one with 2048 counts ring from full forward to full reverse.
    A real board would do the same; the simulated one is checked at start-up, so that a wrong
    encoder or gain does not give numbers that look like a motor: a step to a quarter of the top
    speed, watched for two seconds, must never turn the carrier backwards.
    """
    drive = PidDrivenDcMotor(motor, scale, gains)
    drive.command(_CHECK_SHARE * top_speed_rad_s)
    slowest = math.inf
    for _ in range(int(_CHECK_SECONDS * 1000)):
        drive.advance(1e-3)
        slowest = min(slowest, drive.speed_rad_s)
    if slowest >= 0.0:
        return None
    return (
        f"the simulated DC motor's speed loop is unstable: stepped to "
        f"{_CHECK_SHARE * top_speed_rad_s:g} rad/s it turns the carrier backwards (at "
        f"{slowest:.3g} rad/s) with encoder_counts_per_revolution {scale.counts_per_revolution} "
        f"and gear_ratio {scale.gear_ratio:g} under pid_kp {gains.kp}, pid_kd {gains.kd}; the "
        "default gear motor is gear_ratio:=30.0 encoder_counts_per_revolution:=64 (what "
        "fishtail-run --motor dc and the launch file's motor_model:=dc set), or lower the gains"
    )
