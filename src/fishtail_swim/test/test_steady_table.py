"""The steady table's balance with a fin plate, and its held-fish columns."""

from __future__ import annotations

import numpy as np
import pytest

from fishtail_kinematics.engine.geometry import OscillatoryGeometry, UndulatoryGeometry
from fishtail_kinematics.engine.mechanisms import make_tail
from fishtail_plant.fish.figures import held_fish
from fishtail_plant.fish.fish import FishParameters
from fishtail_plant.fish.tail_drive import EngineTailDrive, constant_carrier_speed
from fishtail_swim.offline.inputs import Swimmer
from fishtail_swim.offline.steady_table import steady_rows

SPEEDS = np.array([4.0, 8.0])
PLATE = FishParameters(fin_chord_m=0.06, fin_normal_drag_coefficient=1.2,
                       surge_linear_damping_kg_s=0.5)  # fmt: skip
#: The fish without the fin plate: Lighthill's force alone.
LIGHTHILL_FISH = FishParameters(fin_chord_m=0.0, fin_normal_drag_coefficient=0.0)


@pytest.mark.parametrize("geometry", [OscillatoryGeometry(), UndulatoryGeometry()])
def test_with_a_plate_the_thrust_in_the_table_balances_the_hulls_drag(geometry):
    rows = steady_rows(Swimmer(PLATE, make_tail(geometry)), SPEEDS)
    speed = rows.speed_m_s
    drag = PLATE.drag_factor_kg_m * speed**2 + PLATE.surge_linear_damping_kg_s * speed
    np.testing.assert_allclose(rows.mean_thrust_n, drag, rtol=1e-6)
    assert np.all(rows.froude_efficiency < 1.0)


def test_held_columns_are_the_held_fish_and_zero_power_without_a_plate():
    tail = make_tail(OscillatoryGeometry())
    bare = steady_rows(Swimmer(LIGHTHILL_FISH, tail), SPEEDS)
    assert np.all(bare.held_tail_power_w == 0.0)
    assert np.all(bare.held_thrust_n > 0.0)
    plate = steady_rows(Swimmer(PLATE, tail), SPEEDS)
    held = held_fish(
        EngineTailDrive(tail, constant_carrier_speed(SPEEDS)), PLATE, 2 * np.pi / SPEEDS, 1024
    )
    np.testing.assert_allclose(plate.held_tail_power_w, held.tail_power_w, rtol=1e-9)
    # Quasi-steady drag at velocities proportional to the beat: power as its cube.
    assert plate.held_tail_power_w[1] / plate.held_tail_power_w[0] == pytest.approx(8.0, 1e-9)
