"""compile_loop (what make setup runs last) leaves nothing for a later process to compile.

Each check runs in fresh interpreters with numba's cache in a temporary directory: one runs
``python -m fishtail_plant.compiled``, the next does what the simulator node and
``fishtail-swim`` do, and what the synthesis' search tier does with the cycle kernels and the
engine's batch pass, and counts the compilations (numba's cache misses).
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import pytest

from fishtail_plant.fish import fused

pytestmark = [
    pytest.mark.skipif(not fused.loop_signatures(), reason="numba is not installed (or disabled)"),
    pytest.mark.slow,
]

#: The simulator node's follower (one fish, free), simulate() of one fish, of fish with a tail
#: each (a speed sweep), of fish sharing one tail, and a held fish: the loop's every use.
USES = textwrap.dedent(
    """
    import numpy as np
    from fishtail_kinematics.engine.geometry import OscillatoryGeometry, UndulatoryGeometry
    from fishtail_kinematics.engine.mechanisms import make_tail
    from fishtail_plant.fish import fused
    from fishtail_plant.fish.fish import FishParameters
    from fishtail_plant.fish.follower import SwimFollower
    from fishtail_plant.fish.integrator import simulate
    from fishtail_plant.fish.model import SwimModel
    from fishtail_plant.fish.tail_drive import EngineTailDrive, constant_carrier_speed

    print("cached before", fused.is_cached(), fused.is_cached("shared tail"))
    tail = make_tail(OscillatoryGeometry())
    follower = SwimFollower(tail, FishParameters(), 0.01, max_interval_s=0.5)
    follower.warm_up()
    follower.follow(0, 0.0, 0.0)
    for k in range(1, 50):
        follower.follow(k * 5_000_000, 4.0 * k * 0.005)
    assert follower.state[0, 0] != 0.0
    for geometry in (OscillatoryGeometry(), UndulatoryGeometry()):
        drive = EngineTailDrive(make_tail(geometry), constant_carrier_speed(np.array([4.0])))
        sweep = EngineTailDrive(make_tail(geometry), constant_carrier_speed(np.array([4.0, 8.0])))
        simulate(SwimModel(FishParameters(), drive), 1, 0.01, 20)
        simulate(SwimModel(FishParameters(), sweep), 2, 0.01, 20)
        simulate(SwimModel(FishParameters(), drive), 3, 0.01, 20)
        simulate(SwimModel(FishParameters(), drive, hold_sway_yaw=True), 1, 0.01, 20)
    print("compiled", fused.compiled_count())
    # The synthesis' cycle kernel, as its search tier calls it.
    from fishtail_kinematics.engine.drive_batch import OscillatoryBatch
    from fishtail_plant.fish import cycle_kernel

    print("kernel cached before", cycle_kernel.is_cached())
    batch = OscillatoryBatch(np.array([0.1, 0.05]), 0.1, 0.233926, 0.15, 0.2)
    assert cycle_kernel.held_cycles(batch, FishParameters(), np.ones(2), 64) is not None
    print("kernel compiled", sum(cycle_kernel._KERNEL.stats.cache_misses.values()))
    from fishtail_kinematics.engine import drive_pass

    batch.solve(np.linspace(0.0, 6.0, 64)[:, None], 1.0)  # the stroke's solve
    passes = drive_pass.compiled_pass()
    print("pass compiled", sum(sum(p.stats.cache_misses.values()) for p in passes))
    # Mechanism 2's loop kernels, as its search tier calls them.
    from fishtail_plant.fish import loop_kernel

    print("loop kernel cached before", loop_kernel.is_cached())
    drive = OscillatoryBatch(np.array([0.1, 0.05]), 0.1, 0.233926, 0.16, 0.2)
    lengths = [np.full(2, value) for value in (0.08, 0.24, 0.2, 0.06)]
    table, loop = loop_kernel.drive_table(drive), loop_kernel.loop_table(drive, *lengths)
    status, stroke = loop_kernel.follow_branches(table, loop, drive.assembles, 64)
    fish = cycle_kernel.design_table([getattr(FishParameters(), name)
                                for name in cycle_kernel.FISH_COLUMNS], 2)  # fmt: skip
    slider = stroke[loop_kernel.STROKE_FIELDS.index("slider_a_distance")]
    assert loop_kernel.held_loop_cycles(table, loop, slider, fish, np.ones(2), True, True,
                                        64) is not None  # fmt: skip
    kernels = (loop_kernel._FOLLOW, loop_kernel._KERNEL)
    print("loop kernels compiled", sum(sum(k.stats.cache_misses.values()) for k in kernels))
    """
)


def run(code_or_module: list[str], cache_dir) -> str:
    environment = {**os.environ, "NUMBA_CACHE_DIR": str(cache_dir)}
    completed = subprocess.run(
        [sys.executable, *code_or_module],
        env=environment,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    assert completed.returncode == 0, completed.stdout + completed.stderr
    return completed.stdout


def test_after_compile_loop_nothing_compiles(tmp_path):
    cache = tmp_path / "numba-cache"
    first = run(["-m", "fishtail_plant.compiled"], cache)
    assert first.startswith("compiling the swimming integrator (numba; cache "), first
    assert "took " in first and "(2 specialisations compiled, 0 loaded" in first, first
    uses = run(["-c", USES], cache)
    assert "cached before True True" in uses, uses
    assert "\ncompiled 0\n" in uses, uses
    assert "kernel cached before True" in uses, uses
    assert "kernel compiled 0" in uses, uses
    assert "pass compiled 0" in uses, uses
    assert "loop kernel cached before True" in uses, uses
    assert "loop kernels compiled 0" in uses, uses
    again = run(["-m", "fishtail_plant.compiled"], cache)
    assert again.startswith("loading the swimming integrator"), again
    assert "(0 specialisations compiled, 2 loaded from the cache)" in again, again
    assert "loading the cycle kernel ... took" in again and "(loaded from the cache)" in again
    assert "loading the engine's batch pass ... took" in again
    assert "loading the mechanism-2 loop kernel ... took" in again


def test_without_compile_loop_the_uses_compile(tmp_path):
    """The check above can fail: on an empty cache the same uses do compile."""
    uses = run(["-c", USES], tmp_path / "empty")
    assert "cached before False False" in uses, uses
    assert "\ncompiled 0\n" not in uses, uses
    assert "kernel cached before False" in uses, uses
    assert "kernel compiled 1" in uses, uses
    assert "pass compiled 1" in uses, uses
    assert "loop kernel cached before False" in uses, uses
    assert "loop kernels compiled 2" in uses, uses
