"""A simulated one-way DC gear motor with a quadrature encoder on the motor shaft.

The driver's default simulated motor (``motor_model: first_order``): the carrier speed follows
the command with a first-order lag, integrated exactly whatever the step, with an optional
seeded speed disturbance; it feels no load. The model: docs/motor-load.md ("The first-order
model").

>>> motor = SimulatedMotor(MotorParameters(time_constant_s=0.1, counts_per_revolution=1000))
>>> motor.command(4.0)
>>> for _ in range(100):
...     motor.advance(0.01)
>>> round(motor.speed_rad_s, 3), round(motor.measured_angle_rad(), 3)
(4.0, 3.594)
"""

from __future__ import annotations

import dataclasses
import math
import random


@dataclasses.dataclass(frozen=True)
class MotorParameters:
    """Simulated motor and encoder; SI units.

    Raises:
        ValueError: a time constant, top speed or gear ratio not finite and > 0, counts not an
            integer > 0, or a negative noise.
    """

    time_constant_s: float = 0.15
    max_speed_rad_s: float = 20.0
    counts_per_revolution: int = 2048
    gear_ratio: float = 1.0
    speed_noise_rad_s: float = 0.0
    seed: int = 0

    def __post_init__(self) -> None:
        """Reject values that would make the model meaningless, with the reason."""
        checks = (
            (self.time_constant_s > 0.0 and math.isfinite(self.time_constant_s),
             f"time_constant_s must be > 0, got {self.time_constant_s!r}"),
            (self.max_speed_rad_s > 0.0 and math.isfinite(self.max_speed_rad_s),
             f"max_speed_rad_s must be > 0, got {self.max_speed_rad_s!r}"),
            (isinstance(self.counts_per_revolution, int) and self.counts_per_revolution > 0,
             f"counts_per_revolution must be an integer > 0, got {self.counts_per_revolution!r}"),
            (self.gear_ratio > 0.0 and math.isfinite(self.gear_ratio),
             f"gear_ratio must be > 0, got {self.gear_ratio!r}"),
            (self.speed_noise_rad_s >= 0.0 and math.isfinite(self.speed_noise_rad_s),
             f"speed_noise_rad_s must be >= 0, got {self.speed_noise_rad_s!r}"),
        )  # fmt: skip
        for ok, reason in checks:
            if not ok:
                raise ValueError(reason)

    @property
    def carrier_angle_per_count_rad(self) -> float:
        """Resolution of the measured carrier angle."""
        return 2.0 * math.pi / (self.counts_per_revolution * self.gear_ratio)


class SimulatedMotor:
    """State of the simulated motor: the carrier angle (unwrapped) and speed."""

    #: For diagnostics.
    model_name = "first_order"
    #: The first-order model has no torque: the joint state's effort stays empty.
    effort_n_m: float | None = None

    def __init__(self, parameters: MotorParameters) -> None:
        """Start at rest at angle 0."""
        self.parameters = parameters
        self.angle_rad = 0.0
        self.speed_rad_s = 0.0
        self.target_rad_s = 0.0
        self.lagged_speed_rad_s = 0.0  # the first-order response, without the disturbance
        self.disturbance_rad_s = 0.0
        self._random = random.Random(parameters.seed)

    def command(self, speed_rad_s: float) -> None:
        """Set the carrier speed target; clamped to [0, max_speed_rad_s] (the motor is one-way).

        Raises:
            ValueError: a non-finite speed.
        """
        if not math.isfinite(speed_rad_s):
            raise ValueError(f"speed command must be finite, got {speed_rad_s!r}")
        self.target_rad_s = min(max(speed_rad_s, 0.0), self.parameters.max_speed_rad_s)

    def advance(self, dt_s: float) -> None:
        """Move the model on by ``dt_s`` seconds with the current command held constant.

        The lagged speed is integrated exactly; the disturbance (if any) by the trapezoid rule,
        and the angle never moves backwards.
        """
        if not dt_s > 0.0:
            return
        p = self.parameters
        tau = p.time_constant_s
        decay = math.exp(-dt_s / tau)
        offset = self.lagged_speed_rad_s - self.target_rad_s
        step = self.target_rad_s * dt_s + offset * tau * (1.0 - decay)
        self.lagged_speed_rad_s = self.target_rad_s + offset * decay
        if p.speed_noise_rad_s > 0.0:
            before = self.disturbance_rad_s
            spread = p.speed_noise_rad_s * math.sqrt(-math.expm1(-2.0 * dt_s / tau))
            self.disturbance_rad_s = before * decay + spread * self._random.gauss(0.0, 1.0)
            step = max(step + 0.5 * (before + self.disturbance_rad_s) * dt_s, 0.0)
        self.angle_rad += step
        self.speed_rad_s = max(self.lagged_speed_rad_s + self.disturbance_rad_s, 0.0)

    def encoder_counts(self) -> int:
        """Encoder count on the motor shaft (floor, as a counter sees it)."""
        p = self.parameters
        motor_turns = self.angle_rad * p.gear_ratio / (2.0 * math.pi)
        return math.floor(motor_turns * p.counts_per_revolution)

    def measured_angle_rad(self) -> float:
        """The carrier angle as the encoder reports it (quantised)."""
        return self.encoder_counts() * self.parameters.carrier_angle_per_count_rad

    def status_values(self) -> dict[str, str]:
        """Nothing beyond what every simulated motor reports."""
        return {}
