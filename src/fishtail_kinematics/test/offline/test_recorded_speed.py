"""The forward speed of each analysed beat from the recorded fish (pure, no bag)."""

from __future__ import annotations

import numpy as np
import pytest

from fishtail_kinematics.offline.recorded_speed import (
    ODOM_MAX_GAP_S,
    beat_speed,
    odom_speed,
    swimming_speed,
)
from fishtail_kinematics.offline.recording import RecordedFish

EMPTY = np.array([])


def fish(odom_time=EMPTY, surge=EMPTY, swim_start=EMPTY, swim_end=EMPTY, swim_speed=EMPTY):
    return RecordedFish("/fish/odom", np.asarray(odom_time, float), np.asarray(surge, float),
                        "/fish/swimming", np.asarray(swim_start, float),
                        np.asarray(swim_end, float), np.asarray(swim_speed, float))  # fmt: skip


def test_odometry_gives_the_time_mean_surge_over_the_beat():
    time_s = np.linspace(0.0, 4.0, 801)
    recorded = fish(time_s, 0.1 + 0.02 * time_s)  # accelerating
    assert odom_speed(recorded, 1.0, 2.0) == pytest.approx(0.13)
    assert odom_speed(recorded, 1.003, 2.5) == pytest.approx(0.1 + 0.02 * 1.7515)


def test_odometry_that_does_not_cover_the_beat_gives_nothing():
    time_s = np.linspace(1.0, 4.0, 601)
    recorded = fish(time_s, np.full_like(time_s, 0.2))
    assert odom_speed(recorded, 0.5, 1.5) is None  # starts inside the beat
    assert odom_speed(recorded, 3.5, 4.5) is None  # ends inside it
    holed = fish(np.concatenate((time_s[:200], time_s[200 + int(ODOM_MAX_GAP_S / 0.005) + 1:])),
                 np.full(601 - int(ODOM_MAX_GAP_S / 0.005) - 1, 0.2))  # fmt: skip
    assert odom_speed(holed, 1.5, 2.5) is None
    assert odom_speed(holed, 2.8, 3.8) == pytest.approx(0.2)


def test_swimming_windows_are_weighted_by_their_overlap_with_the_beat():
    # Revolutions of 1 s at 0.1, 0.2, 0.3 m/s; a tail beat from 0.75 to 1.75 s.
    recorded = fish(swim_start=[0.0, 1.0, 2.0], swim_end=[1.0, 2.0, 3.0],
                    swim_speed=[0.1, 0.2, 0.3])  # fmt: skip
    assert swimming_speed(recorded, 0.75, 1.75) == pytest.approx(0.25 * 0.1 + 0.75 * 0.2)
    assert swimming_speed(recorded, 2.5, 3.5) is None  # after the last reported revolution


def test_the_source_order_and_the_assumed_fallback():
    time_s = np.linspace(0.0, 2.0, 401)
    both = fish(time_s, np.full_like(time_s, 0.12), [0.0, 1.0], [1.0, 2.0], [0.2, 0.2])
    assert beat_speed(both, 0.5, 1.5, 0.3) == (pytest.approx(0.12), "fish/odom")
    resting = fish(time_s, np.zeros_like(time_s), [0.0, 1.0], [1.0, 2.0], [0.2, 0.2])
    assert beat_speed(resting, 0.5, 1.5, 0.3) == (pytest.approx(0.2), "fish/swimming")
    assert beat_speed(fish(time_s, np.zeros_like(time_s)), 0.5, 1.5, 0.3) == (0.3, "assumed")
    assert beat_speed(None, 0.5, 1.5, 0.3) == (0.3, "assumed")
