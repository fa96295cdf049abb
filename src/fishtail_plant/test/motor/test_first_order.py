"""The simulated motor against the closed-form first-order response, and the sim backend."""

from __future__ import annotations

import math

import pytest

from fishtail_driver.backends import SimBackend
from fishtail_plant.motor.first_order import MotorParameters, SimulatedMotor


def test_first_order_step_response_is_exact():
    tau, target = 0.2, 5.0
    motor = SimulatedMotor(MotorParameters(time_constant_s=tau))
    motor.command(target)
    motor.advance(0.37)
    assert motor.speed_rad_s == pytest.approx(target * (1 - math.exp(-0.37 / tau)), abs=1e-12)
    expected_angle = target * (0.37 - tau * (1 - math.exp(-0.37 / tau)))
    assert motor.angle_rad == pytest.approx(expected_angle, abs=1e-12)


def test_result_does_not_depend_on_step_size():
    one_step = SimulatedMotor(MotorParameters())
    many_steps = SimulatedMotor(MotorParameters())
    for motor in (one_step, many_steps):
        motor.command(3.0)
    one_step.advance(1.0)
    for _ in range(1000):
        many_steps.advance(0.001)
    assert many_steps.angle_rad == pytest.approx(one_step.angle_rad, abs=1e-9)
    assert many_steps.speed_rad_s == pytest.approx(one_step.speed_rad_s, abs=1e-9)


def test_commands_are_clamped_to_the_one_way_speed_range():
    motor = SimulatedMotor(MotorParameters(max_speed_rad_s=6.0))
    motor.command(-2.0)
    assert motor.target_rad_s == 0.0
    motor.command(60.0)
    assert motor.target_rad_s == 6.0
    with pytest.raises(ValueError, match="finite"):
        motor.command(math.nan)


def test_encoder_quantises_to_one_count_of_the_carrier():
    parameters = MotorParameters(counts_per_revolution=500, gear_ratio=30.0)
    motor = SimulatedMotor(parameters)
    motor.command(2.0)
    resolution = 2 * math.pi / (500 * 30.0)
    assert parameters.carrier_angle_per_count_rad == pytest.approx(resolution)
    for _ in range(200):
        motor.advance(0.013)
        error = motor.angle_rad - motor.measured_angle_rad()
        assert 0.0 <= error < resolution + 1e-15
        counts = motor.measured_angle_rad() / resolution
        assert counts == pytest.approx(round(counts), abs=1e-6)


def test_noise_is_seeded_and_never_reverses_the_motor():
    def run(seed: int) -> list[float]:
        motor = SimulatedMotor(MotorParameters(speed_noise_rad_s=1.0, seed=seed))
        motor.command(0.5)
        speeds = []
        for _ in range(300):
            motor.advance(0.005)
            speeds.append(motor.speed_rad_s)
        return speeds

    assert run(3) == run(3)
    assert run(3) != run(4)
    assert min(run(3)) >= 0.0


def steady_speed_statistics(dt_s: float, duration_s: float) -> tuple[float, float]:
    """Mean and standard deviation of the speed at a constant command, after the transient."""
    tau, sigma, target = 0.01, 0.5, 10.0
    motor = SimulatedMotor(
        MotorParameters(time_constant_s=tau, speed_noise_rad_s=sigma, max_speed_rad_s=50.0, seed=7)
    )
    motor.command(target)
    for _ in range(round(10 * tau / dt_s) + 1):  # settle: the lag and the disturbance
        motor.advance(dt_s)
    speeds = []
    for _ in range(round(duration_s / dt_s)):
        motor.advance(dt_s)
        speeds.append(motor.speed_rad_s)
    mean = math.fsum(speeds) / len(speeds)
    std = math.sqrt(math.fsum((v - mean) ** 2 for v in speeds) / (len(speeds) - 1))
    return mean, std


def test_noise_std_is_the_parameter_whatever_the_step():
    """The disturbance is stationary: std = speed_noise_rad_s at 0.05 tau and at 5 tau steps.

    Statistical, not timed (a fixed seed makes it deterministic). About 1000 correlation times
    per run give the sample std a relative standard error near 2-3 %; a full-size kick at every
    step (the old model) gave 3.2 sigma at the fine step and 1.0 sigma at the coarse one.
    """
    fine_mean, fine_std = steady_speed_statistics(dt_s=0.0005, duration_s=20.0)
    coarse_mean, coarse_std = steady_speed_statistics(dt_s=0.05, duration_s=100.0)
    assert fine_std == pytest.approx(0.5, rel=0.12)
    assert coarse_std == pytest.approx(0.5, rel=0.12)
    assert fine_std == pytest.approx(coarse_std, rel=0.15)
    assert fine_mean == pytest.approx(10.0, abs=0.1)
    assert coarse_mean == pytest.approx(10.0, abs=0.1)


def test_noise_is_correlated_over_the_time_constant():
    """Consecutive speeds a small fraction of tau apart are nearly equal (no white kicks)."""
    motor = SimulatedMotor(MotorParameters(time_constant_s=0.1, speed_noise_rad_s=1.0, seed=2))
    motor.command(10.0)
    for _ in range(2000):
        motor.advance(0.001)
    steps = []
    for _ in range(2000):
        before = motor.speed_rad_s
        motor.advance(0.001)
        steps.append(motor.speed_rad_s - before)
    # OU increments over dt have std sigma * sqrt(2 dt / tau) = 0.14 sigma for dt = tau / 100.
    rms = math.sqrt(math.fsum(step * step for step in steps) / len(steps))
    assert rms == pytest.approx(math.sqrt(2 * 0.001 / 0.1), rel=0.15)


@pytest.mark.parametrize(
    ("field", "value"),
    [("time_constant_s", 0.0), ("max_speed_rad_s", -1.0), ("counts_per_revolution", 0),
     ("counts_per_revolution", 2.5), ("gear_ratio", math.inf), ("speed_noise_rad_s", -0.1)],
)  # fmt: skip
def test_parameters_refuse_meaningless_values(field, value):
    with pytest.raises(ValueError, match=field):
        MotorParameters(**{field: value})


class FakeClock:
    """A monotonic clock the test moves by hand."""

    def __init__(self) -> None:
        """Start at an arbitrary non-zero time."""
        self.now = 100.0

    def __call__(self) -> float:
        """The current time."""
        return self.now


def test_sim_backend_advances_with_its_clock_and_stops():
    clock = FakeClock()
    motor = SimulatedMotor(MotorParameters(time_constant_s=0.1, counts_per_revolution=4096))
    backend = SimBackend(motor, clock)
    backend.start()
    backend.set_speed(4.0)
    clock.now += 2.0
    sample = backend.read()
    assert sample.monotonic_s == 102.0
    assert sample.velocity_rad_s == pytest.approx(4.0, abs=1e-6)
    assert sample.angle_rad == pytest.approx(4.0 * (2.0 - 0.1), abs=2 * math.pi / 4096)
    backend.stop()
    clock.now += 1.0
    stopped = backend.read()
    assert stopped.velocity_rad_s == pytest.approx(0.0, abs=1e-3)
    assert stopped.effort_n_m is None  # the first-order model has no torque
    level, _, values = backend.status()
    assert level == 0 and values["target_speed_rad_s"] == "0.0000"
    assert values["motor_model"] == "first_order"
