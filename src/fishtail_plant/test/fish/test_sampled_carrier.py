"""LinearCarrier and RecordedCarrier: the carrier between samples, and at steps already taken."""

import numpy as np
import pytest

from fishtail_plant.fish.sampled_carrier import LinearCarrier, RecordedCarrier


def test_the_linear_carrier_is_the_line_through_its_sample():
    carrier = LinearCarrier()
    carrier.set(2.0, 1.0, 3.0)
    angle, speed, acceleration = carrier(np.array([2.0, 2.5]))
    assert angle.tolist() == [1.0, 2.5]
    assert speed.tolist() == [3.0, 3.0] and acceleration.tolist() == [0.0, 0.0]


def test_the_recorded_carrier_answers_each_time_with_its_own_interval_speed():
    carrier = RecordedCarrier()
    # t = 0.2 ends an interval at 1 rad/s; the next one, at 5 rad/s, starts there.
    carrier.record(np.array([0.1, 0.2, 0.3]), np.array([0.1, 0.2, 0.7]), np.array([1.0, 1.0, 5.0]))
    angle, speed, acceleration = carrier(np.array([[0.3], [0.1], [0.2]]))
    assert angle.shape == speed.shape == acceleration.shape == (3, 1)
    assert angle[:, 0].tolist() == [0.7, 0.1, 0.2]
    assert speed[:, 0].tolist() == [5.0, 1.0, 1.0]
    assert not acceleration.any()


@pytest.mark.parametrize("time_s", [0.15, 0.05, 0.4])
def test_the_recorded_carrier_refuses_a_time_it_was_not_recorded_at(time_s):
    carrier = RecordedCarrier()
    carrier.record(np.array([0.1, 0.2, 0.3]), np.zeros(3), np.ones(3))
    with pytest.raises(ValueError, match="not recorded"):
        carrier(np.array([0.1, time_s]))
