"""The DC motor under the firmware's speed loop, alone and as the sim backend runs it.

The motor is the default Pololu 37D 12 V 30:1 with its 64-count encoder: 1920 counts per carrier
turn, so 4 rad/s is 40.3 ticks per 33 ms frame, sent as 40. With Ki 0 the loop leaves a steady
error of up to 2 ticks per frame (|20 error| < 50: the increment truncates to 0), 5 % at 40 ticks
and 2.5 % at 80.
"""

from __future__ import annotations

import doctest
import math

import pytest

from fishtail_driver.backends import SimBackend
from fishtail_driver.parameters import DRIVER_PARAMETERS, make_backend
from fishtail_plant.motor import pid_dc_motor
from fishtail_plant.motor.board_units import Scale
from fishtail_plant.motor.dc_motor import DcMotor, DcMotorParameters
from fishtail_plant.motor.pid_dc_motor import PidDrivenDcMotor
from fishtail_plant.motor.speed_loop import PidGains

SCALE = Scale(counts_per_revolution=64, gear_ratio=30.0)
DC_VALUES = {"motor_model": "dc", "gear_ratio": 30.0, "encoder_counts_per_revolution": 64}


def drive(load=None) -> PidDrivenDcMotor:
    """The default motor on the board's loop, with a carrier load (torque) if given."""
    motor = DcMotor(DcMotorParameters()) if load is None else DcMotor(DcMotorParameters(), load)
    return PidDrivenDcMotor(motor, SCALE)


def run(subject: PidDrivenDcMotor, settle_s: float, measure_s: float) -> tuple[float, list[float]]:
    """Mean speed over ``measure_s`` after ``settle_s`` (from the angle), and the speeds seen."""
    dt = 0.002
    for _ in range(round(settle_s / dt)):
        subject.advance(dt)
    start = subject.motor.angle_rad
    speeds = []
    for _ in range(round(measure_s / dt)):
        subject.advance(dt)
        speeds.append(subject.speed_rad_s)
    return (subject.motor.angle_rad - start) / measure_s, speeds


def test_doctests():
    result = doctest.testmod(pid_dc_motor)
    assert result.failed == 0 and result.attempted >= 3


@pytest.mark.parametrize("target", [4.0, 8.0, 12.0, 16.0])
def test_the_default_loop_reaches_the_commanded_speed(target):
    subject = drive()
    subject.command(target)
    mean, speeds = run(subject, settle_s=2.0, measure_s=2.0)
    assert mean == pytest.approx(target, rel=0.03)
    assert max(speeds) - min(speeds) < 1e-6  # no load: a steady PWM, a steady speed
    assert 0 < subject.loop.pwm[0] < 255


def test_periodic_load_makes_the_speed_ripple_more_as_it_grows():
    ripples, peak_currents = [], []
    for amplitude in (0.0, 0.05, 0.1, 0.2):
        subject = drive(load=lambda phi, phi_dot, a=amplitude: a * math.sin(2 * phi))
        subject.command(8.0)
        mean, speeds = run(subject, settle_s=2.0, measure_s=2.0)
        currents = []
        for _ in range(500):
            subject.advance(0.002)
            currents.append(subject.motor.outputs().current_a)
        ripples.append(max(speeds) - min(speeds))
        peak_currents.append(max(currents))
        assert mean == pytest.approx(8.0, rel=0.05)
    assert ripples[0] < 1e-6
    assert ripples[1] < ripples[2] < ripples[3]
    assert peak_currents[0] < peak_currents[1] < peak_currents[2] < peak_currents[3]


def test_a_zero_command_is_m_0_0():
    subject = drive()
    subject.command(6.0)
    subject.advance(1.0)
    assert subject.loop.pwm[0] > 0
    subject.command(0.0)
    assert subject.loop.pwm == (0,) and not subject.loop.moving and subject.motor.duty == 0.0
    subject.advance(1.0)  # braked through the armature, then held by friction
    assert subject.speed_rad_s == 0.0
    angle = subject.motor.angle_rad
    subject.advance(0.5)
    assert subject.motor.angle_rad == angle and subject.loop.pwm == (0,)


def test_the_pwm_changes_only_at_frames():
    subject = drive()
    subject.command(4.0)
    assert subject.loop.pwm == (0,)  # the target is taken at the next frame
    subject.advance(0.0339)
    assert subject.loop.pwm == (0,)
    subject.advance(0.0002)  # past 34 ms (a millisecond after the 33 ms grid): 20 * 40 / 50 = 16
    assert subject.loop.pwm == (16,) and subject.motor.duty == 16 / 255


def test_encoder_counts_follow_the_carrier_angle():
    subject = drive()
    subject.motor.angle_rad = 2 * math.pi * 1.5 + 1e-9
    assert subject.encoder_counts() == 2880  # 1.5 carrier turns * 1920
    assert subject.measured_angle_rad() == pytest.approx(3 * math.pi)
    subject.motor.angle_rad = -1e-9
    assert subject.encoder_counts() == -1  # floor


class FakeClock:
    """A monotonic clock the test moves by hand."""

    def __init__(self) -> None:
        """Start at an arbitrary time."""
        self.now = 50.0

    def __call__(self) -> float:
        """The current time."""
        return self.now


def defaults(**changes) -> dict:
    """Every driver parameter at its default, with ``changes``."""
    return {**{spec.name: spec.default for spec in DRIVER_PARAMETERS}, **changes}


def test_the_sim_backend_runs_the_dc_motor_with_an_injected_load():
    made = make_backend(
        defaults(**DC_VALUES), load=lambda phi, phi_dot: 0.2, load_inertia=lambda phi: 1e-3
    )
    assert isinstance(made, SimBackend)
    clock = FakeClock()
    backend = SimBackend(made.motor, clock)
    backend.start()
    backend.set_speed(6.0)
    for _ in range(1000):
        clock.now += 0.003
        sample = backend.read()
    assert sample.velocity_rad_s == pytest.approx(6.0, rel=0.05)
    assert sample.effort_n_m == pytest.approx(0.2, rel=1e-6)  # steady: the load's torque
    level, _, values = backend.status()
    assert level == 0 and values["motor_model"] == "dc"
    assert float(values["current_a"]) > 0.0 and float(values["supply_power_w"]) > 0.0
    # Steady: the carrier takes 0.2 N m at ~6 rad/s; the supply pays that over η, and R I².
    carrier_power = float(values["mechanical_power_w"])
    assert carrier_power == pytest.approx(0.2 * 6.0, rel=0.05)
    assert float(values["supply_power_w"]) > carrier_power / DcMotorParameters().gearbox_efficiency
    backend.stop()
    assert backend.status()[2]["pwm"] == "0"


def test_the_first_order_model_stays_the_default():
    backend = make_backend(defaults())
    assert backend.status()[2]["motor_model"] == "first_order"
    assert backend.read().effort_n_m is None


@pytest.mark.parametrize(
    ("changes", "reason"),
    [({"gearbox_efficiency": 1.5}, r"gearbox_efficiency must be in \(0, 1\]"),
     ({"motor_resistance_ohm": -2.0}, "resistance_ohm must be finite and > 0"),
     ({"pid_ko": 0}, "ko must not be 0")],
)  # fmt: skip
def test_the_dc_backend_refuses_bad_values_with_reasons(changes, reason):
    with pytest.raises(ValueError, match=reason):
        make_backend(defaults(**DC_VALUES, **changes))


@pytest.mark.parametrize(
    "changes",
    [{"encoder_counts_per_revolution": 2048, "gear_ratio": 1.0},  # the first-order's defaults
     {"encoder_counts_per_revolution": 2048},  # a fine encoder on the default gains
     {"pid_kp": 200, "pid_kd": 120}],
)  # fmt: skip
def test_a_speed_loop_that_rings_is_refused_with_its_reason(changes):
    # Measured: with these the carrier swings between full forward and full reverse.
    with pytest.raises(ValueError, match="speed loop is unstable: .* turns the carrier backwards"):
        make_backend(defaults(**{**DC_VALUES, **changes}))


def test_the_default_gear_motor_passes_the_start_up_check():
    drive = make_backend(defaults(**DC_VALUES)).motor
    fresh = DcMotor(drive.motor.parameters)
    assert pid_dc_motor.unstable_speed_loop(fresh, drive.scale, PidGains(), 20.0) is None
