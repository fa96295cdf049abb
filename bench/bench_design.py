"""Synthesis throughput: both mechanisms' search tier, the engine's batch solve, sweeps, a run.

Prints figures only; targets: the search tier >= 20 000 designs/s of mechanism 1 and >= 5 000
of mechanism 2 on one core (a design: its linkage solved over a beat and its balance; compiled
kernels), the engine's batch solve <= 1.3x its transcendental floor (the cos/sin/sqrt/atan2/asin
calls on the same samples), a sweep on two Dask workers >= 1.7x one core. Then the time of a full
run of config/design/report-fish.yaml (the search, the verified front, the files). The problems
are config/design/report-fish.yaml and, for mechanism 2, report-fish-undulatory.yaml, 128 samples
a beat. Run with `make bench`; ``--quick``: fewer designs in the sweeps and no full run;
``--search-tier``: the search tier's lines only; ``--sweeps``: the sweeps' lines only.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import psutil

from fishtail_design.dask_executor import DaskExecutor
from fishtail_design.evaluation import evaluate_rows
from fishtail_design.executors import InProcessExecutor
from fishtail_design.linkages import OscillatoryLinkages
from fishtail_design.performance import performance
from fishtail_design.problem import Problem, read_problem
from fishtail_design.sweep import SweepResult, latin_hypercube, sweep
from fishtail_design.variables import CARRIER_SPEED, GEAR_RATIO, GEARBOX_EFFICIENCY
from fishtail_kinematics.engine.blocks import BLOCK_SAMPLES, block_slices
from fishtail_plant.fish import cycle_kernel
from fishtail_plant.motor.duty import MotorConstants
from measure import ROOT, TICKS_PER_S, best_of, pin_to_one_core, verdict

PROBLEM = ROOT / "config" / "design" / "report-fish.yaml"
UNDULATORY_PROBLEM = ROOT / "config" / "design" / "report-fish-undulatory.yaml"
POPULATION = 2000
SWEEP_DESIGNS = 1_000_000
QUICK_SWEEP_DESIGNS = 100_000
TARGET_DESIGNS_S = 20_000
TARGET_UNDULATORY_DESIGNS_S = 5_000
SWEEP_CHUNK = 16384
SWEEP_BATCH = 8192


def designs(problem: Problem, count: int, seed: int = 1) -> np.ndarray:
    """``count`` designs of the problem's space (the optimiser's rows), a Latin hypercube."""
    return latin_hypercube(problem.space, count, seed)


def search_tier_rate(problem: Problem, rows: np.ndarray, repeats: int = 5) -> float:
    """Designs per second of evaluate_rows (the search tier: stroke, performance, margins)."""
    evaluate_rows(problem, rows[:8])  # loads the compiled kernel, if any
    return rows.shape[0] / best_of(lambda: evaluate_rows(problem, rows), repeats)


def numpy_tier_rate(rows: int, problem: Path = PROBLEM) -> float:
    """The search tier's designs/s without the compiler (a process with NUMBA_DISABLE_JIT)."""
    environment = {**os.environ, "NUMBA_DISABLE_JIT": "1"}
    completed = subprocess.run(
        [sys.executable, __file__, "--numpy-tier", str(rows), str(problem)],
        env=environment, capture_output=True, text=True, check=True, timeout=1800,
    )  # fmt: skip
    return float(completed.stdout.split()[-1])


def performance_rates(problem: Problem, rows: np.ndarray) -> tuple[float, float, float]:
    """Designs/s of performance() compiled and by numpy, and their largest relative difference."""
    values = problem.space.decode(rows)
    linkages = OscillatoryLinkages(values)
    motor = MotorConstants.of(
        problem.motor.parameters(problem.motor.default_gear_ratio),
        values[GEAR_RATIO], values[GEARBOX_EFFICIENCY],
    )  # fmt: skip
    speed = values[CARRIER_SPEED]
    samples = problem.search.samples_per_beat

    def run(compiled: bool):
        return performance(linkages, problem.fish, motor, speed, samples, compiled=compiled)

    compiled_s = best_of(lambda: run(True), 5)
    numpy_s = best_of(lambda: run(False), 2)
    difference = 0.0
    for fast, slow in zip(run(True), run(False), strict=True):
        finite = np.isfinite(slow) & (slow != 0.0)
        if finite.any():
            relative = np.abs(np.asarray(fast)[finite] / slow[finite] - 1.0).max()
            difference = max(difference, float(relative))
    count = rows.shape[0]
    return count / compiled_s, count / numpy_s, difference


def floor_calls(angles: np.ndarray) -> Callable[[], None]:
    """The calls mechanism 1's solve must make on ``angles``, at their cheapest.

    cos and sin of the carrier angle, sqrt(OP² + OS²), atan2(OS, OP), asin K, sqrt(1 - K²) and
    atan2 for theta1, a block at a time into buffers that stay in the cache (as
    bench_kinematics.py measures the single tail's floor).
    """
    flat = angles.reshape(-1)
    a, b, c = np.empty(BLOCK_SAMPLES), np.empty(BLOCK_SAMPLES), np.empty(BLOCK_SAMPLES)
    ratio = np.linspace(-0.9, 0.9, BLOCK_SAMPLES)
    positive = np.linspace(0.01, 1.0, BLOCK_SAMPLES)

    def calls() -> None:
        for block in block_slices(flat.size):
            x, n = flat[block], block.stop - block.start
            np.cos(x, out=a[:n])
            np.sin(x, out=b[:n])
            np.sqrt(positive[:n], out=c[:n])
            np.arctan2(0.2, a[:n], out=c[:n])
            np.arcsin(ratio[:n], out=c[:n])
            np.sqrt(positive[:n], out=c[:n])
            np.arctan2(b[:n], a[:n], out=c[:n])

    return calls


def paired(first: Callable[[], object], second: Callable[[], object]) -> tuple[float, float]:
    """Best times of two functions timed in turn (the machine's load shifts between runs)."""
    times = [math.inf, math.inf]
    for _ in range(9):
        for index, function in enumerate((first, second)):
            times[index] = min(times[index], best_of(function, 1))
    return times[0], times[1]


def engine_against_floor(problem: Problem, rows: np.ndarray) -> None:
    """The engine's batch solve of the population over a beat, against its floor.

    The beat's angles shared by every linkage, (samples, 1), as the synthesis' stroke asks; then
    an angle of its own for every linkage and sample, (samples, N); compiled and by numpy. Each
    solve's result replaces the last (a steady pipeline: fresh arrays, memory reused). The floor
    counts every call on every angle, though shared angles need cos and sin once an angle.
    """
    batch = OscillatoryLinkages(problem.space.decode(rows)).batch
    samples = problem.search.samples_per_beat
    shared = (np.arange(samples) * (2.0 * math.pi / samples))[:, None]
    own = np.ascontiguousarray(np.broadcast_to(shared, (samples, batch.size)))
    floor = floor_calls(own)
    count = own.size
    print(
        f"engine batch solve, {batch.size} linkages x {samples} angles, against the "
        f"transcendental floor (cos, sin, 2 sqrt, 2 atan2, asin on every angle):"
    )
    kept: list[object] = [None]
    for compiled in (True, False):
        batch.compiled = compiled
        for name, angles in (("shared angles", shared), ("own angles", own)):

            def solve(angles: np.ndarray = angles) -> None:
                kept[0] = batch.solve(angles, 1.0)

            solve()
            floor_s, solve_s = paired(floor, solve)
            target = f" (target <= 1.3x: {verdict(solve_s <= 1.3 * floor_s)})" if compiled else ""
            print(
                f"  {'compiled' if compiled else 'numpy'}, {name}: "
                f"{solve_s / count * 1e9:.1f} ns/angle, floor {floor_s / count * 1e9:.1f} ns/angle:"
                f" {solve_s / floor_s:.2f}x{target}"
            )
    batch.compiled = True


def sweep_seconds(
    problem: Problem,
    count: int,
    executor: object,
    folder: Path,
    batch_size: int = SWEEP_BATCH,
    parts: bool = False,
    chunk_size: int = SWEEP_CHUNK,
    points: np.ndarray | None = None,
) -> tuple[float, SweepResult]:
    """Wall seconds of a sweep of ``count`` Latin-hypercube designs to Parquet.

    Chunks of :data:`SWEEP_CHUNK` designs in tasks of :data:`SWEEP_BATCH`: with the compiled
    kernel the default task of 64 designs takes a few milliseconds, less than a Dask task's own
    overhead, and two tasks a chunk keep two workers busy. Parquet: writing CSV costs as much
    as scoring. ``parts``: a folder of part files, each chunk a task that writes its own.
    Returns the seconds and what the sweep said. ``points``: the designs, if already made.
    """
    points = designs(problem, count, seed=2) if points is None else points
    started = time.perf_counter()
    path = folder / ("parts.parquet" if parts else "sweep.parquet")
    result = sweep(problem, points, path, executor,  # type: ignore[arg-type]
                   chunk_size=chunk_size, batch_size=batch_size, parts=parts)  # fmt: skip
    return time.perf_counter() - started, result


def machine_ticks() -> tuple[int, int, int]:
    """The machine's busy, idle and stolen CPU ticks since boot (/proc/stat's first line)."""
    fields = [int(value) for value in Path("/proc/stat").read_text().split("\n")[0].split()[1:]]
    idle = fields[3] + fields[4]  # idle, iowait
    steal = fields[7] if len(fields) > 7 else 0
    return sum(fields[:8]) - idle - steal, idle, steal


def process_cpu(processes: list[psutil.Process]) -> float:
    """CPU seconds (user + system) of ``processes`` so far (those that have ended: none)."""
    total = 0.0
    for process in processes:
        try:
            times = process.cpu_times()
        except psutil.Error:
            continue
        total += times.user + times.system
    return total


def cpu_split(run: Callable[[], object], workers: list[psutil.Process]) -> str:
    """Where the machine's CPU went while ``run`` ran: the workers, this process, the rest."""
    this = psutil.Process()
    before = (machine_ticks(), process_cpu(workers), process_cpu([this]), time.perf_counter())
    run()
    after = (machine_ticks(), process_cpu(workers), process_cpu([this]), time.perf_counter())
    wall = after[3] - before[3]
    busy, idle, steal = (
        (later - earlier) / TICKS_PER_S
        for later, earlier in zip(after[0], before[0], strict=True)
    )
    worker_s, client_s = after[1] - before[1], after[2] - before[2]
    cores = len(os.sched_getaffinity(0))
    return (
        f"{cores} cores x {wall:.1f} s = {cores * wall:.1f} core-s: the workers "
        f"{worker_s:.1f} (with their nannies), this process (client, scheduler) {client_s:.1f}, "
        f"other processes {busy - worker_s - client_s:.1f}, idle {idle:.1f}, stolen by the "
        f"hypervisor {steal:.1f}"
    )


def load() -> str:
    """The load averages (1, 5, 15 min), said with each figure: the machine is shared."""
    return "load average " + ", ".join(f"{value:.2f}" for value in os.getloadavg())


def sweeps(problem: Problem, count: int, all_cores: set[int]) -> None:
    """A sweep on one core in this process, then on a local Dask cluster of two workers.

    One core writes the single file (what a sweep writes by default); the two workers write
    their own parts (``--parts``: the client only hands out designs), and, for comparison, the
    single file through the client. The one-core sweep is timed before and after the cluster's,
    as the load of a shared machine drifts; the ratio is against the faster of the two.
    """
    with tempfile.TemporaryDirectory() as folder:
        evaluate_rows(problem, designs(problem, 8))
        print(f"sweep of {count:,} designs (Parquet, chunks of {SWEEP_CHUNK}), {load()}")
        one_s, _ = sweep_seconds(problem, count, InProcessExecutor(), Path(folder))
        print(f"  one core, the single file (tasks of {SWEEP_BATCH}): {one_s:.1f} s "
              f"({count / one_s:,.0f}/s), {load()}")  # fmt: skip
        chunks = math.ceil(count / SWEEP_CHUNK)
        parts_s, result = sweep_seconds(problem, count, InProcessExecutor(), Path(folder),
                                        parts=True)  # fmt: skip
        print(f"  one core, parts: {parts_s:.1f} s ({count / parts_s:,.0f}/s); per chunk "
              f"scoring {result.scoring_s / chunks:.3f} s, sweep_table + Parquet part "
              f"{result.writing_s / chunks:.3f} s, {load()}")  # fmt: skip
        try:
            os.sched_setaffinity(0, all_cores)  # the workers inherit this process's cores
        except (AttributeError, OSError):
            pass
        cores = len(os.sched_getaffinity(0))
        with DaskExecutor(workers=2) as executor:
            # A first small sweep in small tasks, so that both workers import fishtail and load
            # the compiled code before the timed one.
            sweep_seconds(problem, 512, executor, Path(folder), batch_size=64)
            sweep_seconds(problem, 512, executor, Path(folder), parts=True, chunk_size=64)
            workers = [child for child in psutil.Process().children(recursive=True)
                       if "resource_tracker" not in " ".join(child.cmdline())]  # fmt: skip
            timed: list[tuple[float, SweepResult]] = []
            points = designs(problem, count, seed=2)

            def parts_run() -> None:
                timed.append(sweep_seconds(problem, count, executor, Path(folder), parts=True,
                                           points=points))  # fmt: skip

            split = cpu_split(parts_run, workers)
            two_s, result = timed[0]
            print(f"  two Dask workers ({cores} cores allowed), parts written by the workers: "
                  f"{two_s:.1f} s ({count / two_s:,.0f}/s), {load()}")  # fmt: skip
            print(f"    CPU: {split}")
            busy = result.scoring_s + result.writing_s
            print(f"    per chunk of {SWEEP_CHUNK} (mean of {chunks}, in the task): scoring "
                  f"{result.scoring_s / chunks:.3f} s, sweep_table + Parquet part "
                  f"{result.writing_s / chunks:.3f} s, task CPU {result.task_cpu_s / chunks:.3f} "
                  f"s; the rest of 2 workers x wall (handing out, scheduling, waiting, other "
                  f"processes' load): {(2.0 * two_s - busy) / chunks:.3f} s")  # fmt: skip
            single_s, _ = sweep_seconds(problem, count, executor, Path(folder))
            print(f"  two Dask workers, the single file written by the client: "
                  f"{single_s:.1f} s ({count / single_s:,.0f}/s), {load()}")  # fmt: skip
        pin_to_one_core()
        again_s, _ = sweep_seconds(problem, count, InProcessExecutor(), Path(folder))
        print(f"  one core again: {again_s:.1f} s ({count / again_s:,.0f}/s), {load()}")
        one_s = min(one_s, again_s)
        print(
            f"  two Dask workers writing parts: {one_s / two_s:.2f}x one core "
            f"(target >= 1.7x: {verdict(one_s / two_s >= 1.7)})"
        )


def full_run() -> None:
    """fishtail-design on the report's problem, timed (search, verified front, files)."""
    with tempfile.TemporaryDirectory() as folder:
        started = time.perf_counter()
        completed = subprocess.run(
            ["fishtail-design", str(PROBLEM), "--output-dir", folder],
            capture_output=True, text=True, check=False, timeout=7200,
        )  # fmt: skip
        seconds = time.perf_counter() - started
        verified = Path(folder, "front.csv").is_file()
    if completed.returncode != 0:
        print(f"full run: fishtail-design failed ({completed.returncode}): "
              f"{completed.stderr.strip().splitlines()[-1:]}")  # fmt: skip
        return
    print(
        f"full run, fishtail-design {PROBLEM.relative_to(ROOT)} (population 100 x 50 "
        f"generations, the front verified{', front.csv written' if verified else ''}): "
        f"{seconds:.0f} s"
    )


def main() -> None:
    """Print the figures."""
    if sys.argv[1:2] == ["--numpy-tier"]:
        pin_to_one_core()
        problem = read_problem(Path(sys.argv[3]))
        print(search_tier_rate(problem, designs(problem, int(sys.argv[2])), repeats=2))
        return
    quick = "--quick" in sys.argv[1:]
    all_cores = os.sched_getaffinity(0)
    pinned = pin_to_one_core()
    problem = read_problem(PROBLEM)
    rows = designs(problem, POPULATION)
    print(
        f"design benchmark ({pinned}), {PROBLEM.relative_to(ROOT)}, population {POPULATION}, "
        f"{problem.search.samples_per_beat} samples a beat; compiled kernel: "
        f"{'yes' if cycle_kernel.kernel_signature() else 'no (numba missing)'}; "
        f"{os.environ.get('OPENBLAS_NUM_THREADS', 'default')} OpenBLAS threads"
    )
    if "--sweeps" in sys.argv[1:]:
        sweeps(problem, QUICK_SWEEP_DESIGNS if quick else SWEEP_DESIGNS, all_cores)
        return
    compiled_rate = search_tier_rate(problem, rows)
    numpy_rate = numpy_tier_rate(POPULATION)
    print(
        f"search tier (evaluate_rows), mechanism 1, one core: {compiled_rate:,.0f} designs/s "
        f"compiled, {numpy_rate:,.0f} designs/s numpy; {compiled_rate / numpy_rate:.0f}x "
        f"(target >= {TARGET_DESIGNS_S:,}/s: {verdict(compiled_rate >= TARGET_DESIGNS_S)})"
    )
    undulatory = read_problem(UNDULATORY_PROBLEM)
    undulatory_rows = designs(undulatory, POPULATION)
    compiled_rate = search_tier_rate(undulatory, undulatory_rows)
    numpy_rate = numpy_tier_rate(POPULATION, UNDULATORY_PROBLEM)
    print(
        f"search tier (evaluate_rows), mechanism 2, one core: {compiled_rate:,.0f} designs/s "
        f"compiled, {numpy_rate:,.0f} designs/s numpy; {compiled_rate / numpy_rate:.0f}x "
        f"(target >= {TARGET_UNDULATORY_DESIGNS_S:,}/s: "
        f"{verdict(compiled_rate >= TARGET_UNDULATORY_DESIGNS_S)})"
    )
    if "--search-tier" in sys.argv[1:]:
        return
    fast, slow, difference = performance_rates(problem, rows)
    print(
        f"performance() alone: {fast:,.0f} designs/s compiled, {slow:,.0f} numpy "
        f"({fast / slow:.0f}x); largest relative difference of a figure {difference:.1e}"
    )
    engine_against_floor(problem, rows)
    sweeps(problem, QUICK_SWEEP_DESIGNS if quick else SWEEP_DESIGNS, all_cores)
    if not quick:
        full_run()


if __name__ == "__main__":
    main()
