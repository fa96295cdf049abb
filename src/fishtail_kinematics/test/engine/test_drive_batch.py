import math

import numpy as np
import pytest

from fishtail_kinematics.engine.drive_batch import OscillatoryBatch
from fishtail_kinematics.engine.errors import AssemblyError
from fishtail_kinematics.engine.geometry import OscillatoryGeometry
from fishtail_kinematics.engine.mechanisms import OscillatoryTail
from fishtail_kinematics.engine.tail_base import assembly_margins, assembly_violations


def _random_lengths(count: int, seed: int) -> tuple[np.ndarray, ...]:
    rng = np.random.default_rng(seed)
    return (
        rng.uniform(0.05, 0.15, count), rng.uniform(0.03, 0.2, count),
        rng.uniform(0.05, 0.4, count), rng.uniform(0.05, 0.3, count),
        rng.uniform(0.05, 0.4, count), rng.uniform(-1.0, 1.0, count),
    )  # fmt: skip


def test_a_batch_solves_every_linkage_as_its_own_tail_does():
    lengths = _random_lengths(300, seed=3)
    batch = OscillatoryBatch(*lengths)
    angles = np.linspace(0.0, 2.0 * math.pi, 97)[:, None]
    state = batch.solve(angles, 2.5)
    solved = 0
    for index in range(batch.size):
        geometry = OscillatoryGeometry(*(float(values[index]) for values in lengths))
        try:
            tail = OscillatoryTail(geometry)
        except AssemblyError:
            assert not batch.assembles[index]
            assert np.isnan(batch.theta2_mid[index])
            continue
        assert batch.assembles[index]
        solved += 1
        one = tail.solve(angles[:, 0], 2.5)
        for field in one._fields:
            expected = np.asarray(getattr(one, field))
            assert np.allclose(getattr(state, field)[:, index], expected, rtol=0.0, atol=1e-13)
        for name in ("theta2_min", "theta2_max", "theta2_mid", "swing_range_rad"):
            assert getattr(batch, name)[index] == pytest.approx(getattr(tail, name), abs=1e-13)
    # The draw covers linkages that assemble and linkages that do not.
    assert 30 < solved < 270


def test_non_monotone_swings_find_their_inner_extreme():
    # theta2 turns back inside the stroke here, so an extreme is not at OP = +-R.
    tail = OscillatoryTail(OscillatoryGeometry(0.1, 0.15, 0.1, 0.15, 0.2))
    assert not tail.monotone
    batch = OscillatoryBatch(0.1, 0.15, 0.1, 0.15, 0.2)
    assert batch.swing_range_rad[0] == pytest.approx(tail.swing_range_rad, abs=1e-13)


def test_assembly_margins_have_the_sign_of_the_conditions():
    lengths = _random_lengths(500, seed=4)
    r, pr, rs, _, os_, _ = lengths
    inner, outer = assembly_margins(r, pr, rs, os_)
    for index in range(r.size):
        problems = assembly_violations(r[index], pr[index], rs[index], os_[index])
        assert (inner[index] > 0.0 and outer[index] > 0.0) == (not problems)
    # The margins are lengths: OS - |RS - PR| and RS + PR - |OS, R|.
    assert inner[0] == pytest.approx(os_[0] - abs(rs[0] - pr[0]))
    assert outer[0] == pytest.approx(rs[0] + pr[0] - math.hypot(os_[0], r[0]))
