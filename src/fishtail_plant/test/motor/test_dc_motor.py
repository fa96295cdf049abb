"""The DC gear motor against hand-derived steady states, stall, stiction and the energy balance.

Notation of the DC motor model: carrier speed ω, gear ratio N, the motor turns at
N ω; friction and inertia at the motor shaft; a constant carrier load T needs T/η from the motor
while the motor drives it and gives back η T while it drives the motor.
"""

from __future__ import annotations

import math

import pytest

from fishtail_plant.motor.dc_motor import DcMotor, DcMotorParameters

P = DcMotorParameters()  # the Pololu 37D 30:1 defaults
N, K, R, V = P.gear_ratio, P.torque_constant_n_m_a, P.resistance_ohm, P.supply_voltage_v
B, TC, ETA = P.viscous_friction_n_m_s, P.coulomb_friction_n_m, P.gearbox_efficiency


def constant(torque: float):
    """A load of constant torque at the carrier."""
    return lambda phi, phi_dot: torque


def test_steady_speed_driving_a_constant_load():
    # N k I - b N² ω - N τ_c - T/η = 0 with I = (V - k N ω)/R
    torque = 0.5
    expected = (N * K * V / R - N * TC - torque / ETA) / (N**2 * (K**2 / R + B))
    motor = DcMotor(P, load=constant(torque))
    motor.set_duty(1.0)
    motor.advance(1.5)
    assert motor.speed_rad_s == pytest.approx(expected, rel=1e-9)
    outputs = motor.outputs()
    assert outputs.carrier_torque_n_m == pytest.approx(torque, rel=1e-9)
    assert outputs.mechanical_power_w == pytest.approx(torque * expected, rel=1e-9)


def test_steady_speed_when_the_load_drives_the_motor_back():
    # Duty 0 (armature shorted), the load pulls forward with 0.5 N m: the motor gets η T.
    # N k I - b N² ω - N τ_c + η T = 0 with I = -k N ω / R
    pull = 0.5
    expected = (ETA * pull - N * TC) / (N**2 * (K**2 / R + B))
    motor = DcMotor(P, load=constant(-pull))
    motor.advance(1.5)
    assert motor.speed_rad_s == pytest.approx(expected, rel=1e-9)
    outputs = motor.outputs()
    assert outputs.current_a == pytest.approx(-K * N * expected / R, rel=1e-9)
    assert outputs.supply_power_w == 0.0 and outputs.mechanical_power_w < 0.0


def test_stall_current_is_v_over_r():
    # Forward needs T < η N (k V/R - τ_c) = 1.374 N m (the stall torque); being driven back
    # needs η T > N (k V/R + τ_c), T > 2.466 N m. In between the motor holds, stalled.
    assert P.stall_torque_n_m == pytest.approx(ETA * N * (K * V / R - TC))
    assert P.stall_torque_n_m == pytest.approx(14 * 0.0980665, rel=0.01)  # 14 kg cm
    motor = DcMotor(P, load=constant(2.0))
    motor.set_duty(1.0)
    motor.advance(1.0)
    assert motor.angle_rad == 0.0 and motor.speed_rad_s == 0.0
    outputs = motor.outputs()
    assert outputs.current_a == pytest.approx(V / R, rel=1e-12)
    assert P.stall_current_a == pytest.approx(5.5, rel=0.01)
    assert outputs.supply_power_w == pytest.approx(V**2 / R, rel=1e-12)
    assert outputs.carrier_torque_n_m == 2.0 and outputs.mechanical_power_w == 0.0


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_a_stopped_motor_stays_at_rest_below_breakaway(sign):
    # Duty 0: the load moves the motor once η |T| > N τ_c, |T| > 0.0434 N m.
    breakaway = N * TC / ETA
    held = DcMotor(P, load=constant(sign * 0.95 * breakaway))
    for _ in range(2000):
        held.advance(0.0005)
        assert held.angle_rad == 0.0 and held.speed_rad_s == 0.0
    pushed = DcMotor(P, load=constant(sign * 1.05 * breakaway))
    pushed.advance(0.1)
    assert pushed.speed_rad_s * sign < 0.0  # it yields to the load


def test_a_coasting_motor_stops_without_chattering():
    motor = DcMotor(P, speed_rad_s=20.0)
    motor.set_duty(0.01)  # d k V/R = 6.1e-4 N m < τ_c: too weak to turn it
    speeds = []
    for _ in range(1000):
        motor.advance(0.001)
        speeds.append(motor.speed_rad_s)
    stopped = speeds.index(0.0)
    assert all(speed > 0.0 for speed in speeds[:stopped])
    assert all(speed == 0.0 for speed in speeds[stopped:])
    angle = motor.angle_rad
    motor.advance(1.0)
    assert motor.angle_rad == angle


def test_load_inertia_is_on_the_left_hand_side():
    # From rest, duty 1, no load torque, load inertia J: motoring, so
    # φ̈ = (N k V/R - N τ_c) / (J_m N² + J/η) and the carrier torque is J φ̈.
    inertia = 0.01
    motor = DcMotor(P, load_inertia=lambda phi: inertia)
    motor.set_duty(1.0)
    outputs = motor.outputs()
    expected = (N * K * V / R - N * TC) / (P.rotor_inertia_kg_m2 * N**2 + inertia / ETA)
    assert outputs.carrier_acceleration_rad_s2 == pytest.approx(expected, rel=1e-12)
    assert outputs.carrier_torque_n_m == pytest.approx(inertia * expected, rel=1e-12)


def test_energy_balance():
    """Supply energy = R I² + friction + gearbox losses + kinetic energy + work on the load."""
    eta, inertia, amplitude, mean = 0.8, 2e-3, 0.3, 0.05
    parameters = DcMotorParameters(gearbox_efficiency=eta)
    motor = DcMotor(
        parameters,
        load=lambda phi, phi_dot: amplitude * math.sin(2 * phi) + mean,
        load_inertia=lambda phi: inertia,
    )
    motor.set_duty(0.6)
    dt = 1e-4
    carrier_powers = []

    def rates() -> tuple[float, ...]:
        out = motor.outputs()
        carrier_powers.append(out.mechanical_power_w)
        motor_speed = N * motor.speed_rad_s
        power = out.mechanical_power_w
        gearbox = (1 / eta - 1) * power if power >= 0 else (1 - eta) * -power
        return (out.supply_power_w, R * out.current_a**2,
                B * motor_speed**2 + TC * abs(motor_speed), gearbox)  # fmt: skip

    totals = [0.0] * 4
    before = rates()
    for _ in range(15000):
        motor.advance(dt)
        after = rates()
        pairs = zip(totals, before, after, strict=True)
        totals = [total + 0.5 * dt * (a + b) for total, a, b in pairs]
        before = after
    supplied, resistive, friction, gearbox = totals
    phi, omega = motor.angle_rad, motor.speed_rad_s
    kinetic = 0.5 * (P.rotor_inertia_kg_m2 * N**2 + inertia) * omega**2
    work = amplitude / 2 * (1 - math.cos(2 * phi)) + mean * phi  # ∫ τ_L dφ
    assert phi > 10.0 and min(carrier_powers) < 0.0 < max(carrier_powers)  # both ways
    assert supplied == pytest.approx(resistive + friction + gearbox + kinetic + work, rel=1e-6)


def test_the_result_hardly_depends_on_how_time_is_cut():
    def run(dt: float, steps: int) -> tuple[float, float]:
        motor = DcMotor(P, load=lambda phi, w: 0.3 * math.sin(2 * phi) + 0.1)
        motor.set_duty(0.8)
        for _ in range(steps):
            motor.advance(dt)
        return motor.angle_rad, motor.speed_rad_s

    coarse, fine = run(0.5, 1), run(0.00025, 2000)  # steps of 1 ms and of 0.25 ms
    assert fine[0] == pytest.approx(coarse[0], rel=1e-6)
    assert fine[1] == pytest.approx(coarse[1], rel=1e-5)


def test_from_stall_and_no_load():
    built = DcMotorParameters.from_stall_and_no_load(
        supply_voltage_v=12.0, stall_torque_n_m=1.2, no_load_speed_rad_s=30.0,
        gear_ratio=30.0, gearbox_efficiency=0.8,
    )  # fmt: skip
    # k = V / (N Ω₀) = 12 / 900; at the motor τ_s = 1.2 / (30 * 0.8) = 0.05; R = k V / τ_s = 3.2
    assert built.torque_constant_n_m_a == pytest.approx(12 / 900)
    assert built.resistance_ohm == pytest.approx(3.2)
    assert built.coulomb_friction_n_m == 0.0 and built.viscous_friction_n_m_s == 0.0
    assert built.stall_torque_n_m == pytest.approx(1.2)
    assert built.no_load_speed_rad_s == pytest.approx(30.0)
    with pytest.raises(ValueError, match="stall_torque_n_m must be finite and > 0"):
        DcMotorParameters.from_stall_and_no_load(
            supply_voltage_v=12.0, stall_torque_n_m=0.0, no_load_speed_rad_s=30.0
        )
    with pytest.raises(ValueError, match="gearbox_efficiency"):
        DcMotorParameters.from_stall_and_no_load(
            supply_voltage_v=12.0, stall_torque_n_m=1.0, no_load_speed_rad_s=30.0,
            gearbox_efficiency=0.0,
        )  # fmt: skip


@pytest.mark.parametrize(
    ("field", "value", "reason"),
    [("resistance_ohm", -1.0, "> 0"), ("resistance_ohm", math.nan, "> 0"),
     ("torque_constant_n_m_a", 0.0, "> 0"), ("supply_voltage_v", math.inf, "finite"),
     ("gear_ratio", 0.0, "> 0"), ("rotor_inertia_kg_m2", 0.0, "> 0"),
     ("gearbox_efficiency", 0.0, r"\(0, 1\]"), ("gearbox_efficiency", 1.5, r"\(0, 1\]"),
     ("gearbox_efficiency", math.nan, r"\(0, 1\]"), ("viscous_friction_n_m_s", -1e-6, ">= 0"),
     ("coulomb_friction_n_m", math.nan, ">= 0"), ("max_step_s", 0.0, "> 0"),
     ("resistance_ohm", True, "> 0")],
)  # fmt: skip
def test_parameters_refuse_meaningless_values(field, value, reason):
    with pytest.raises(ValueError, match=f"{field} must .*{reason}"):
        DcMotorParameters(**{field: value})


def test_duty_and_load_refused_with_reasons():
    motor = DcMotor(P)
    for duty in (1.5, -1.01, math.nan):
        with pytest.raises(ValueError, match=r"duty must be in \[-1, 1\]"):
            motor.set_duty(duty)
    with pytest.raises(ValueError, match="load_inertia.*must be finite and >= 0"):
        DcMotor(P, load_inertia=lambda phi: -1.0).outputs()
    with pytest.raises(ValueError, match="not finite"):
        DcMotor(P, load=lambda phi, w: math.nan).advance(0.01)
