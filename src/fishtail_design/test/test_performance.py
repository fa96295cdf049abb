import dataclasses
import math

import numpy as np
import pytest

from fishtail_design.linkages import OscillatoryLinkages
from fishtail_design.performance import performance
from fishtail_kinematics.engine.geometry import OscillatoryGeometry
from fishtail_kinematics.engine.mechanisms import OscillatoryTail
from fishtail_plant.fish.fish import FishParameters
from fishtail_plant.linkage_load.link_inertia import LinkInertia
from fishtail_plant.linkage_load.tail_load import TailLoad
from fishtail_plant.motor.dc_motor import DcMotorParameters
from fishtail_plant.motor.duty import MotorConstants, torque_at_carrier
from fishtail_swim.offline.inputs import Swimmer
from fishtail_swim.offline.motor_sizing import LoadSamples, quasi_static_limits
from fishtail_swim.offline.steady_table import steady_rows

FISH = FishParameters()
MOTOR = DcMotorParameters()
GEOMETRIES = [
    OscillatoryGeometry(),
    OscillatoryGeometry(ring_radius_m=0.05, crank_link_m=0.06, rocker_link_m=0.16,
                        tail_link_m=0.2, pivot_offset_m=0.15),  # fmt: skip
]
NAMES = ("ring_radius_m", "crank_link_m", "rocker_link_m", "tail_link_m", "pivot_offset_m")
MASSLESS = LinkInertia(**{field.name: 0.0 for field in dataclasses.fields(LinkInertia)})


def _linkages() -> OscillatoryLinkages:
    return OscillatoryLinkages({name: np.array([getattr(g, name) for g in GEOMETRIES])
                                for name in NAMES})  # fmt: skip


def _figures(speed, fish=FISH, turning=None, samples=128):
    count = len(GEOMETRIES)
    motor = MotorConstants.of(MOTOR, np.full(count, MOTOR.gear_ratio),
                              np.full(count, MOTOR.gearbox_efficiency))  # fmt: skip
    return performance(_linkages(), fish, motor, np.asarray(speed, dtype=float), samples, turning)


def test_the_balance_speed_is_what_fishtail_swim_steady_says():
    speeds = np.array([4.0, 9.0])
    figures = _figures(speeds)
    for index, geometry in enumerate(GEOMETRIES):
        rows = steady_rows(Swimmer(FISH, OscillatoryTail(geometry)), speeds[index : index + 1])
        assert figures.speed_m_s[index] == pytest.approx(rows.speed_m_s[0], rel=1e-6)
        assert figures.thrust_n[index] == pytest.approx(rows.mean_thrust_n[0], rel=1e-5)
        assert figures.tail_power_w[index] == pytest.approx(rows.tail_power_w[0], rel=1e-5)


def test_the_load_by_virtual_work_is_the_carrier_load_of_fishtail_swim_motor_without_links():
    figures = _figures([math.nan, math.nan])  # as fast as the motor sustains
    for index, geometry in enumerate(GEOMETRIES):
        load = TailLoad(OscillatoryTail(geometry), MASSLESS, FISH, "water_swimming")
        angles = np.arange(512) * (2.0 * math.pi / 512)
        torque = np.asarray(load.exact(angles, 1.0).torque_n_m, dtype=float)
        limits = quasi_static_limits(MOTOR, LoadSamples(torque, np.zeros_like(torque)))
        # The peak of a 128-sample beat against 512: the holding speed within the peak's sampling.
        assert figures.holding_speed_rad_s[index] == pytest.approx(
            limits.constant_speed_rad_s, rel=2e-3
        )
        # The mean of the load: the speed the motor sustains, the carrier's speed here.
        # (The plate's kink leaves a 128-sample mean some 1e-6 off the 512-sample one.)
        assert figures.sustained_speed_rad_s[index] == pytest.approx(limits.mean_rad_s, rel=1e-5)
        speed = figures.carrier_speed_rad_s[index]
        assert speed == figures.sustained_speed_rad_s[index]
        assert figures.peak_load_torque_n_m[index] == pytest.approx(
            np.abs(torque).max() * speed**2, rel=5e-3
        )
        # At the holding speed the load's peak is what the motor gives at full duty.
        holding = figures.holding_speed_rad_s[index]
        assert np.abs(torque).max() * holding**2 == pytest.approx(
            float(torque_at_carrier(MotorConstants.of(MOTOR), holding)), rel=5e-3
        )


def test_without_a_linear_drag_the_scaling_law_matches_a_second_evaluation():
    speeds = np.array([6.0, 12.0])
    scaled = _figures(speeds)
    # A linear drag a million times too small to matter makes the figures be evaluated again.
    nearly = dataclasses.replace(FISH, surge_linear_damping_kg_s=1e-9)
    direct = _figures(speeds, nearly)
    for field in ("speed_m_s", "thrust_n", "tail_power_w", "rms_current_a", "peak_current_a",
                  "electrical_power_w"):  # fmt: skip
        assert getattr(scaled, field) == pytest.approx(getattr(direct, field), rel=1e-6), field


def test_the_electrical_power_covers_the_tail_s_power_and_the_losses():
    figures = _figures([5.0, 8.0])
    # Copper and gearbox losses: the supply gives more than the tail takes, never less.
    assert np.all(figures.electrical_power_w > figures.tail_power_w)
    assert np.all(figures.cost_of_transport_j_kg_m == pytest.approx(
        figures.electrical_power_w / (figures.speed_m_s * FISH.body_mass_kg)))  # fmt: skip


def test_without_modulation_a_symmetric_tail_does_not_turn():
    figures = _figures([6.0, 6.0], turning=0.0, samples=64)
    # Only the unsteered drift of a swing whose mean is a milliradian off the axis is left.
    assert np.abs(figures.turning_rad_per_beat).max() < 3e-3
    modulated = _figures([6.0, 6.0], turning=0.5, samples=64)
    assert np.all(modulated.turning_rad_per_beat > 0.01)


def test_with_a_linear_drag_a_design_that_does_not_assemble_is_nan_not_an_error():
    lengths = {name: np.array([getattr(GEOMETRIES[0], name), getattr(GEOMETRIES[0], name)])
               for name in NAMES}  # fmt: skip
    lengths["rocker_link_m"][1] = 0.05  # RS + PR cannot reach: it does not assemble
    fish = dataclasses.replace(FISH, surge_linear_damping_kg_s=0.5)
    motor = MotorConstants.of(MOTOR, np.full(2, 30.0), np.full(2, 0.76))
    figures = performance(OscillatoryLinkages(lengths), fish, motor, np.full(2, math.nan), 64)
    assert np.isfinite(figures.speed_m_s[0]) and figures.speed_m_s[0] > 0.0
    assert np.isnan(figures.speed_m_s[1])
