"""The water's force on the tail for the carrier's load: frame, sign, work, broadcasting."""

from __future__ import annotations

import dataclasses
import doctest
import math

import numpy as np
import pytest

from fishtail_kinematics.engine.geometry import OscillatoryGeometry, UndulatoryGeometry
from fishtail_kinematics.engine.mechanisms import OscillatoryTail, UndulatoryTail
from fishtail_plant.errors import SwimInputError
from fishtail_plant.fish.figures import held_fish, steady_surge_speed, tail_power
from fishtail_plant.fish.fish import FishParameters
from fishtail_plant.fish.model import trailing_edge_force
from fishtail_plant.fish.tail_drive import EngineTailDrive, constant_carrier_speed
from fishtail_plant.linkage_load import water as water_module
from fishtail_plant.linkage_load.carrier_load import CarrierLoadModel
from fishtail_plant.linkage_load.link_inertia import LinkInertia
from fishtail_plant.linkage_load.water import (
    carrier_load_in_water,
    fin_added_inertia,
    water_force_on_tail,
)

TAILS = [OscillatoryTail(OscillatoryGeometry()), UndulatoryTail(UndulatoryGeometry())]
IDS = ["oscillatory", "undulatory"]
REVOLUTION = np.arange(512) * (2.0 * math.pi / 512)
#: Lighthill's reactive force alone: the fish without the fin plate (the plate's own tests below
#: name theirs).
FISH = FishParameters(fin_chord_m=0.0, fin_normal_drag_coefficient=0.0)


@pytest.fixture(scope="module", params=TAILS, ids=IDS)
def tail(request):
    return request.param


def swimming_speed(tail, carrier_speed):
    """The cycle-average steady speed U of the fish at this carrier speed (sway, yaw held)."""
    drive = EngineTailDrive(tail, constant_carrier_speed(np.array([carrier_speed])))
    return float(steady_surge_speed(drive, FISH, 2.0 * math.pi / carrier_speed)[0])


def water_torque(tail, carrier_speed, surge_speed):
    model = CarrierLoadModel(tail, LinkInertia.massless())
    return carrier_load_in_water(model, FISH, REVOLUTION, carrier_speed, 0.0, surge_speed)


@pytest.mark.parametrize("carrier_speed", [4.0, 12.0])
def test_the_carrier_works_on_the_water_of_a_swimming_fish(tail, carrier_speed):
    """Held at its swimming speed U > 0 the tail does positive work on the water on average."""
    surge = swimming_speed(tail, carrier_speed)
    assert surge > 0.0
    load = water_torque(tail, carrier_speed, surge)
    assert load.power_w.mean() > 0.0
    # It is the spec's tail power, -F_T . (-Tx_dot, Ty_dot), sample by sample.
    drive = EngineTailDrive(tail, constant_carrier_speed(carrier_speed))
    sample = drive.sample(REVOLUTION / carrier_speed)
    held = np.zeros_like(REVOLUTION)
    force = trailing_edge_force(FISH, sample, held + surge, held, held).force
    expected = tail_power(force, sample)
    np.testing.assert_allclose(load.power_w, expected, rtol=0, atol=1e-13 * np.abs(expected).max())
    # And the faster the fish is held, the more work the tail does.
    assert water_torque(tail, carrier_speed, 2 * surge).power_w.mean() > load.power_w.mean()


def test_held_at_rest_the_water_takes_no_work_over_a_revolution(tail):
    """Held at u = 0, Lighthill's power, cubic in the tail's velocities, averages out.

    The pose depends on phi only through OP = R cos(phi + psi), so each revolution is its own
    time reversal; the instantaneous power is -F . v_T = ½ m u_t w^2, odd in the velocities.
    """
    load = water_torque(tail, 8.0, 0.0)
    scale = np.abs(load.power_w).max()
    assert abs(load.power_w.mean()) < 1e-14 * max(scale, 1.0)
    if tail.fin_joint is None:
        # Mechanism 1's fin turns about S: the tip moves along the normal (u_t = 0), the force
        # ½ m w^2 t runs along the fin through the pivot, and the carrier feels none of it.
        np.testing.assert_allclose(load.torque_n_m, 0.0, atol=1e-15)
    else:
        assert scale > 0.0


def test_the_tail_frame_force_by_hand():
    """Mid-stroke of the symmetric mechanism 1 at rest: F_T = ½ m w^2 forward, w = ST theta3_dot.

    Forward in the body is -x in the tail frame.
    """
    tail = TAILS[0]
    carrier_speed = 4.0
    state = tail.solve(math.pi / 2, carrier_speed)
    assert state.theta3 == pytest.approx(0.0, abs=1e-12)
    water = water_force_on_tail(tail, FISH, math.pi / 2, carrier_speed)
    normal = tail.geometry.tail_link_m * state.theta3_dot
    added_mass = math.pi / 4 * 1000.0 * 0.1**2
    assert float(water.force_x_n) == pytest.approx(-0.5 * added_mass * normal**2, rel=1e-12)
    assert float(water.force_y_n) == pytest.approx(0.0, abs=1e-12)


def test_swimming_forward_the_water_pushes_the_tail_back_against_its_stroke():
    """Towed at U with the fin straight and moving left: the lateral force pushes it right."""
    tail = TAILS[0]
    water = water_force_on_tail(tail, FISH, math.pi / 2, 4.0, surge_speed_m_s=0.5)
    assert float(water.tip_velocity_y_m_s) > 0.0  # the tip moves left
    assert float(water.force_y_n) < 0.0  # the water pushes it right
    assert float(water.force_y_n * water.tip_velocity_y_m_s) < 0.0


def test_vectorised_over_angles_and_fish(tail):
    spans = np.array([0.05, 0.1, 0.2])
    # Without the plate, whose drag grows as d and its recoil as d² c: Lighthill's d² alone.
    fish = dataclasses.replace(FISH, fin_span_m=spans)
    angles = REVOLUTION[::32, None]
    water = water_force_on_tail(tail, fish, angles, 6.0, surge_speed_m_s=0.3)
    assert water.force_x_n.shape == (16, 3)
    # Lighthill's force is proportional to the added mass per length, (pi/4) rho d^2.
    np.testing.assert_allclose(water.force_x_n[:, 2], 4.0 * water.force_x_n[:, 1], rtol=1e-13)
    np.testing.assert_allclose(water.force_y_n[:, 0], 0.25 * water.force_y_n[:, 1], rtol=1e-13)
    single = water_force_on_tail(
        tail, dataclasses.replace(FISH, fin_span_m=0.2), angles[:, 0], 6.0, 0.3
    )
    np.testing.assert_allclose(water.force_y_n[:, 2], single.force_y_n, rtol=1e-15)
    model = CarrierLoadModel(tail, LinkInertia())
    load = carrier_load_in_water(model, fish, angles, 6.0, 1.0, surge_speed_m_s=0.3)
    assert load.torque_n_m.shape == (16, 3)
    np.testing.assert_allclose(
        load.inertial_torque_n_m[:, 0], model.load(angles[:, 0], 6.0, 1.0).torque_n_m, rtol=1e-15
    )


PLATE = FishParameters(fin_chord_m=0.06, fin_normal_drag_coefficient=1.2)


def test_held_at_rest_the_carrier_pays_the_plates_dissipation(tail):
    """By virtual work through the linkage, the carrier's mean power is the tail's power held.

    held_fish computes it from the plate's force and the tail's motion in the body; the carrier's
    load from the linkage's ratios: two routes to one figure. The recoil averages out.
    """
    speed = 4.0
    model = CarrierLoadModel(tail, LinkInertia.massless())
    load = carrier_load_in_water(model, PLATE, REVOLUTION, speed)
    drive = EngineTailDrive(tail, constant_carrier_speed(speed))
    held = held_fish(drive, PLATE, 2.0 * math.pi / speed, samples=REVOLUTION.size)
    assert held.fin_drag_power_w[0] > 0.0
    np.testing.assert_allclose(load.power_w.mean(), held.tail_power_w[0], rtol=1e-9)
    assert np.abs(load.power_w).max() > 2 * held.tail_power_w[0]  # the recoil swings about it


def test_a_chord_adds_the_fins_added_mass_to_the_carriers_inertia(tail):
    """The recoil's part in phi_ddot is the added inertia m c (n . dM/dphi)², nothing else."""
    model = CarrierLoadModel(tail, LinkInertia.massless())
    angles = REVOLUTION[::16]
    steady = carrier_load_in_water(model, PLATE, angles, 5.0, 0.0, 0.1)
    speeding = carrier_load_in_water(model, PLATE, angles, 5.0, 30.0, 0.1)
    added = fin_added_inertia(tail, PLATE, angles)
    assert added.max() > 0.0
    np.testing.assert_allclose(speeding.torque_n_m - steady.torque_n_m, added * 30.0, rtol=1e-6,
                               atol=1e-9 * added.max())  # fmt: skip


def test_without_a_plate_the_load_is_lighthills_alone(tail):
    model = CarrierLoadModel(tail, LinkInertia.massless())
    lighthill = carrier_load_in_water(model, FISH, REVOLUTION, 6.0, 0.0, 0.2)
    no_coefficient = FishParameters(fin_chord_m=0.0, fin_normal_drag_coefficient=2.0)
    same = carrier_load_in_water(model, no_coefficient, REVOLUTION, 6.0, 0.0, 0.2)
    np.testing.assert_array_equal(same.torque_n_m, lighthill.torque_n_m)


@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_a_non_finite_forward_speed_is_refused(bad):
    with pytest.raises(SwimInputError, match="forward speed must be finite"):
        water_force_on_tail(TAILS[0], FISH, 0.0, 4.0, surge_speed_m_s=bad)


def test_doctests():
    result = doctest.testmod(water_module)
    assert result.attempted > 0 and result.failed == 0
