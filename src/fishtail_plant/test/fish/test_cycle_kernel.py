"""The compiled cycle kernel against the numpy path it stands for, design by design."""

from __future__ import annotations

import math
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from fishtail_kinematics.engine.drive_batch import OscillatoryBatch
from fishtail_plant.errors import SwimParameterError
from fishtail_plant.fish import cycle_kernel
from fishtail_plant.fish.cycle_kernel import HeldCycles, held_cycles
from fishtail_plant.fish.figures import held_tail, steady_surge_speed
from fishtail_plant.fish.fish import FishParameters
from fishtail_plant.fish.tail_drive import LinkageBatchDrive, constant_carrier_speed

pytestmark = pytest.mark.skipif(
    cycle_kernel.kernel_signature() is None, reason="numba is not installed (or disabled)"
)


def _batch(count: int, seed: int, phase: bool = False) -> OscillatoryBatch:
    """Random linkages over the synthesis' ranges: some assemble, some do not."""
    rng = np.random.default_rng(seed)
    return OscillatoryBatch(
        rng.uniform(0.02, 0.1, count), rng.uniform(0.02, 0.2, count),
        rng.uniform(0.05, 0.3, count), rng.uniform(0.08, 0.3, count),
        rng.uniform(0.05, 0.2, count), rng.uniform(-1.0, 1.0, count) if phase else 0.0,
    )  # fmt: skip


def _numpy_path(
    batch: OscillatoryBatch, fish: FishParameters, speed: np.ndarray, samples: int
) -> HeldCycles:
    """What the kernel stands for: the balance and the towed tail, evaluated by numpy."""
    drive = LinkageBatchDrive(batch, constant_carrier_speed(speed))
    period = 2.0 * math.pi / speed
    balance = steady_surge_speed(drive, fish, period, samples, strict=False)
    times = np.arange(samples)[:, None] / samples * period
    towed = held_tail(drive, fish, times, balance)
    return HeldCycles(
        balance, towed.push_n.mean(axis=0), towed.power_w, np.ptp(towed.tail.tip_y, axis=0)
    )


def _assert_same(compiled: HeldCycles | None, expected: HeldCycles) -> None:
    assert compiled is not None
    for name, value, reference in zip(HeldCycles._fields, compiled, expected, strict=True):
        reference = np.asarray(reference, dtype=float)
        assert value.shape == reference.shape, name
        np.testing.assert_array_equal(np.isnan(value), np.isnan(reference), err_msg=name)
        finite = np.isfinite(reference)
        scale = np.abs(reference[finite]).max(initial=0.0)
        # Rounding only: the same formulas, summed in the same order; the balance's root to the
        # same 1e-12 of itself.
        np.testing.assert_allclose(
            value[finite], reference[finite], rtol=1e-9, atol=1e-12 * scale, err_msg=name
        )


def test_the_default_fish_at_unit_speed_as_the_search_tier_uses_it():
    batch = _batch(300, seed=1)
    assert 30 < batch.assembles.sum() < 270  # linkages that do not assemble give NaN
    speed = np.ones(batch.size)
    fish = FishParameters()
    _assert_same(held_cycles(batch, fish, speed, 128), _numpy_path(batch, fish, speed, 128))


def test_per_design_fish_speeds_and_phases():
    count = 120
    rng = np.random.default_rng(2)
    batch = _batch(count, seed=3, phase=True)
    # Every column the kernel reads varies; a few designs have no plate (C_n = 0) among the rest.
    fish = FishParameters(
        fin_chord_m=rng.uniform(0.0, 0.1, count),
        fin_normal_drag_coefficient=np.where(rng.uniform(size=count) < 0.2, 0.0, 1.2),
        fin_span_m=rng.uniform(0.05, 0.15, count),
        drag_coefficient=rng.uniform(0.1, 0.6, count),
        surge_linear_damping_kg_s=rng.uniform(0.0, 2.0, count),
        tail_origin_offset_m=rng.uniform(0.0, 0.1, count),
    )
    speed = rng.uniform(2.0, 15.0, count)
    _assert_same(held_cycles(batch, fish, speed, 96), _numpy_path(batch, fish, speed, 96))


@pytest.mark.parametrize(
    "changes",
    [{"fin_normal_drag_coefficient": 0.0}, {"fin_chord_m": 0.0}],
    ids=["no plate drag: the quadratic balance", "no chord: no plate, no recoil"],
)
def test_fish_without_a_plate_or_a_chord(changes):
    batch = _batch(80, seed=4)
    fish = FishParameters(**changes)
    speed = np.full(batch.size, 7.0)
    _assert_same(held_cycles(batch, fish, speed, 64), _numpy_path(batch, fish, speed, 64))


def test_a_carrier_speed_that_is_not_finite_is_refused_as_by_the_carrier():
    batch = _batch(3, seed=5)
    with pytest.raises(SwimParameterError):
        held_cycles(batch, FishParameters(), np.array([1.0, math.inf, 1.0]), 32)


def test_without_the_compiler_there_is_no_kernel(monkeypatch):
    monkeypatch.setattr(cycle_kernel, "kernel_signature", lambda: None)
    assert held_cycles(_batch(3, seed=6), FishParameters(), np.ones(3), 32) is None


#: A formula in one file, compiled into a cached function of another keyed to it.
_FORMULA = "def scale(x):\n    return {factor} * x\n"
_USER = textwrap.dedent(
    """
    import numba
    import formula
    from fishtail_common.compiled_cache import key_cache_to_sources

    _scale = numba.njit(formula.scale)

    @numba.njit(cache=True)
    def user(x):
        return _scale(x) + 1.0

    key_cache_to_sources(user, formula)
    print(user(1.0), sum(user.stats.cache_misses.values()))
    """
)


@pytest.mark.slow
def test_an_edited_formula_is_compiled_not_loaded_stale(tmp_path):
    (tmp_path / "user.py").write_text(_USER)
    environment = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}

    def run(factor: float) -> str:
        (tmp_path / "formula.py").write_text(_FORMULA.format(factor=factor))
        completed = subprocess.run(
            [sys.executable, "-c", "import user"], cwd=tmp_path, env=environment,
            capture_output=True, text=True, timeout=300, check=False,
        )  # fmt: skip
        assert completed.returncode == 0, completed.stderr
        return completed.stdout.strip()

    assert run(2.0) == "3.0 1"  # compiled, cached
    assert run(2.0) == "3.0 0"  # loaded
    # Another formula of the same size (numba alone would check only user.py's stamp).
    assert run(5.0) == "6.0 1"
