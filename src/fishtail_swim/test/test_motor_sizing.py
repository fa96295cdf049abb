"""``fishtail-swim motor``: quasi-static rows and limits, the full-duty run, verdicts, the CLI."""

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from fishtail_kinematics.engine.geometry import OscillatoryGeometry, UndulatoryGeometry
from fishtail_kinematics.engine.mechanisms import make_tail
from fishtail_plant.fish.fish import FishParameters
from fishtail_plant.linkage_load.link_inertia import LinkInertia
from fishtail_plant.linkage_load.tail_load import TailLoad
from fishtail_plant.motor.dc_motor import DcMotorParameters
from fishtail_plant.motor.full_duty_run import RunLimits, run_at_full_duty
from fishtail_swim.offline.motor_load_table import motor_load_rows
from fishtail_swim.offline.motor_sizing import (
    OK,
    OVER_THE_STALL,
    OVER_THE_SUPPLY,
    LoadSamples,
    UnsettledRunError,
    quasi_static_limits,
    quasi_static_rows,
    sample_load,
    size_motor,
    verdict,
)

CONFIG = Path(__file__).resolve().parents[3] / "config"
FISH = CONFIG / "fish.yaml"
GEOMETRIES = {"oscillatory": OscillatoryGeometry(), "undulatory": UndulatoryGeometry()}
#: Stall torque and no-load speed at the carrier of a motor far too weak for mechanism 2 swimming.
WEAK = ("--stall-torque-n-m", "0.05", "--no-load-speed-rpm", "100")
#: The fish without the fin plate: Lighthill's force alone.
LIGHTHILL_FISH = FishParameters(fin_chord_m=0.0, fin_normal_drag_coefficient=0.0)


def tail_load(mechanism, surroundings, inertia=None, fish=None):
    tail = make_tail(GEOMETRIES[mechanism])
    return TailLoad(tail, inertia or LinkInertia(), fish or FishParameters(), surroundings)


# ---- hand-derived cases


def test_with_no_load_the_motor_sustains_its_no_load_speed_less_its_friction():
    # Steady, unloaded, full duty: N (k (V - k N w) / R - b N w - tau_c) = 0 at the motor shaft.
    p = DcMotorParameters()
    k, r, n = p.torque_constant_n_m_a, p.resistance_ohm, p.gear_ratio
    by_hand = (k * p.supply_voltage_v / r - p.coulomb_friction_n_m) / (
        n * (k * k / r + p.viscous_friction_n_m_s)
    )
    assert by_hand == pytest.approx(34.56, abs=0.01)  # below the frictionless V / (k N) = 35.9
    sizing = size_motor(p, tail_load("oscillatory", "none"))
    assert sizing.limits.constant_speed_rad_s == pytest.approx(by_hand, rel=1e-12)
    assert sizing.limits.mean_rad_s == pytest.approx(by_hand, rel=1e-12)
    run = sizing.run
    assert run.settled
    # RK4 at a tenth of the time constant: the revolution's time to ~1e-9.
    assert run.mean_speed_rad_s == pytest.approx(by_hand, rel=1e-7)
    assert run.max_speed_rad_s - run.min_speed_rad_s < 1e-6 * by_hand
    assert run.mean_supply_power_w == pytest.approx(
        p.supply_voltage_v * (p.supply_voltage_v - k * n * by_hand) / r, rel=1e-6
    )
    assert sizing.verdict.startswith(f"sustains {by_hand / (2 * math.pi):#.3g} Hz")


def test_quasi_static_rows_of_a_constant_load_by_hand():
    p = DcMotorParameters()
    c0 = 0.002  # N m s^2: tau = c0 w^2 at every angle
    load = LoadSamples(np.full(16, c0), np.zeros(16))
    rows = quasi_static_rows(p, load, [1.0, 2.0])
    w = 2.0 * math.pi * np.array([1.0, 2.0])
    k, n, eta = p.torque_constant_n_m_a, p.gear_ratio, p.gearbox_efficiency
    friction = p.viscous_friction_n_m_s * n * w + p.coulomb_friction_n_m
    current = (c0 * w**2 / (n * eta) + friction) / k
    voltage = p.resistance_ohm * current + k * n * w
    np.testing.assert_allclose(rows.carrier_speed_rad_s, w)
    np.testing.assert_allclose(rows.peak_torque_n_m, c0 * w**2)
    np.testing.assert_allclose(rows.rms_torque_n_m, c0 * w**2)
    np.testing.assert_allclose(rows.peak_current_a, current)
    np.testing.assert_allclose(rows.rms_current_a, current)
    np.testing.assert_allclose(rows.peak_voltage_v, voltage)
    np.testing.assert_allclose(rows.mean_voltage_v, voltage)
    np.testing.assert_allclose(rows.mean_supply_power_w, voltage * current)
    # The constant-speed limit is where the voltage needed is the supply's.
    limit = quasi_static_limits(p, load).constant_speed_rad_s
    at_limit = quasi_static_rows(p, load, [limit / (2.0 * math.pi)])
    assert at_limit.peak_voltage_v[0] == pytest.approx(p.supply_voltage_v, rel=1e-12)
    assert at_limit.verdict == (OK,)


def test_the_gearbox_charges_its_losses_both_ways():
    # Half the revolution drives the load, half is driven by it: a mean of e c, not of c.
    p = DcMotorParameters(coulomb_friction_n_m=0.0, viscous_friction_n_m_s=0.0)
    eta = p.gearbox_efficiency
    load = LoadSamples(np.array([0.01, -0.01]), np.zeros(2))
    rows = quasi_static_rows(p, load, [1.0])
    w = 2.0 * math.pi
    k, n = p.torque_constant_n_m_a, p.gear_ratio
    currents = np.array([0.01 / eta, -0.01 * eta]) * w**2 / (n * k)
    assert rows.rms_current_a[0] == pytest.approx(math.sqrt(np.mean(currents**2)))
    assert rows.mean_voltage_v[0] == pytest.approx(p.resistance_ohm * currents.mean() + k * n * w)
    assert rows.mean_voltage_v[0] > k * n * w  # the losses cost voltage though tau averages to 0


def test_the_torque_columns_are_those_of_the_motor_load_table():
    speeds = np.array([4.0, 12.0])
    table = motor_load_rows(
        make_tail(OscillatoryGeometry()), LinkInertia(), FishParameters(), speeds
    )
    expected = {
        "air": (table.air_peak_torque_n_m, table.air_rms_torque_n_m),
        "water_held": (table.rest_peak_torque_n_m, table.rest_rms_torque_n_m),
        "water_swimming": (table.swimming_peak_torque_n_m, table.swimming_rms_torque_n_m),
    }
    for surroundings, (peak, rms) in expected.items():
        samples = sample_load(tail_load("oscillatory", surroundings))
        rows = quasi_static_rows(DcMotorParameters(), samples, speeds / (2.0 * math.pi))
        np.testing.assert_allclose(rows.peak_torque_n_m, peak, rtol=1e-6)
        np.testing.assert_allclose(rows.rms_torque_n_m, rms, rtol=1e-6)


def test_row_verdicts_say_which_limit_a_constant_speed_passes():
    p = DcMotorParameters()
    load = LoadSamples(np.full(4, 0.002), np.zeros(4))
    stall_speed = math.sqrt(p.stall_torque_n_m / 0.002)
    limit = quasi_static_limits(p, load).constant_speed_rad_s
    frequencies = np.array([0.9 * limit, 1.1 * limit, 1.1 * stall_speed]) / (2.0 * math.pi)
    assert quasi_static_rows(p, load, frequencies).verdict == (
        OK,
        OVER_THE_SUPPLY,
        OVER_THE_STALL,
    )


# ---- the full-duty run against the quasi-static limits


@pytest.mark.parametrize("mechanism", ["oscillatory", "undulatory"])
def test_sustained_speed_falls_as_the_load_grows(mechanism):
    speeds = {
        surroundings: size_motor(
            DcMotorParameters(), tail_load(mechanism, surroundings)
        ).run.mean_speed_rad_s
        for surroundings in ("none", "air", "water_held", "water_swimming")
    }
    assert speeds["none"] > speeds["air"] > speeds["water_held"] > speeds["water_swimming"]
    # Held at rest the default fin plate's drag loads either tail (without the plate mechanism
    # 1's fin force runs through its pivot: test_held_in_water_a_fin_plate_asks_...).
    assert speeds["air"] > 1.005 * speeds["water_held"]
    assert speeds["water_swimming"] < 0.7 * speeds["air"]


def test_sustained_speed_rises_with_the_supply_voltage():
    load = tail_load("oscillatory", "water_swimming")
    speeds = [
        size_motor(DcMotorParameters(supply_voltage_v=volts), load).run.mean_speed_rad_s
        for volts in (6.0, 9.0, 12.0, 15.0)
    ]
    assert all(later > earlier for earlier, later in zip(speeds, speeds[1:], strict=False))


@pytest.mark.parametrize("mechanism", ["oscillatory", "undulatory"])
@pytest.mark.parametrize("surroundings", ["air", "water_held", "water_swimming"])
def test_the_constant_speed_limit_is_a_lower_bound(mechanism, surroundings):
    # Below it the motor out-pulls the load at every angle, so the carrier cannot stay there.
    sizing = size_motor(DcMotorParameters(), tail_load(mechanism, surroundings))
    assert sizing.run.settled
    assert sizing.run.min_speed_rad_s >= sizing.limits.constant_speed_rad_s * (1.0 - 1e-3)
    assert sizing.run.mean_speed_rad_s > sizing.limits.constant_speed_rad_s


@pytest.mark.parametrize("mechanism", ["oscillatory", "undulatory"])
def test_with_a_heavy_rotor_the_run_agrees_with_the_mean_limit(mechanism):
    # A rotor 1700 times the default's holds the ripple under 1 % of the speed (300 times left
    # 2.8 % with the default fish's fin plate, whose drag makes mechanism 2's load peakier); the
    # run's mean then agrees with the flywheel limit to 0.05 %. The default rotor ripples and
    # runs up to 14 % faster than that limit (the peaks met at a lower speed cost less).
    heavy = DcMotorParameters(rotor_inertia_kg_m2=5e-3)
    load = tail_load(mechanism, "water_swimming")
    sizing = size_motor(heavy, load)
    run = sizing.run
    assert run.settled
    assert (run.max_speed_rad_s - run.min_speed_rad_s) < 0.02 * run.mean_speed_rad_s
    assert run.mean_speed_rad_s == pytest.approx(sizing.limits.mean_rad_s, rel=5e-4)
    light = size_motor(DcMotorParameters(), load)
    assert light.run.mean_speed_rad_s > light.limits.mean_rad_s
    assert light.run.mean_speed_rad_s < 1.15 * light.limits.mean_rad_s


# ---- motors that cannot do it


def test_a_load_heavier_than_the_stall_torque_at_rest_keeps_the_carrier_still():
    p = DcMotorParameters()
    at_rest = 1.1 * p.stall_torque_n_m  # under the back-driving breakaway (stall / eta^2)
    run = run_at_full_duty(p, lambda phi, omega: at_rest, lambda phi: 0.0)
    assert not run.started
    assert run.mean_speed_rad_s == 0.0
    assert run.rms_current_a == pytest.approx(p.stall_current_a)
    text = verdict(p, run, 0.5, at_rest)
    assert text == (
        f"cannot start the tail: peak load {at_rest:.3g} N m at rest > stall 1.37 N m at the "
        "carrier"
    )


def test_a_carrier_that_sticks_within_a_revolution_stalls_there():
    p = DcMotorParameters()
    # From 2 to 5 rad a load the motor balances only with its friction: it stops and sticks.
    frictionless = p.gearbox_efficiency * p.gear_ratio * p.torque_constant_n_m_a * p.stall_current_a

    def bump(phi, omega):
        return frictionless if 2.0 <= phi % (2.0 * math.pi) <= 5.0 else 0.0

    run = run_at_full_duty(p, bump, lambda phi: 0.0)
    assert run.started
    assert run.stopped_at_rad is not None and 2.0 <= run.stopped_at_rad <= 5.0
    assert run.mean_speed_rad_s > 0.0 and run.min_speed_rad_s == 0.0
    assert verdict(p, run, 0.5, 0.0) == (
        f"stalls: at full duty the carrier stops at phi = {run.stopped_at_rad:.3f} rad, in "
        "revolution 1"
    )


def test_a_weak_motor_stalls_with_a_clear_sentence_and_exit_status_0(swim_cli):
    status, out, err = swim_cli("motor", "--mechanism", "undulatory", "--fish", FISH, *WEAK)
    assert status == 0, err
    assert "nan" not in out.lower() and "inf" not in out.lower()
    last = out.strip().splitlines()[-1]
    assert last.startswith("stalls at 0.3")
    assert "below the slowest beat asked for (0.5 Hz)" in last
    assert out.count("over the stall") == 6  # every row of the table


def test_a_motor_that_cannot_turn_itself_cannot_start_the_tail(swim_cli):
    status, out, err = swim_cli(
        "motor", "--fish", FISH, "--coulomb-friction-n-m", "0.1", "--frequencies", "1,2"
    )
    assert status == 0, err
    assert "nan" not in out.lower() and "inf" not in out.lower()
    assert "does not move" in out
    assert (
        out.strip()
        .splitlines()[-1]
        .startswith("cannot start the tail: the motor cannot turn itself at 12 V")
    )


# ---- the command line


def test_motor_prints_the_table_the_limits_and_writes_a_png(swim_cli, tmp_path):
    figure = tmp_path / "torque_speed.png"
    status, out, err = swim_cli("motor", "--config", CONFIG / "oscillatory.yaml", "--fish", FISH,
        "--frequencies", "1,2,3", "--figure", figure,
    )  # fmt: skip
    assert status == 0, err
    lines = out.splitlines()
    header = next(i for i, line in enumerate(lines) if line.startswith("f [Hz]"))
    assert [line.split()[0] for line in lines[header + 1 : header + 4]] == ["1.00", "2.00", "3.00"]
    assert lines[header + 3].endswith("over the supply")  # 3 Hz needs 17.1 V at the peak
    assert "constant speed (V peak = supply):           2.39 Hz" in out
    assert "sustains 3.37 Hz at full duty (12 V, PWM 255)" in out
    held = next(i for i, line in enumerate(lines) if line.startswith("f [Hz]  held thrust [N]"))
    assert [line.split()[0] for line in lines[held + 1 : held + 4]] == ["1.00", "2.00", "3.00"]
    # Mechanism 1 held still: all its power goes into the default fin plate's drag.
    assert lines[held + 1].split()[2:] == ["0.0762", "0.0762"]
    assert f"wrote {figure}" in out
    with Image.open(figure) as image:
        assert image.format == "PNG"
        assert image.size[0] > 400 and image.size[1] > 300


def test_motor_options_set_the_motor_and_the_datasheet_form_agrees(swim_cli):
    # The default motor's own stall torque and no-load speed, given as datasheet figures with its
    # friction: the same motor, so the same answer.
    p = DcMotorParameters()
    friction = ("--coulomb-friction-n-m", p.coulomb_friction_n_m,
                "--viscous-friction-n-m-s", p.viscous_friction_n_m_s)  # fmt: skip
    _, default, _ = swim_cli("motor", "--fish", FISH, "--surroundings", "air")
    frictionless = dataclasses.replace(p, coulomb_friction_n_m=0.0, viscous_friction_n_m_s=0.0)
    status, datasheet, err = swim_cli("motor", "--fish", FISH, "--surroundings", "air", *friction,
        "--stall-torque-n-m", repr(frictionless.stall_torque_n_m),
        "--no-load-speed-rad-s", repr(frictionless.no_load_speed_rad_s),
    )  # fmt: skip
    assert status == 0, err
    assert datasheet.splitlines()[1:] == default.splitlines()[1:]  # R and k round the same


@pytest.mark.parametrize(
    ("arguments", "words"),
    [
        (("--gearbox-efficiency", "1.5"), "--gearbox-efficiency must be in (0, 1]"),
        (("--resistance-ohm", "-1"), "--resistance-ohm must be finite and > 0"),
        (("--gear-ratio", "0"), "--gear-ratio must be finite and > 0"),
        (("--supply-voltage-v", "nan"), "--supply-voltage-v must be finite and > 0, got nan"),
        (("--stall-torque-n-m", "1"), "give both --stall-torque-n-m"),
        (("--stall-torque-n-m", "0", "--no-load-speed-rpm", "100"), "--stall-torque-n-m must be"),
        ((*WEAK, "--torque-constant-n-m-a", "0.01"), "cannot go with --stall-torque-n-m"),
        (("--no-load-speed-rpm", "1", "--no-load-speed-rad-s", "1"), "not allowed with"),
        (("--frequencies", "1,-2"), "frequency_hz = -2.0 is outside (0.0, inf] Hz"),
        (("--frequencies", ","), "no beat frequency in ','"),
        (("--surroundings", "vacuum"), "invalid choice"),
        (("--figure", "{tmp}/figure.svg"), "name it *.png"),
        (("--figure", "{tmp}/no/figure.png"), "no directory"),
        (("--config", "{tmp}/none.yaml"), "no such file"),
    ],
)
def test_bad_motor_options_are_one_line_and_status_2(swim_cli, tmp_path, arguments, words):
    filled = [argument.replace("{tmp}", str(tmp_path)) for argument in arguments]
    status, out, err = swim_cli("motor", "--fish", FISH, *filled)
    assert status == 2
    assert out == ""
    assert len(err.strip().splitlines()) == 1
    assert err.startswith("fishtail-swim: error: ")
    assert words in err


@pytest.mark.parametrize(
    ("arguments", "words"),
    [
        # Outside a small fish motor's ranges: refused at once (was a verdict after about 60 s).
        (("--supply-voltage-v", "1e9"), "--supply-voltage-v = 1000000000.0 is outside [1.0, 60.0]"),
        (("--stall-torque-n-m", "1e30", "--no-load-speed-rpm", "100"),
         "--stall-torque-n-m = 1e+30 is outside [0.001, 100.0] N m"),
        (("--resistance-ohm", "1e-12"), "--resistance-ohm = 1e-12 is outside [0.01, 1000.0] ohm"),
        (("--no-load-speed-rad-s", "1e4", "--stall-torque-n-m", "1"), "is outside [0.5, 1000.0]"),
        (("--supply-voltage-v", "1", "--stall-torque-n-m", "1", "--no-load-speed-rad-s", "1000"),
         "the datasheet figures (with the supply and the gearbox) give --resistance-ohm = 0.00076"),
        # In range, but a step far too short for the revolutions: refused before the run.
        (("--rotor-inertia-kg-m2", "1e-10", "--resistance-ohm", "0.01",
          "--torque-constant-n-m-a", "1"), "would need about 6.28e+14 steps to settle"),
    ],
)  # fmt: skip
def test_absurd_motors_are_refused_in_one_line_without_a_figure(
    swim_cli, tmp_path, arguments, words
):
    figure = tmp_path / "figure.png"
    status, out, err = swim_cli("motor", "--fish", FISH, "--figure", figure, *arguments)
    assert status == 2
    assert out == ""
    assert len(err.strip().splitlines()) == 1, err
    assert err.startswith("fishtail-swim: error: ")
    assert words in err
    assert not figure.exists()


def test_a_run_that_does_not_settle_gives_no_verdict():
    load = tail_load("oscillatory", "water_swimming")
    # Three revolutions cannot settle (the test needs four); too few steps for four revolutions.
    with pytest.raises(UnsettledRunError, match="did not settle: 3 revolutions"):
        size_motor(DcMotorParameters(), load, limits=RunLimits(max_revolutions=3))
    # Four revolutions at the loaded tail's 20.3 rad/s, 1 ms steps.
    with pytest.raises(UnsettledRunError, match="would need about 1.2[0-9]e\\+03 steps"):
        size_motor(DcMotorParameters(), load, limits=RunLimits(max_steps=500))


def test_held_in_water_a_fin_plate_asks_the_oscillating_tail_for_power():
    """Mechanism 1 held still: no power without the plate's drag, its dissipation with it."""
    tail = make_tail(OscillatoryGeometry())
    plate = FishParameters(fin_chord_m=0.06, fin_normal_drag_coefficient=1.2)
    held = {}
    for name, fish in (("bare", LIGHTHILL_FISH), ("plate", plate)):
        load = TailLoad(tail, LinkInertia(), fish, "water_held")
        held[name] = size_motor(DcMotorParameters(), load, (1.0, 2.0))
    bare, with_plate = held["bare"].held, held["plate"].held
    assert np.all(np.abs(bare.tail_power_w) < 1e-12)
    assert np.all(with_plate.tail_power_w > 0.0)
    np.testing.assert_allclose(with_plate.tail_power_w, with_plate.fin_drag_power_w, rtol=1e-9)
    # Quadratic drag of velocities proportional to f: the power goes as f³.
    ratio = with_plate.tail_power_w[1] / with_plate.tail_power_w[0]
    assert ratio == pytest.approx(8.0, rel=1e-9)
    # The motor pays for it: more current, a lower sustained beat.
    assert held["plate"].run.rms_current_a > 2.0 * held["bare"].run.rms_current_a
    assert held["plate"].run.mean_speed_rad_s < held["bare"].run.mean_speed_rad_s
    in_air = size_motor(DcMotorParameters(), TailLoad(tail, LinkInertia(), plate, "air"), (1.0,))
    assert in_air.held is None
