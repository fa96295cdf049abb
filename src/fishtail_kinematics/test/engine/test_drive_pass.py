"""The batch solve's compiled pass against numpy's blocks and the single tail, field by field."""

import math

import numpy as np
import pytest

from fishtail_kinematics.engine import drive_pass
from fishtail_kinematics.engine.blocks import BLOCK_SAMPLES
from fishtail_kinematics.engine.drive_batch import OscillatoryBatch
from fishtail_kinematics.engine.geometry import OscillatoryGeometry
from fishtail_kinematics.engine.mechanisms import OscillatoryTail

pytestmark = pytest.mark.skipif(
    drive_pass.compiled_pass() is None, reason="numba is not installed (or disabled)"
)


def _batch(count: int, seed: int, phases: str = "zero", compiled: bool = True) -> OscillatoryBatch:
    rng = np.random.default_rng(seed)
    phase = {"zero": 0.0, "shared": 0.7, "own": rng.uniform(-1.0, 1.0, count)}[phases]
    batch = OscillatoryBatch(
        rng.uniform(0.02, 0.1, count), rng.uniform(0.02, 0.2, count),
        rng.uniform(0.05, 0.3, count), rng.uniform(0.08, 0.3, count),
        rng.uniform(0.05, 0.2, count), phase,
    )  # fmt: skip
    batch.compiled = compiled
    return batch


def _assert_same(compiled: tuple, numpy_result: tuple) -> None:
    (state, cos_fin, sin_fin), (expected, cos_expected, sin_expected) = compiled, numpy_result
    pairs = [*zip(state._fields, state, expected, strict=True), ("cos_fin", cos_fin, cos_expected),
             ("sin_fin", sin_fin, sin_expected)]  # fmt: skip
    for name, value, reference in pairs:
        value, reference = np.asarray(value), np.asarray(reference)
        assert value.shape == reference.shape, name
        np.testing.assert_array_equal(np.isnan(value), np.isnan(reference), err_msg=name)
        # The same operations in the same order: numpy's and libm's last bits apart.
        np.testing.assert_allclose(value, reference, rtol=1e-13, atol=1e-13, err_msg=name)


@pytest.mark.parametrize("phases", ["zero", "shared", "own"])
@pytest.mark.parametrize(
    "angles, speeds",
    [
        ((128, 1), 1.0),  # a beat's angles, every linkage (the synthesis' stroke)
        ((97, 400), (400,)),  # an angle and a speed of its own for each linkage and time
        ((400,), (1,)),  # one angle per linkage
        ((3, 50, 1), (3, 1, 1)),  # more leading axes
    ],
    ids=["shared angles", "own angles and speeds", "one row", "three axes"],
)
def test_the_compiled_pass_gives_numpys_numbers(phases, angles, speeds):
    rng = np.random.default_rng(7)
    phi = rng.uniform(-7.0, 7.0, angles)
    speed = speeds if isinstance(speeds, float) else rng.uniform(-5.0, 5.0, speeds)
    compiled = _batch(400, seed=1, phases=phases)
    reference = _batch(400, seed=1, phases=phases, compiled=False)
    assert 40 < compiled.assembles.sum() < 360  # NaN alike where a linkage does not assemble
    _assert_same(
        compiled.solve_with_tail_trig(phi, speed), reference.solve_with_tail_trig(phi, speed)
    )


def test_a_linkage_solves_to_the_same_bits_alone_and_in_any_batch():
    big = _batch(3 * BLOCK_SAMPLES // 128, seed=2)
    angles = (np.arange(128) * (2.0 * math.pi / 128))[:, None]
    everyone = big.solve(angles, 1.0)
    for index in (0, 5, big.size - 1):
        c = big.constants
        alone = OscillatoryBatch(
            c.ring_radius_m[index], c.crank_link_m[index], c.rocker_link_m[index],
            c.tail_link_m[index], c.pivot_offset_m[index],
        ).solve(angles, 1.0)  # fmt: skip
        for name, value, single in zip(everyone._fields, everyone, alone, strict=True):
            np.testing.assert_array_equal(np.asarray(value)[:, index], np.asarray(single)[:, 0],
                                          err_msg=name)  # fmt: skip


def test_the_compiled_batch_is_each_linkages_own_tail():
    geometries = [OscillatoryGeometry(), OscillatoryGeometry(0.05, 0.06, 0.16, 0.2, 0.15, 0.3)]
    batch = OscillatoryBatch(*(
        np.array([getattr(g, name) for g in geometries])
        for name in ("ring_radius_m", "crank_link_m", "rocker_link_m", "tail_link_m",
                     "pivot_offset_m", "phase_rad")
    ))  # fmt: skip
    angles = np.linspace(0.0, 2.0 * math.pi, 301)[:, None]
    state = batch.solve(angles, 3.0)
    for index, geometry in enumerate(geometries):
        own = OscillatoryTail(geometry).solve(angles[:, 0], 3.0)
        for name in own._fields:
            np.testing.assert_allclose(getattr(state, name)[:, index], getattr(own, name),
                                       rtol=0.0, atol=1e-13, err_msg=name)  # fmt: skip


def test_compile_pass_compiles_or_loads_the_pass_the_batch_uses():
    done = drive_pass.compile_pass()
    assert done is not None and done.seconds >= 0.0
    assert drive_pass.is_cached() in (True, None)
