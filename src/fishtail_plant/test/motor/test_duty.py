import dataclasses
import math

import numpy as np
import pytest

from fishtail_plant.motor.dc_motor import DcMotorParameters
from fishtail_plant.motor.duty import (
    MotorConstants,
    duty,
    paid_per_speed_squared,
    speed_at_supply,
    torque_at_carrier,
)

MOTOR = DcMotorParameters()


def test_without_load_the_supply_limit_is_the_no_load_speed():
    assert float(speed_at_supply(MotorConstants.of(MOTOR), 0.0)) == pytest.approx(
        MOTOR.no_load_speed_rad_s, rel=1e-12
    )


def test_at_the_supply_limit_the_motor_needs_exactly_the_supply():
    load = np.array([0.002, -0.001, 0.004, 0.0005])  # c(phi) [N m s^2]
    constants = MotorConstants.of(MOTOR)
    paid = paid_per_speed_squared(load, MOTOR.gearbox_efficiency)
    limit = float(speed_at_supply(constants, paid.max()))
    voltage = duty(constants, load, limit).voltage_v
    assert voltage.max() == pytest.approx(MOTOR.supply_voltage_v, rel=1e-12)
    mean_limit = float(speed_at_supply(constants, paid.mean()))
    assert duty(constants, load, mean_limit).voltage_v.mean() == pytest.approx(
        MOTOR.supply_voltage_v, rel=1e-12
    )
    assert mean_limit > limit


def test_gear_ratios_as_an_array_give_each_motor_its_own_figures():
    ratios = np.array([10.0, 30.0, 75.0])
    efficiencies = np.array([0.85, 0.76, 0.7])
    load = np.array([0.003, 0.001, -0.0005])[:, None]
    speeds = np.array([20.0, 8.0, 3.0])
    batch = duty(MotorConstants.of(MOTOR, ratios, efficiencies), load, speeds)
    for index, (ratio, efficiency) in enumerate(zip(ratios, efficiencies, strict=True)):
        one = dataclasses.replace(MOTOR, gear_ratio=ratio, gearbox_efficiency=efficiency)
        single = duty(MotorConstants.of(one), load[:, 0], speeds[index])
        assert np.allclose(batch.current_a[:, index], single.current_a, rtol=1e-14)
        assert np.allclose(batch.voltage_v[:, index], single.voltage_v, rtol=1e-14)
    # By hand, the first sample of the first motor: tau_m = (c / eta) w^2 / N + b N w + tau_c.
    torque = 0.003 / 0.85 * 20.0**2 / 10.0 + MOTOR.viscous_friction_n_m_s * 200.0
    current = (torque + MOTOR.coulomb_friction_n_m) / MOTOR.torque_constant_n_m_a
    assert batch.current_a[0, 0] == pytest.approx(current, rel=1e-14)


def test_the_torque_line_runs_from_the_stall_torque_to_zero_at_the_no_load_speed():
    constants = MotorConstants.of(MOTOR)
    assert float(torque_at_carrier(constants, 0.0)) == pytest.approx(MOTOR.stall_torque_n_m)
    assert float(torque_at_carrier(constants, MOTOR.no_load_speed_rad_s)) == pytest.approx(
        0.0, abs=1e-12
    )
    assert math.isfinite(float(torque_at_carrier(constants, 5.0)))
