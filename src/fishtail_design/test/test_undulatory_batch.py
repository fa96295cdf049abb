"""Mechanism 2's population: the engine's exact poses, its verdict, and numpy against the kernel."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest

from fishtail_common.parameter_files import default_parameter_file, load_parameter_file
from fishtail_design.evaluation import evaluate_rows
from fishtail_design.problem import read_problem
from fishtail_design.sweep import latin_hypercube
from fishtail_design.undulatory_batch import BRANCH_SAMPLES, UndulatoryBatch
from fishtail_design.variables import LINKAGE_VARIABLES
from fishtail_kinematics.engine.errors import (
    AssemblyError,
    InvalidLengthError,
    PinOffsetError,
    SolverError,
)
from fishtail_kinematics.engine.geometry import UndulatoryGeometry, UndulatoryState
from fishtail_kinematics.engine.parameters import geometry_from_parameters, geometry_parameters_in
from fishtail_kinematics.engine.undulatory_tail import UndulatoryTail
from fishtail_plant.fish import loop_kernel
from fishtail_plant.fish.fish import FishParameters
from fishtail_plant.fish.loop_kernel import STROKE_FIELDS
from fishtail_plant.fish.tail_drive import (
    EngineTailDrive,
    LinkageBatchDrive,
    constant_carrier_speed,
)

PROBLEM = read_problem(default_parameter_file("design/report-fish-undulatory"))
NAMES = LINKAGE_VARIABLES["undulatory"]
#: The report's mechanism 2, as config/undulatory.yaml gives it.
REPORT = geometry_from_parameters(
    geometry_parameters_in(load_parameter_file(default_parameter_file("undulatory")))
)
HAND_PICKED = [
    REPORT,
    UndulatoryGeometry(pin_offset_m=0.05),
    UndulatoryGeometry(ring_radius_m=0.05, crank_link_m=0.06, rocker_link_m=0.16,
                       pivot_offset_m=0.15, swing_arm_m=0.12, slotted_link_m=0.2,
                       fin_link_m=0.25, fin_joint_offset_m=0.05, pin_offset_m=0.04),
]  # fmt: skip
ENGINE_REFUSALS = (AssemblyError, InvalidLengthError, PinOffsetError, SolverError)
compiled_only = pytest.mark.skipif(
    loop_kernel.kernel_signatures() is None, reason="numba is not installed (or disabled)"
)


def _designs(geometries: list[UndulatoryGeometry]) -> dict[str, np.ndarray]:
    return {name: np.array([getattr(g, name) for g in geometries]) for name in NAMES}


def _problem_designs(count: int, seed: int) -> dict[str, np.ndarray]:
    """Designs of the worked problem's space: about half do not assemble."""
    return PROBLEM.space.decode(latin_hypercube(PROBLEM.space, count, seed))


def test_the_hand_picked_designs_are_the_engine_s_exact_poses_at_any_angle_and_speed():
    batch = UndulatoryBatch(_designs(HAND_PICKED))
    rng = np.random.default_rng(1)
    angles = rng.uniform(-20.0, 20.0, (300, len(HAND_PICKED)))
    speeds = rng.uniform(-9.0, 9.0, angles.shape)
    state = batch.solve(angles, speeds)
    for index, geometry in enumerate(HAND_PICKED):
        engine = UndulatoryTail(geometry).solve(angles[:, index], speeds[:, index])
        for name in UndulatoryState._fields:
            want = np.asarray(getattr(engine, name))
            # Both close the loop to the engine's 1e-13 m; a rate scales with the speed.
            np.testing.assert_allclose(np.asarray(getattr(state, name))[:, index], want,
                                       rtol=1e-11, atol=1e-11, err_msg=name)  # fmt: skip


def test_the_branch_s_stroke_is_the_solve_s():
    batch = UndulatoryBatch(_problem_designs(80, seed=3))
    angles = np.arange(BRANCH_SAMPLES) * (2.0 * math.pi / BRANCH_SAMPLES)
    state = batch.solve(angles[:, None], 1.0)
    branch = batch.stroke_states(BRANCH_SAMPLES)
    built = batch.assembles
    assert 20 < built.sum() < 60
    for name in STROKE_FIELDS:
        got, want = branch[name], np.asarray(getattr(state, name))
        # 1e-13 m of closure, over VW's few centimetres for theta5.
        np.testing.assert_allclose(got[:, built], want[:, built], rtol=0, atol=1e-11, err_msg=name)
        # A design without a loop has no stroke at all, though its drive may assemble.
        assert np.isnan(got[:, ~built]).all()
    assert np.isnan(state.slider_a_distance[:, ~built]).all()


def test_random_designs_share_the_engine_s_verdict_and_drive():
    designs = _problem_designs(60, seed=4)
    batch = UndulatoryBatch(designs)
    speeds = np.linspace(3.0, 12.0, batch.size)
    times = (np.arange(32)[:, None] / 32) * (2.0 * math.pi / speeds)
    drive = LinkageBatchDrive(batch, constant_carrier_speed(speeds))
    sample = drive.sample(times)
    built = 0
    for index in range(batch.size):
        geometry = UndulatoryGeometry(**{name: float(designs[name][index]) for name in NAMES})
        try:
            tail = UndulatoryTail(geometry)
            tail.solve(np.arange(128) * (2.0 * math.pi / 128), 1.0)
        except ENGINE_REFUSALS as error:
            assert not batch.assembles[index], error
            assert batch.refusals[index] is not None
            assert np.isnan(sample.tip_y[:, index]).all()
            continue
        built += 1
        assert batch.assembles[index] and batch.refusals[index] is None
        alone = EngineTailDrive(tail, constant_carrier_speed(speeds[index])).sample(
            times[:, index]
        )
        for got, want in zip(sample, alone, strict=True):
            np.testing.assert_allclose(got[:, index], want, rtol=1e-11, atol=1e-11)
    assert 15 < built < 50


@compiled_only
@pytest.mark.parametrize("linear_damping", [0.0, 0.8])
def test_the_compiled_towing_is_the_numpy_path_s(linear_damping):
    from fishtail_design.linkages import UndulatoryLinkages
    from fishtail_design.performance import towed_cycles

    linkages = UndulatoryLinkages(_problem_designs(120, seed=5))
    fish = FishParameters(surge_linear_damping_kg_s=linear_damping)
    speeds = np.linspace(2.0, 14.0, linkages.size)
    compiled = towed_cycles(linkages, fish, speeds, 96, compiled=True)
    by_numpy = towed_cycles(linkages, fish, speeds, 96, compiled=False)
    for name, got, want in zip(compiled._fields, compiled, by_numpy, strict=True):
        want = np.asarray(want, dtype=float)
        np.testing.assert_array_equal(np.isnan(got), np.isnan(want), err_msg=name)
        finite = np.isfinite(want)
        scale = np.abs(want[finite]).max(initial=0.0)
        np.testing.assert_allclose(got[finite], want[finite], rtol=1e-9, atol=1e-12 * scale,
                                   err_msg=name)  # fmt: skip
    assert 40 < np.isfinite(compiled.speed_m_s).sum() < 100


_WITHOUT_NUMBA = """
import json, sys
import numpy as np
from fishtail_common.parameter_files import default_parameter_file
from fishtail_design.evaluation import evaluate_rows
from fishtail_design.problem import read_problem
from fishtail_plant.fish import loop_kernel
assert loop_kernel.kernel_signatures() is None
problem = read_problem(default_parameter_file("design/report-fish-undulatory"))
scores = evaluate_rows(problem, np.array(json.loads(sys.stdin.read())))
print(json.dumps([np.asarray(field).tolist() for field in scores]))
"""


@compiled_only
def test_without_numba_the_search_tier_gives_the_same_figures():
    rows = latin_hypercube(PROBLEM.space, 40, 6)
    completed = subprocess.run(
        [sys.executable, "-c", _WITHOUT_NUMBA], input=json.dumps(rows.tolist()),
        env={**os.environ, "NUMBA_DISABLE_JIT": "1"}, capture_output=True, text=True,
        timeout=600, check=True,
    )  # fmt: skip
    fallback = [np.array(field, dtype=float) for field in json.loads(completed.stdout)]
    for name, got, want in zip(("objectives", "margins", "figures"), evaluate_rows(PROBLEM, rows),
                               fallback, strict=True):  # fmt: skip
        np.testing.assert_array_equal(np.isnan(got), np.isnan(want), err_msg=name)
        np.testing.assert_array_equal(np.isinf(got), np.isinf(want), err_msg=name)
        finite = np.isfinite(want)
        np.testing.assert_allclose(got[finite], want[finite], rtol=1e-9, atol=1e-12,
                                   err_msg=name)  # fmt: skip
