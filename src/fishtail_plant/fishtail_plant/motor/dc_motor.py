r"""A brushed DC gear motor turning the carrier through a gearbox, against a load.

What a real motor does under the tail's load, for the driver's simulated backend
(``motor_model: dc``), the emulated board and the motor sizing: armature current, gearbox
losses both ways, stiction, integrated by RK4 on the carrier angle and speed. The load is two
callables of the carrier's state, :data:`LoadTorque` and :data:`LoadInertia`.
Equations, symbols, assumptions and the default motor: docs/motor-load.md ("The DC motor model").

>>> motor = DcMotor(DcMotorParameters.from_stall_and_no_load(
...     supply_voltage_v=12.0, stall_torque_n_m=1.2, no_load_speed_rad_s=30.0, gear_ratio=30.0))
>>> motor.set_duty(1.0)
>>> motor.advance(2.0)
>>> round(motor.speed_rad_s, 6)   # no friction, no load: the no-load speed
30.0
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

#: ``load(φ [rad], ω [rad/s]) -> torque [N m]`` at the carrier, apart from the load's inertia.
LoadTorque = Callable[[float, float], float]
#: ``load_inertia(φ [rad]) -> inertia [kg m²]`` of the load reduced to the carrier, >= 0.
LoadInertia = Callable[[float], float]


def zero_load(phi_rad: float, phi_dot_rad_s: float) -> float:
    """No load torque."""
    return 0.0


def zero_load_inertia(phi_rad: float) -> float:
    """No load inertia."""
    return 0.0


def _finite(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


@dataclasses.dataclass(frozen=True)
class DcMotorParameters:
    """The motor, its gearbox and its supply; SI units, friction and inertia at the motor shaft.

    The defaults are a Pololu 37D 12 V 30:1 gearmotor; docs/motor-load.md derives each value
    from its datasheet.

    Raises:
        ValueError: a value that is not finite, not positive (friction: negative), or an
            efficiency outside (0, 1].
    """

    resistance_ohm: float = 2.18
    torque_constant_n_m_a: float = 0.01115
    supply_voltage_v: float = 12.0
    gear_ratio: float = 30.0
    gearbox_efficiency: float = 0.76
    rotor_inertia_kg_m2: float = 3.0e-6
    viscous_friction_n_m_s: float = 1.1e-6
    coulomb_friction_n_m: float = 1.1e-3
    max_step_s: float = 1.0e-3

    def __post_init__(self) -> None:
        """Refuse values that make the model meaningless, with the reason."""
        positive = ("resistance_ohm", "torque_constant_n_m_a", "supply_voltage_v", "gear_ratio",
                    "rotor_inertia_kg_m2", "max_step_s")  # fmt: skip
        for name in positive:
            value = getattr(self, name)
            if not (_finite(value) and value > 0.0):
                raise ValueError(f"{name} must be finite and > 0, got {value!r}")
        for name in ("viscous_friction_n_m_s", "coulomb_friction_n_m"):
            value = getattr(self, name)
            if not (_finite(value) and value >= 0.0):
                raise ValueError(f"{name} must be finite and >= 0, got {value!r}")
        eta = self.gearbox_efficiency
        if not (_finite(eta) and 0.0 < eta <= 1.0):
            raise ValueError(f"gearbox_efficiency must be in (0, 1], got {eta!r}")

    @classmethod
    def from_stall_and_no_load(
        cls,
        *,
        supply_voltage_v: float,
        stall_torque_n_m: float,
        no_load_speed_rad_s: float,
        gear_ratio: float = 1.0,
        gearbox_efficiency: float = 1.0,
        **others: float,
    ) -> DcMotorParameters:
        """A motor with this stall torque and no-load speed at the carrier at V, frictionless.

        At the motor shaft the no-load speed is ω₀ = N Ω₀ and the stall torque τ_s / (N η), so
        k = V / ω₀ and R = k V / (τ_s / (N η)). ``others`` are further fields (inertia, friction,
        step); friction given there lowers the no-load speed and the stall torque below these.

        Raises:
            ValueError: a figure that is not finite and positive, or a field the class refuses.
        """
        for name, value in (("stall_torque_n_m", stall_torque_n_m),
                            ("no_load_speed_rad_s", no_load_speed_rad_s)):  # fmt: skip
            if not (_finite(value) and value > 0.0):
                raise ValueError(f"{name} must be finite and > 0, got {value!r}")
        others = {"viscous_friction_n_m_s": 0.0, "coulomb_friction_n_m": 0.0, **others}
        # The parameters' own checks run on a first build, before the derived values divide.
        cls(supply_voltage_v=supply_voltage_v, gear_ratio=gear_ratio,
            gearbox_efficiency=gearbox_efficiency, **others)  # fmt: skip
        torque_constant = supply_voltage_v / (gear_ratio * no_load_speed_rad_s)
        motor_stall_torque = stall_torque_n_m / (gear_ratio * gearbox_efficiency)
        return cls(
            resistance_ohm=torque_constant * supply_voltage_v / motor_stall_torque,
            torque_constant_n_m_a=torque_constant,
            supply_voltage_v=supply_voltage_v,
            gear_ratio=gear_ratio,
            gearbox_efficiency=gearbox_efficiency,
            **others,
        )

    @property
    def stall_current_a(self) -> float:
        """Current at full voltage with the motor held still: V / R."""
        return self.supply_voltage_v / self.resistance_ohm

    @property
    def stall_torque_n_m(self) -> float:
        """Torque at the carrier at full voltage, held still: η N (k V / R − τ_c), at least 0."""
        motor = self.torque_constant_n_m_a * self.stall_current_a - self.coulomb_friction_n_m
        return max(motor, 0.0) * self.gear_ratio * self.gearbox_efficiency

    @property
    def no_load_speed_rad_s(self) -> float:
        """Carrier speed at full voltage and no load: (k V/R − τ_c) / (k²/R + b) / N, at least 0."""
        k, r = self.torque_constant_n_m_a, self.resistance_ohm
        drive = k * self.supply_voltage_v / r - self.coulomb_friction_n_m
        return max(drive, 0.0) / (k * k / r + self.viscous_friction_n_m_s) / self.gear_ratio

    @property
    def mechanical_time_constant_s(self) -> float:
        """J_m / (k²/R + b): the unloaded motor's speed time constant."""
        k = self.torque_constant_n_m_a
        damping = k * k / self.resistance_ohm + self.viscous_friction_n_m_s
        return self.rotor_inertia_kg_m2 / damping

    @property
    def step_s(self) -> float:
        """The longest internal integration step."""
        return min(self.max_step_s, 0.1 * self.mechanical_time_constant_s)


@dataclasses.dataclass(frozen=True)
class DcMotorOutputs:
    """What the motor does at one instant (the state and duty of that instant)."""

    current_a: float
    #: Power drawn from the supply, d·V·I (negative: fed back).
    supply_power_w: float
    #: Power the gearbox delivers to the carrier, τ_out·ω.
    mechanical_power_w: float
    #: Torque of the gearbox on the carrier, τ_out.
    carrier_torque_n_m: float
    carrier_acceleration_rad_s2: float


class DcMotor:
    """The motor's state (carrier angle and speed, stuck or not) and its equation of motion."""

    def __init__(
        self,
        parameters: DcMotorParameters,
        load: LoadTorque = zero_load,
        load_inertia: LoadInertia = zero_load_inertia,
        angle_rad: float = 0.0,
        speed_rad_s: float = 0.0,
    ) -> None:
        """At ``angle_rad`` and ``speed_rad_s`` with duty 0; at rest if the speed is 0.

        Raises:
            ValueError: a non-finite angle or speed.
        """
        if not (_finite(angle_rad) and _finite(speed_rad_s)):
            raise ValueError(f"angle and speed must be finite, got {angle_rad!r}, {speed_rad_s!r}")
        self.parameters = parameters
        self.load = load
        self.load_inertia = load_inertia
        self.angle_rad = float(angle_rad)
        self.speed_rad_s = float(speed_rad_s)
        self.duty = 0.0
        p = parameters
        self._n = p.gear_ratio
        self._k = p.torque_constant_n_m_a
        self._reflected_rotor = p.rotor_inertia_kg_m2 * p.gear_ratio**2
        self._viscous = p.viscous_friction_n_m_s * p.gear_ratio**2  # at the carrier
        self._coulomb = p.coulomb_friction_n_m * p.gear_ratio  # at the carrier

    def set_duty(self, duty: float) -> None:
        """The PWM duty from now on, in [-1, 1] (armature voltage duty · V).

        Raises:
            ValueError: a duty outside [-1, 1] or not finite.
        """
        if not (_finite(duty) and -1.0 <= duty <= 1.0):
            raise ValueError(f"duty must be in [-1, 1], got {duty!r}")
        self.duty = float(duty)

    # --- the equation of motion ----------------------------------------------------------------
    def current_at(self, speed_rad_s: float) -> float:
        """Armature current at this carrier speed and the present duty."""
        p = self.parameters
        back_emf = self._k * self._n * speed_rad_s
        return (self.duty * p.supply_voltage_v - back_emf) / p.resistance_ohm

    def _inertia(self, angle_rad: float) -> float:
        inertia = float(self.load_inertia(angle_rad))
        if not (math.isfinite(inertia) and inertia >= 0.0):
            raise ValueError(f"load_inertia({angle_rad!r}) = {inertia!r}: must be finite and >= 0")
        return inertia

    def _load(self, angle_rad: float, speed_rad_s: float) -> float:
        torque = float(self.load(angle_rad, speed_rad_s))
        if not math.isfinite(torque):
            raise ValueError(f"load({angle_rad!r}, {speed_rad_s!r}) = {torque!r}: not finite")
        return torque

    def _acceleration(self, angle_rad: float, speed_rad_s: float, direction: float) -> float:
        """φ̈ moving in ``direction`` (+1 or -1), with the gearbox mode that is consistent."""
        drive = (self._n * self._k * self.current_at(speed_rad_s) - self._viscous * speed_rad_s
                 - self._coulomb * direction)  # fmt: skip
        load = self._load(angle_rad, speed_rad_s)
        inertia = self._inertia(angle_rad)
        eta = self.parameters.gearbox_efficiency
        motoring = (drive - load / eta) / (self._reflected_rotor + inertia / eta)
        if (inertia * motoring + load) * direction >= 0.0:
            return motoring
        return (drive - eta * load) / (self._reflected_rotor + eta * inertia)

    def _breakaway(self, angle_rad: float) -> float:
        """At rest: +1 or -1 if the motor starts moving that way, 0 if it stays stuck."""
        if self._acceleration(angle_rad, 0.0, 1.0) > 0.0:
            return 1.0
        if self._acceleration(angle_rad, 0.0, -1.0) < 0.0:
            return -1.0
        return 0.0

    def _rk4(self, angle: float, speed: float, h: float, direction: float) -> tuple[float, float]:
        accel = self._acceleration
        a1 = accel(angle, speed, direction)
        s2 = speed + 0.5 * h * a1
        a2 = accel(angle + 0.5 * h * speed, s2, direction)
        s3 = speed + 0.5 * h * a2
        a3 = accel(angle + 0.5 * h * s2, s3, direction)
        s4 = speed + h * a3
        a4 = accel(angle + h * s3, s4, direction)
        new_angle = angle + h / 6.0 * (speed + 2.0 * s2 + 2.0 * s3 + s4)
        new_speed = speed + h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
        return new_angle, new_speed

    def _step(self, h: float) -> None:
        speed = self.speed_rad_s
        direction = math.copysign(1.0, speed) if speed != 0.0 else self._breakaway(self.angle_rad)
        if direction == 0.0:
            return  # stuck: the torques on it are within the breakaway friction
        angle, new_speed = self._rk4(self.angle_rad, speed, h, direction)
        if new_speed * direction > 0.0:
            self.angle_rad, self.speed_rad_s = angle, new_speed
            return
        # ω reached 0 within the step: integrate up to the crossing and stick there.
        fraction = speed / (speed - new_speed) if speed != 0.0 else 0.0
        if fraction > 0.0:
            self.angle_rad, _ = self._rk4(self.angle_rad, speed, fraction * h, direction)
        self.speed_rad_s = 0.0

    def advance(self, dt_s: float) -> None:
        """Move on by ``dt_s`` seconds with the present duty, in equal steps of at most step_s.

        Raises:
            ValueError: the load's torque or inertia came out non-finite (or the inertia < 0).
        """
        if not dt_s > 0.0:
            return
        steps = max(1, math.ceil(dt_s / self.parameters.step_s - 1e-9))
        h = dt_s / steps
        for _ in range(steps):
            self._step(h)

    # --- outputs -------------------------------------------------------------------------------
    def outputs(self) -> DcMotorOutputs:
        """Current, powers, carrier torque and acceleration at the present state and duty.

        Raises:
            ValueError: the load's torque or inertia came out non-finite (or the inertia < 0).
        """
        angle, speed = self.angle_rad, self.speed_rad_s
        if speed != 0.0:
            acceleration = self._acceleration(angle, speed, math.copysign(1.0, speed))
        else:
            direction = self._breakaway(angle)
            acceleration = 0.0 if direction == 0.0 else self._acceleration(angle, 0.0, direction)
        torque = self._inertia(angle) * acceleration + self._load(angle, speed)
        current = self.current_at(speed)
        return DcMotorOutputs(
            current_a=current,
            supply_power_w=self.duty * self.parameters.supply_voltage_v * current,
            mechanical_power_w=torque * speed,
            carrier_torque_n_m=torque,
            carrier_acceleration_rad_s2=acceleration,
        )
