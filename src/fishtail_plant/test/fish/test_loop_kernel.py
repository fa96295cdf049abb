"""The mechanism-2 loop kernel against the engine's exact poses and verdict, design by design."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fishtail_common.parameter_files import default_parameter_file, load_parameter_file
from fishtail_kinematics.engine.drive_batch import OscillatoryBatch
from fishtail_kinematics.engine.errors import (
    AssemblyError,
    InvalidLengthError,
    PinOffsetError,
    SolverError,
)
from fishtail_kinematics.engine.geometry import UndulatoryGeometry
from fishtail_kinematics.engine.parameters import geometry_from_parameters, geometry_parameters_in
from fishtail_kinematics.engine.undulatory_tail import UndulatoryTail
from fishtail_plant.fish import loop_kernel
from fishtail_plant.fish.fish import FishParameters
from fishtail_plant.fish.loop_kernel import STROKE_FIELDS, follow_branches

#: The report's mechanism 2, as config/undulatory.yaml gives it.
REPORT = geometry_from_parameters(
    geometry_parameters_in(load_parameter_file(default_parameter_file("undulatory")))
)
HAND_PICKED = [
    REPORT,
    UndulatoryGeometry(pin_offset_m=0.05),
    UndulatoryGeometry(pin_offset_m=0.01112),  # 20 µm from the fold: the loop's angle < 1.5°
    UndulatoryGeometry(ring_radius_m=0.05, crank_link_m=0.06, rocker_link_m=0.16,
                       pivot_offset_m=0.15, swing_arm_m=0.12, slotted_link_m=0.2,
                       fin_link_m=0.25, fin_joint_offset_m=0.05, pin_offset_m=0.04),
]  # fmt: skip
ENGINE_REFUSALS = (AssemblyError, InvalidLengthError, PinOffsetError, SolverError)
SAMPLES = 128
ANGLES = np.arange(SAMPLES) * (2.0 * math.pi / SAMPLES)
_BOUNDS = {
    "ring_radius_m": (0.02, 0.1), "crank_link_m": (0.02, 0.2), "pivot_offset_m": (0.05, 0.2),
    "swing_arm_m": (0.08, 0.24), "slotted_link_m": (0.05, 0.4), "fin_link_m": (0.1, 0.3),
    "fin_joint_offset_m": (0.01, 0.12), "pin_offset_m": (0.002, 0.15),
}  # fmt: skip

pytestmark = pytest.mark.skipif(
    loop_kernel.kernel_signatures() is None, reason="numba is not installed (or disabled)"
)


def _random(count: int, seed: int) -> list[UndulatoryGeometry]:
    """Designs over wide ranges, RS about the symmetric one: many the engine refuses."""
    rng = np.random.default_rng(seed)
    designs = []
    for _ in range(count):
        values = {name: float(rng.uniform(*bounds)) for name, bounds in _BOUNDS.items()}
        reach = values["pivot_offset_m"] * math.hypot(values["pivot_offset_m"],
                                                       values["ring_radius_m"])  # fmt: skip
        symmetric = math.sqrt(values["crank_link_m"] ** 2 + reach)
        designs.append(UndulatoryGeometry(**values,
                                          rocker_link_m=symmetric * rng.uniform(0.8, 1.2)))
    return designs


def _follow(geometries: list[UndulatoryGeometry]) -> tuple[np.ndarray, np.ndarray]:
    """The kernel's status and stroke of each geometry (the synthesis' tables)."""
    def lengths(name: str) -> np.ndarray:
        return np.array([getattr(g, name) for g in geometries])

    batch = OscillatoryBatch(lengths("ring_radius_m"), lengths("crank_link_m"),
                             lengths("rocker_link_m"), lengths("swing_arm_m"),
                             lengths("pivot_offset_m"))  # fmt: skip
    su, sw, vw = lengths("pin_offset_m"), lengths("swing_arm_m"), lengths("fin_joint_offset_m")
    av, vt = lengths("slotted_link_m"), lengths("fin_link_m")
    active = batch.assembles & (su > 0) & (su < sw - vw) & (vw < vt) & (av + vw > sw)
    table = loop_kernel.loop_table(batch, su, av, vt, vw)
    return follow_branches(loop_kernel.drive_table(batch), table, active, SAMPLES)


def _branch_slider(tail: UndulatoryTail, theta3: np.ndarray, step: float = 0.002) -> np.ndarray:
    """AS on the engine's branch at each SW angle, continued from the straight pose.

    The engine's sweep step (:meth:`UndulatoryTail._pose_on_branch`), at most ``step`` apart.
    """
    slider = np.empty_like(theta3)
    for sign in (-1.0, 1.0):
        a, reached = tail.straight_slider_a_distance, 0.0
        for index in np.argsort(sign * theta3):
            if sign * theta3[index] < 0.0:
                continue
            count = max(1, math.ceil(abs(theta3[index] - reached) / step))
            for angle in np.linspace(reached, theta3[index], count + 1)[1:]:
                a = tail._pose_on_branch(float(angle), a)
            reached, slider[index] = theta3[index], a
    return slider


def _engine(geometry: UndulatoryGeometry) -> UndulatoryTail | None:
    """The engine's tail as the synthesis built it: constructed and solved over a stroke."""
    try:
        tail = UndulatoryTail(geometry)
        tail.solve(ANGLES, 1.0)
    except ENGINE_REFUSALS:
        return None
    return tail


def test_the_hand_picked_designs_are_the_engine_s_exact_poses():
    status, stroke = _follow(HAND_PICKED)
    assert (status == loop_kernel.FOLLOWED).all()
    for index, geometry in enumerate(HAND_PICKED):
        engine = UndulatoryTail(geometry).solve(ANGLES, 1.0)
        for row, name in enumerate(STROKE_FIELDS):
            np.testing.assert_allclose(stroke[row, :, index], getattr(engine, name), rtol=0,
                                       atol=1e-11, err_msg=name)  # fmt: skip


def test_random_designs_follow_the_engine_s_branch_and_share_its_verdict():
    geometries = _random(150, seed=1)
    status, stroke = _follow(geometries)
    followed = status == loop_kernel.FOLLOWED
    built = np.array([_engine(g) is not None for g in geometries])
    assert 30 < built.sum() < 120
    np.testing.assert_array_equal(followed, built)
    slider = stroke[STROKE_FIELDS.index("slider_a_distance")]
    theta3 = stroke[STROKE_FIELDS.index("theta3")]
    for index in np.flatnonzero(followed)[:25]:
        tail = UndulatoryTail(geometries[index])
        reference = _branch_slider(tail, tail.solve(ANGLES, 1.0).theta3)
        np.testing.assert_allclose(theta3[:, index], tail.solve(ANGLES, 1.0).theta3, atol=1e-14)
        np.testing.assert_allclose(slider[:, index], reference, rtol=0, atol=1e-12)
    assert np.isnan(stroke[:, :, ~followed]).all()


def test_a_loop_that_folds_inside_the_swing_is_not_followed():
    # Past the fold Newton finds no root near the branch: the engine's sweep stops there too.
    folded = UndulatoryGeometry(pin_offset_m=0.0111)
    status, stroke = _follow([folded, REPORT])
    assert _engine(folded) is None
    assert status.tolist() == [loop_kernel.OPEN, loop_kernel.FOLLOWED]
    assert np.isnan(stroke[:, :, 0]).all() and np.isfinite(stroke[:, :, 1]).all()


def test_without_the_compiler_there_is_no_towing_kernel(monkeypatch):
    monkeypatch.setattr(loop_kernel, "kernel_signatures", lambda: None)
    table = np.zeros((1, len(loop_kernel.LOOP_COLUMNS)))
    fish = np.zeros((1, 6))
    assert loop_kernel.held_loop_cycles(np.zeros((1, 17)), table, np.zeros((SAMPLES, 1)), fish,
                                        np.ones(1), True, True, SAMPLES) is None  # fmt: skip
    assert FishParameters().has_fin_drag
