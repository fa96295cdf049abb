"""The engine's tail drive: small batches (float path) and large ones (array path) agree."""

from __future__ import annotations

import numpy as np
import pytest

from fishtail_kinematics.engine.geometry import OscillatoryGeometry, UndulatoryGeometry
from fishtail_kinematics.engine.mechanisms import make_tail
from fishtail_plant.fish import tail_drive
from fishtail_plant.fish.tail_drive import EngineTailDrive, constant_carrier_speed


@pytest.mark.parametrize("geometry", [OscillatoryGeometry(), UndulatoryGeometry()])
def test_small_and_large_batches_give_the_same_tail(geometry: object) -> None:
    drive = EngineTailDrive(make_tail(geometry), constant_carrier_speed(np.array([3.0, 9.0])))
    many = np.linspace(0.0, 2.5, 4 * tail_drive._SCALAR_PATH_MAX)[:, None]
    few = many[:: len(many) // 4][:4]
    assert few.size * 2 <= tail_drive._SCALAR_PATH_MAX < many.size * 2
    small, large = drive.sample(few), drive.sample(many)
    for name, from_floats, from_arrays in zip(small._fields, small, large, strict=True):
        assert from_floats.shape == (4, 2), name
        np.testing.assert_allclose(
            from_floats, from_arrays[:: len(many) // 4][:4], rtol=1e-13, atol=1e-15, err_msg=name
        )
