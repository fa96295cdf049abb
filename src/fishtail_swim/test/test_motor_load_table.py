"""The motor-load table: its figures against their definitions and the steady-swimming table."""

from __future__ import annotations

import csv
import io

import numpy as np
import pytest

from fishtail_kinematics.engine.geometry import OscillatoryGeometry, UndulatoryGeometry
from fishtail_kinematics.engine.mechanisms import make_tail
from fishtail_plant.fish.figures import held_fish
from fishtail_plant.fish.fish import FishParameters
from fishtail_plant.fish.tail_drive import EngineTailDrive, constant_carrier_speed
from fishtail_plant.linkage_load.carrier_load import carrier_load
from fishtail_plant.linkage_load.link_inertia import LinkInertia
from fishtail_swim.offline.inputs import Swimmer
from fishtail_swim.offline.motor_load_table import (
    MotorLoadRows,
    motor_load_rows,
    write_motor_load_table,
)
from fishtail_swim.offline.steady_table import steady_rows

SPEEDS = np.array([4.0, 8.0, 16.0])
#: The fish without the fin plate: Lighthill's force alone, whose power held at rest averages out.
LIGHTHILL_FISH = FishParameters(fin_chord_m=0.0, fin_normal_drag_coefficient=0.0)
TAILS = [make_tail(OscillatoryGeometry()), make_tail(UndulatoryGeometry())]
IDS = ["oscillatory", "undulatory"]


@pytest.fixture(scope="module", params=TAILS, ids=IDS)
def tail(request):
    return request.param


@pytest.fixture(scope="module")
def rows(tail):
    return motor_load_rows(tail, LinkInertia(), FishParameters(), SPEEDS)


def test_air_is_the_inertial_torque_over_a_revolution(tail, rows):
    angles = np.arange(4096) * (2 * np.pi / 4096)
    torque = carrier_load(tail, LinkInertia(), angles, 8.0).torque_n_m
    assert rows.air_peak_torque_n_m[1] == pytest.approx(np.abs(torque).max(), rel=1e-4)
    assert rows.air_rms_torque_n_m[1] == pytest.approx(np.sqrt(np.mean(torque**2)), rel=1e-12)
    # Quadratic in the speed.
    np.testing.assert_allclose(rows.air_rms_torque_n_m / SPEEDS**2, rows.air_rms_torque_n_m[0] / 16)


def test_swimming_power_is_the_steady_tables_tail_power(tail, rows):
    steady = steady_rows(Swimmer(FishParameters(), tail), SPEEDS)
    np.testing.assert_allclose(rows.swimming_speed_m_s, steady.speed_m_s, rtol=1e-12)
    # The links' inertia does no work over a revolution: the mean power is the water's.
    np.testing.assert_allclose(rows.swimming_mean_power_w, steady.tail_power_w, rtol=1e-9)
    assert np.all(rows.swimming_mean_power_w > 0.0)


def test_held_at_rest_the_mean_power_is_zero_without_a_plate(tail):
    rows = motor_load_rows(tail, LinkInertia(), LIGHTHILL_FISH, SPEEDS)
    scale = rows.rest_peak_torque_n_m * SPEEDS
    assert np.all(np.abs(rows.rest_mean_power_w) < 1e-12 * scale)
    if tail.fin_joint is None:
        np.testing.assert_allclose(rows.rest_peak_torque_n_m, rows.air_peak_torque_n_m, rtol=1e-12)


def test_held_at_rest_the_default_fin_plate_takes_the_held_fishs_power(tail, rows):
    # The carrier's mean power is the tail's power held still (figures.held_fish): the plate's
    # drag dissipates it; Lighthill's force and the recoil average out.
    drive = EngineTailDrive(tail, constant_carrier_speed(SPEEDS))
    held = held_fish(drive, FishParameters(), 2.0 * np.pi / SPEEDS)
    assert np.all(held.tail_power_w > 0.0)
    np.testing.assert_allclose(rows.rest_mean_power_w, held.tail_power_w, rtol=1e-6)


def test_rms_never_exceeds_peak(rows):
    for peak, rms in (
        (rows.air_peak_torque_n_m, rows.air_rms_torque_n_m),
        (rows.rest_peak_torque_n_m, rows.rest_rms_torque_n_m),
        (rows.swimming_peak_torque_n_m, rows.swimming_rms_torque_n_m),
    ):
        assert np.all(rms <= peak)
    assert np.all(rows.swimming_peak_power_w >= rows.swimming_mean_power_w)


def test_a_massless_tail_in_air_needs_nothing(tail):
    rows = motor_load_rows(tail, LinkInertia.massless(), FishParameters(), SPEEDS, samples=256)
    np.testing.assert_array_equal(rows.air_peak_torque_n_m, 0.0)
    assert np.all(rows.swimming_peak_torque_n_m > 0.0)


def test_written_as_text_and_csv(rows):
    text = io.StringIO()
    write_motor_load_table(rows, text)
    lines = text.getvalue().splitlines()
    assert len(lines) == 1 + SPEEDS.size
    assert lines[0].split()[0] == "phi_dot"
    comma = io.StringIO()
    write_motor_load_table(rows, comma, as_csv=True)
    table = list(csv.reader(io.StringIO(comma.getvalue())))
    assert table[0] == list(MotorLoadRows._fields)
    assert float(table[2][0]) == 8.0
    assert float(table[3][-1]) == pytest.approx(rows.swimming_peak_power_w[2], rel=1e-11)
