import math

import numpy as np
import pytest

from fishtail_kinematics.engine.drive_batch import OscillatoryBatch
from fishtail_kinematics.engine.geometry import OscillatoryGeometry
from fishtail_kinematics.engine.mechanisms import OscillatoryTail
from fishtail_plant.errors import NoSteadySpeedError
from fishtail_plant.fish.figures import held_tail, steady_surge_speed
from fishtail_plant.fish.fish import FishParameters
from fishtail_plant.fish.tail_drive import (
    EngineTailDrive,
    LinkageBatchDrive,
    SinusoidalTailDrive,
    constant_carrier_speed,
)

FISH = FishParameters()  # the default fish, with its fin plate


def test_a_fish_without_a_balance_is_nan_when_not_strict_and_the_others_unchanged():
    drive = SinusoidalTailDrive(0.2, 0.0, np.array([0.3, 0.0, 0.2]), 2.0 * math.pi)
    with pytest.raises(NoSteadySpeedError):
        steady_surge_speed(drive, FISH, drive.beat_period_s)
    speeds = steady_surge_speed(drive, FISH, drive.beat_period_s, strict=False)
    assert np.isnan(speeds[1])
    alone = SinusoidalTailDrive(0.2, 0.0, np.array([0.3, 0.2]), 2.0 * math.pi)
    expected = steady_surge_speed(alone, FISH, alone.beat_period_s)
    assert speeds[[0, 2]] == pytest.approx(expected, rel=1e-12)


def test_at_the_balance_speed_the_mean_push_equals_the_hull_drag():
    drive = SinusoidalTailDrive(0.2, 0.0, np.array([0.15, 0.3]), 2.0 * math.pi)
    speed = steady_surge_speed(drive, FISH, drive.beat_period_s)
    samples = 1024
    times = np.arange(samples)[:, None] / samples * drive.beat_period_s
    towed = held_tail(drive, FISH, times, speed)
    drag = FISH.drag_factor_kg_m * speed**2 + FISH.surge_linear_damping_kg_s * speed
    assert towed.push_n.mean(axis=0) == pytest.approx(drag, rel=1e-8)
    # The tail works on the water: its mean power is positive, and above the useful part.
    assert np.all(towed.power_w.mean(axis=0) > drag * speed)
    # Straight swimming: the mean yaw moment of a symmetric beat vanishes.
    assert np.abs(towed.yaw_moment_n_m.mean(axis=0)).max() < 1e-9


def test_a_batch_of_linkages_swims_as_each_linkage_does_alone():
    geometries = [
        OscillatoryGeometry(),
        OscillatoryGeometry(ring_radius_m=0.08, tail_link_m=0.2),
        OscillatoryGeometry(crank_link_m=0.12, pivot_offset_m=0.18),
    ]
    speeds = np.array([4.0, 6.0, 3.0])
    batch = OscillatoryBatch(*(
        np.array([getattr(g, name) for g in geometries])
        for name in ("ring_radius_m", "crank_link_m", "rocker_link_m", "tail_link_m",
                     "pivot_offset_m")
    ))  # fmt: skip
    period = 2.0 * math.pi / speeds
    drive = LinkageBatchDrive(batch, constant_carrier_speed(speeds))
    together = steady_surge_speed(drive, FISH, period)
    for index, geometry in enumerate(geometries):
        one = EngineTailDrive(OscillatoryTail(geometry), constant_carrier_speed(speeds[index]))
        alone = steady_surge_speed(one, FISH, period[index])
        assert together[index] == pytest.approx(float(np.ravel(alone)[0]), rel=1e-10)
