"""Shared runs of the swimming checks (simulated once per session, used by several tests)."""

import numpy as np
import pytest

from fishtail_kinematics.engine.geometry import OscillatoryGeometry, UndulatoryGeometry
from fishtail_kinematics.engine.mechanisms import make_tail
from fishtail_plant.fish.fish import FishParameters
from fishtail_plant.fish.integrator import simulate
from fishtail_plant.fish.model import SwimModel
from fishtail_plant.fish.tail_drive import EngineTailDrive, constant_carrier_speed

#: Carrier speeds of the multi-speed run: the report's 4 rad/s and two multiples, whose periods
#: the common step divides (48, 24 and 16 steps per beat).
CARRIER_SPEEDS_RAD_S = np.array([4.0, 8.0, 12.0])
SLOWEST_STEPS_PER_BEAT = 48
#: Beats of the slowest fish: the start-up transient falls about 100-fold every 20 beats, so after
#: 60 it is below the integrator's error (~2e-5 at 16 steps per beat).
SLOWEST_BEATS = 60


def run_free(geometry, speeds, steps_per_beat, beats, hold_sway_yaw=False):
    """A batch of fish with the engine's tail, one per carrier speed, from rest."""
    drive = EngineTailDrive(make_tail(geometry), constant_carrier_speed(speeds))
    model = SwimModel(FishParameters(), drive, hold_sway_yaw=hold_sway_yaw)
    periods = 2.0 * np.pi / speeds
    step = periods[0] / steps_per_beat
    trajectory = simulate(model, speeds.size, step, steps_per_beat * beats)
    return model, drive, trajectory, periods


@pytest.fixture(scope="session")
def run_engine():
    """The function that runs a batch of fish with an engine tail (see run_free)."""
    return run_free


@pytest.fixture(scope="session")
def oscillatory_free_run():
    """Mechanism 1 (report geometry), free body, at 4, 8 and 12 rad/s."""
    return run_free(
        OscillatoryGeometry(), CARRIER_SPEEDS_RAD_S, SLOWEST_STEPS_PER_BEAT, SLOWEST_BEATS
    )


@pytest.fixture(scope="session")
def undulatory_free_run():
    """Mechanism 2 (report geometry), free body, at 4 rad/s."""
    return run_free(UndulatoryGeometry(), np.array([4.0]), 24, 40)
