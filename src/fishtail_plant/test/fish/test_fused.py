"""The compiled RK4 loop against the numpy model's, step for step."""

from __future__ import annotations

import numpy as np
import pytest

from fishtail_kinematics.engine.geometry import OscillatoryGeometry, UndulatoryGeometry
from fishtail_kinematics.engine.mechanisms import make_tail
from fishtail_plant.errors import SwimInputError
from fishtail_plant.fish import fused
from fishtail_plant.fish.fish import FishParameters
from fishtail_plant.fish.integrator import rk4_step, simulate
from fishtail_plant.fish.model import SwimModel
from fishtail_plant.fish.tail_drive import (
    EngineTailDrive,
    SinusoidalTailDrive,
    TailDrive,
    constant_carrier_speed,
)

pytestmark = pytest.mark.skipif(not fused.AVAILABLE, reason="numba is not installed")

STEP_S = 4e-3
STEPS = 500
SPEEDS = np.array([4.0, 7.0, 11.0])


def _numpy_loop(model: SwimModel, fish_count: int, steps: int) -> np.ndarray:
    state = np.zeros((fish_count, 6))
    for step in range(steps):
        state = rk4_step(model.derivatives, step * STEP_S, state, STEP_S)
    return state


def _drives() -> list[tuple[str, TailDrive]]:
    carrier = constant_carrier_speed(SPEEDS)
    return [
        ("mechanism 1", EngineTailDrive(make_tail(OscillatoryGeometry()), carrier)),
        ("mechanism 2", EngineTailDrive(make_tail(UndulatoryGeometry()), carrier)),
        ("sinusoid", SinusoidalTailDrive(0.2, np.array([0.0, 0.1, -0.2]), 0.4, SPEEDS)),
    ]


# Ids from the names alone: a drive's repr has its address, which differs between the processes
# of a parallel run (pytest-xdist), which must all collect the same ids.
@pytest.mark.parametrize("name, drive", _drives(), ids=["mechanism 1", "mechanism 2", "sinusoid"])
@pytest.mark.parametrize("chord_m", [0.0, 0.04])
@pytest.mark.parametrize("hold_sway_yaw", [False, True])
def test_compiled_loop_matches_the_numpy_model(
    name: str, drive: TailDrive, chord_m: float, hold_sway_yaw: bool
) -> None:
    # Three different fish in one batch: per-fish parameters must reach the right rows.
    fish = FishParameters(
        drag_coefficient=np.array([0.2, 0.3, 0.6]),
        yaw_damping_kg_m2=np.array([0.5, 1.0, 2.0]),
        fin_chord_m=chord_m,
        # Fossen's linear terms and the plate's drag, per fish, so every column is read.
        surge_linear_damping_kg_s=np.array([0.0, 1.0, 2.0]),
        sway_linear_damping_kg_s=np.array([0.5, 0.0, 1.0]),
        sway_quadratic_damping_kg_m=np.array([0.0, 3.0, 1.0]),
        yaw_linear_damping_kg_m2_s=np.array([0.02, 0.0, 0.05]),
        fin_normal_drag_coefficient=np.array([1.2, 0.0, 2.0]),
    )
    model = SwimModel(fish, drive, hold_sway_yaw=hold_sway_yaw)
    compiled = simulate(model, 3, STEP_S, STEPS).state[-1]
    reference = _numpy_loop(model, 3, STEPS)
    scale = np.abs(reference).max(axis=0)
    # Only the rounding of sin/cos (libm against numpy's) and of the stage times differ.
    np.testing.assert_allclose(compiled, reference, rtol=0, atol=1e-11 * scale.max())
    assert np.abs(reference[:, 3]).min() > 0.01, f"{name}: the fish did not swim"
    if hold_sway_yaw:
        assert np.all(compiled[:, 4:] == 0.0)


def test_without_numba_the_numpy_loop_gives_the_same_run(monkeypatch: pytest.MonkeyPatch) -> None:
    model = SwimModel(FishParameters(), _drives()[0][1])
    compiled = simulate(model, 3, STEP_S, 200, record_every=50)
    monkeypatch.setattr(fused, "AVAILABLE", False)
    fallback = simulate(model, 3, STEP_S, 200, record_every=50)
    np.testing.assert_array_equal(compiled.time_s, fallback.time_s)
    # The default fish's fin has a chord: its recoil needs the tail's accelerations, central
    # differences over 1e-4 rad of the engine's rates, which magnify the rounding of the
    # engine's float and array paths some 5000-fold. The compiled-loop test's bound, then.
    scale = np.abs(fallback.state).max()
    np.testing.assert_allclose(compiled.state, fallback.state, rtol=0, atol=1e-11 * scale)


def test_blocks_and_records_do_not_change_the_run(monkeypatch: pytest.MonkeyPatch) -> None:
    model = SwimModel(FishParameters(), _drives()[1][1])
    whole = simulate(model, 3, STEP_S, 300)
    # Blocks of 10 steps: 30 engine batches, stage times from the step count in each.
    monkeypatch.setattr(fused, "_SAMPLES_PER_BLOCK", 60)
    assert fused.block_steps(3) == 10
    reported: list[int] = []
    blocked = simulate(model, 3, STEP_S, 300, record_every=7, progress=reported.append)
    np.testing.assert_array_equal(blocked.state, whole.state[::7])
    np.testing.assert_array_equal(blocked.time_s, whole.time_s[::7])
    assert reported == list(range(10, 301, 10))


def test_a_diverging_run_is_refused() -> None:
    # A 1 s step at a carrier speed of 2000 rad/s skips hundreds of beats per step.
    drive = EngineTailDrive(make_tail(OscillatoryGeometry()), constant_carrier_speed(2000.0))
    model = SwimModel(FishParameters(body_mass_kg=1e-3, added_mass_surge_kg=0.0), drive)
    with pytest.raises(SwimInputError, match="diverged"):
        simulate(model, 1, 1.0, 400)


def test_a_tail_shared_by_the_batch_is_solved_once_and_reaches_every_fish() -> None:
    # One carrier speed: the engine's samples have one column, broadcast to the three fish.
    drive = EngineTailDrive(make_tail(UndulatoryGeometry()), constant_carrier_speed(6.0))
    model = SwimModel(FishParameters(drag_coefficient=np.array([0.2, 0.3, 0.6])), drive)
    assert fused.tail_samples(model, np.arange(5) * STEP_S, 3).strides[1] == 0
    compiled = simulate(model, 3, STEP_S, 300).state[-1]
    reference = _numpy_loop(model, 3, 300)
    np.testing.assert_allclose(compiled, reference, rtol=0, atol=1e-11 * np.abs(reference).max())
    assert compiled[0, 3] > compiled[1, 3] > compiled[2, 3] > 0.0  # less drag, faster
