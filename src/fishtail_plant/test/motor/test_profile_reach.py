"""The duty a carrier speed profile asks of the DC motor (fishtail_plant.motor.profile_reach)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fishtail_plant.motor.dc_motor import DcMotor, DcMotorParameters
from fishtail_plant.motor.profile_reach import deepest_depth, fastest_mean, profile_duty
from fishtail_plant.values import tail_load_from_files

MOTOR = DcMotorParameters()
PHASES = [2.0 * math.pi * i / 8 for i in range(8)]


@pytest.fixture(scope="module")
def water():
    return tail_load_from_files("water_swimming")


def test_the_duty_drives_the_motor_model_along_the_profile(water):
    """Played back to DcMotor at each angle it reaches, the duty keeps it on the law."""
    omega, depth, phase = 2.0 * math.pi, 0.5, 1.0
    duty = profile_duty(MOTOR, omega, depth, phase, water.torque, water.inertia, samples=3600)
    scale = omega / math.sqrt(1.0 - depth**2)
    motor = DcMotor(
        MOTOR, water.torque, water.inertia, 0.0, scale * (1.0 + depth * math.cos(-phase))
    )
    worst = 0.0
    for _ in range(4000):  # about two revolutions in 0.5 ms steps
        index = int(motor.angle_rad % (2.0 * math.pi) / (2.0 * math.pi) * 3600) % 3600
        motor.set_duty(float(np.clip(duty[index], -1.0, 1.0)))
        motor.advance(5e-4)
        law = scale * (1.0 + depth * math.cos(motor.angle_rad - phase))
        worst = max(worst, abs(motor.speed_rad_s - law) / law)
    assert worst < 0.02


def test_3_75_hz_in_water_is_beyond_the_default_motor_at_every_depth_and_phase(water):
    """Not even the flat profile: the mean itself asks more than PWM 255 gives."""
    omega = 3.75 * 2.0 * math.pi
    for phase in PHASES:
        assert deepest_depth(MOTOR, omega, phase, water.torque, water.inertia) is None
    # Depth 0.5 at 3.75 Hz asks a peak above the no-load speed: beyond it even unloaded.
    assert omega * math.sqrt(3.0) > MOTOR.no_load_speed_rad_s
    assert deepest_depth(MOTOR, omega, 0.0) < 0.5


def test_depth_0_5_in_water_is_within_reach_only_at_slow_beats(water):
    """Within PWM 255 at every phase up to about 1.35 Hz; never as fast as 2 Hz."""
    fastest = [fastest_mean(MOTOR, 0.5, phase, water.torque, water.inertia) for phase in PHASES]
    assert 1.2 < min(fastest) / (2.0 * math.pi) < 1.5
    assert max(fastest) / (2.0 * math.pi) < 2.0
