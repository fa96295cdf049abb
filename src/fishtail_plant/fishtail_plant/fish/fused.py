"""The fixed-step RK4 loop compiled: the model's formulas for one fish at a time, many steps a call.

The tail is solved ahead for a block of steps, so the loop over steps needs only the body's
equations, where numpy's per-call cost would dominate; numba compiles
:mod:`~fishtail_plant.fish.formulas` (the numpy model's own source) into one loop. Numba is
optional (:data:`AVAILABLE`); without it the integrator uses the numpy model. Costs, the cache
and the fallback: docs/swimming-dynamics.md ("Integrator").

Compiling takes seconds (tens on a busy machine); numba caches the result on disk, beside this
file (or under ``NUMBA_CACHE_DIR``), keyed to the source of the formulas as well as this file's
(:mod:`fishtail_common.compiled_cache`). :func:`compile_loop` compiles, or loads, every
specialisation the simulator node and ``fishtail-swim`` use: ``make setup`` runs it last
(``python -m fishtail_plant.compiled``, which prepares the suite's other compiled code too),
so that no later run waits for the compiler.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any, NamedTuple, TypeAlias

import numpy as np
import numpy.typing as npt

from fishtail_common.compiled_cache import key_cache_to_sources
from fishtail_plant.fish import formulas
from fishtail_plant.fish.fish import FloatArray
from fishtail_plant.fish.model import STATE_SIZE, SwimModel

try:
    import numba
except ImportError:  # pragma: no cover - exercised where numba is not installed
    AVAILABLE = False
else:
    #: Whether the compiled loop can be used.
    AVAILABLE = True

#: Columns of the per-fish parameter table the compiled loop reads.
PARAMETER_COLUMNS = (
    "surge_mass_kg", "sway_mass_kg", "yaw_inertia_kg_m2", "fin_added_mass_per_length_kg_m",
    "fin_chord_m", "tail_origin_offset_m", "drag_factor_kg_m", "lift_factor_kg_m",
    "yaw_damping_kg_m2", "surge_linear_damping_kg_s", "sway_linear_damping_kg_s",
    "sway_quadratic_damping_kg_m", "yaw_linear_damping_kg_m2_s", "fin_drag_factor_kg_m2",
)  # fmt: skip
#: Columns of a tail sample: the TailSample fields, then the TailAcceleration ones.
TAIL_COLUMNS = 9
#: Stage samples per block (times x fish): a few MB, so a block's tail stays in cache-sized
#: memory however long the run.
_SAMPLES_PER_BLOCK = 1 << 16


def parameter_table(model: SwimModel, fish_count: int) -> FloatArray:
    """The fish's derived parameters, one row per fish, in :data:`PARAMETER_COLUMNS` order."""
    table = np.empty((fish_count, len(PARAMETER_COLUMNS)))
    for column, name in enumerate(PARAMETER_COLUMNS):
        table[:, column] = np.broadcast_to(getattr(model.fish, name), (fish_count,))
    return table


def tail_samples(model: SwimModel, time_s: npt.ArrayLike, fish_count: int) -> FloatArray:
    """The tail of every fish at ``time_s`` (K,): shape (K, N, 9), accelerations 0 without chord.

    A tail motion the whole batch shares (one carrier speed and tail for fish that differ only in
    their bodies, the usual sweep) is solved once and broadcast: a read-only view with stride 0
    across the fish.
    """
    column_time = np.asarray(time_s, dtype=float).reshape(-1, 1)
    fields = list(model.drive.sample(column_time))
    if model.has_recoil:
        fields.extend(model.drive.acceleration(column_time))
    width = max(np.shape(values)[-1] for values in fields)
    samples = np.zeros((column_time.size, width, TAIL_COLUMNS))
    for column, values in enumerate(fields):
        samples[:, :, column] = values
    return np.broadcast_to(samples, (column_time.size, fish_count, TAIL_COLUMNS))


def block_steps(fish_count: int) -> int:
    """Steps per block: about :data:`_SAMPLES_PER_BLOCK` stage samples (2 per step and fish)."""
    return max(8, _SAMPLES_PER_BLOCK // (2 * fish_count))


Compiler: TypeAlias = Callable[[Callable[..., Any]], Callable[..., Any]]


def _identity(function: Callable[..., Any]) -> Callable[..., Any]:
    return function


# Module-level functions of module-level functions: what numba can cache on disk.
_jit: Compiler = numba.njit(cache=True, nogil=True) if AVAILABLE else _identity
_tip_force = _jit(formulas.tip_force)
_hull_force = _jit(formulas.hull_force)
_fin_recoil = _jit(formulas.fin_recoil)
_fin_drag = _jit(formulas.fin_drag)
_coupling = _jit(formulas.coupling)
_accelerations = _jit(formulas.accelerations)
_held_surge_acceleration = _jit(formulas.held_surge_acceleration)
_pose_rates = _jit(formulas.pose_rates)


@_jit
def _rates(p: Any, s: Any, y: Any, hold: bool, out: Any) -> None:
    # p: a row of parameter_table, s: a row of tail_samples, y: the state; out: its rates.
    u, v, r = y[3], y[4], y[5]
    cos_fin, sin_fin = np.cos(s[4]), np.sin(s[4])
    force_x, force_y, moment, _, _, _, _ = _tip_force(
        p[3], p[5], s[0], s[1], s[2], s[3], cos_fin, sin_fin, u, v, r
    )
    hull_x, hull_y, hull_z = _hull_force(p[6], p[7], p[8], p[9], p[10], p[11], p[12], u, v, r)
    plate_x, plate_y, plate_z, _ = _fin_drag(
        p[13], p[4], p[5], s[0], s[1], s[2], s[3], cos_fin, sin_fin, s[5], u, v, r
    )
    coupling_x, coupling_y, coupling_z = _coupling(p[0], p[1], u, v, r)
    direction_x, direction_y, direction_z, added_mass, rest_x, rest_y, rest_z = _fin_recoil(
        p[3], p[4], p[5], s[0], s[1], s[2], s[3], cos_fin, sin_fin, s[5], s[6], s[7], s[8],
        u, v, r,
    )  # fmt: skip
    # The sums in the numpy model's order; a chord or C_n of 0 adds exact zeros.
    total_x = coupling_x + force_x + hull_x + plate_x + rest_x
    total_y = coupling_y + force_y + hull_y + plate_y + rest_y
    total_z = coupling_z + moment + hull_z + plate_z + rest_z
    if hold:
        out[3] = _held_surge_acceleration(p[0], total_x, added_mass, direction_x)
        out[4] = 0.0
        out[5] = 0.0
    else:
        out[3], out[4], out[5] = _accelerations(
            p[0], p[1], p[2], total_x, total_y, total_z,
            added_mass, direction_x, direction_y, direction_z,
        )  # fmt: skip
    out[0], out[1], out[2] = _pose_rates(y[2], u, v, r)


@_jit
def _rk4_steps(
    state: Any, parameters: Any, tail: Any, step_s: float, steps: int, hold: bool,
    first_step: int, record_every: int, records: Any,
) -> None:  # fmt: skip
    half = 0.5 * step_s
    sixth = step_s / 6.0
    k1, k2, k3, k4 = np.empty(6), np.empty(6), np.empty(6), np.empty(6)
    stage = np.empty(6)
    for fish in range(state.shape[0]):
        p, y = parameters[fish], state[fish]
        for step in range(steps):
            start = 2 * step
            _rates(p, tail[start, fish], y, hold, k1)
            for i in range(6):
                stage[i] = y[i] + half * k1[i]
            _rates(p, tail[start + 1, fish], stage, hold, k2)
            for i in range(6):
                stage[i] = y[i] + half * k2[i]
            _rates(p, tail[start + 1, fish], stage, hold, k3)
            for i in range(6):
                stage[i] = y[i] + step_s * k3[i]
            _rates(p, tail[start + 2, fish], stage, hold, k4)
            for i in range(6):
                y[i] = y[i] + sixth * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i])
            done = first_step + step + 1
            if done % record_every == 0:
                records[done // record_every, fish, :] = y


def rk4_block(
    model: SwimModel,
    parameters: FloatArray,
    state: FloatArray,
    start_s: float,
    first_step: int,
    steps: int,
    step_s: float,
    record_every: int,
    records: FloatArray,
) -> None:
    """Advance ``state`` (N, 6) in place by ``steps`` RK4 steps from step ``first_step``.

    Step k runs from t = start_s + k h to start_s + (k + 1) h; the tail is solved for the block's
    2 steps + 1 stage times (t, t + h/2, t + h for each step) before the loop. After step j the
    state is written to ``records[j // record_every]`` whenever ``record_every`` divides j.
    """
    fish_count = state.shape[0]
    # Stage times from the step count (no accumulation): the same times the numpy loop uses.
    stage_index = np.arange(2 * first_step, 2 * (first_step + steps) + 1)
    stage_time_s = start_s + stage_index * (0.5 * step_s)
    tail = tail_samples(model, stage_time_s, fish_count)
    assert state.shape == (fish_count, STATE_SIZE)
    _rk4_steps(
        state, parameters, tail, step_s, steps, model.hold_sway_yaw,
        first_step, record_every, records,
    )  # fmt: skip


#: The compiled loop's numba dispatcher (the plain function without numba), for its cache.
_LOOP: Any = _rk4_steps
key_cache_to_sources(_LOOP, formulas)


def loop_signatures() -> dict[str, tuple[Any, ...]]:
    """The argument types :func:`rk4_block` calls the compiled loop with, by the batch they serve.

    ``one tail``: one fish (the simulator node, the follower) or fish with a tail each (a sweep
    over carrier speeds: ``fishtail-swim simulate``, ``steady --check``), where
    :func:`tail_samples` is C-contiguous. ``shared tail``: many fish on one tail motion (fits,
    turning tables), where it is broadcast with stride 0 (layout A). Both tails are read-only
    views, ``hold`` is a bool either way (held or free fish share a specialisation). Empty
    without numba (or with NUMBA_DISABLE_JIT set).
    """
    if not hasattr(_LOOP, "compile"):
        return {}
    from numba import types as numba_types

    types: Any = numba_types
    matrix = types.Array(types.float64, 2, "C")
    records = types.Array(types.float64, 3, "C")
    signatures = {}
    layouts = (("one tail", "C"), ("shared tail", "A"))
    for name, layout in layouts:
        tail = types.Array(types.float64, 3, layout, readonly=True)
        signatures[name] = (
            matrix, matrix, tail, types.float64, types.int64, types.boolean, types.int64,
            types.int64, records,
        )  # fmt: skip
    return signatures


def cache_path() -> str | None:
    """Where numba keeps the compiled loop (None without numba)."""
    return str(_LOOP.stats.cache_path) if hasattr(_LOOP, "stats") else None


def is_cached(batch: str = "one tail") -> bool | None:
    """Whether numba's cache holds a current compiled loop for ``batch`` (:func:`loop_signatures`).

    Read from numba's cache index without compiling or loading anything, so a caller can say
    beforehand whether preparing the loop will take a fraction of a second or many. None where
    it cannot tell (no numba, or a numba whose cache internals differ from 0.5x-0.6x).
    """
    if not loop_signatures():
        return None
    try:
        cache = _LOOP._cache
        key = cache._index_key(loop_signatures()[batch], _LOOP.targetctx.codegen())
        return key in cache._cache_file._load_index()
    except Exception:  # noqa: BLE001 - numba internals: unknown rather than wrong
        return None


def compiled_count() -> int:
    """How many specialisations of the loop this process compiled (not loaded from the cache)."""
    return sum(_LOOP.stats.cache_misses.values()) if hasattr(_LOOP, "stats") else 0


class LoopPreparation(NamedTuple):
    """What :func:`compile_loop` did: seconds taken, specialisations compiled and loaded."""

    seconds: float
    compiled: int
    loaded: int


def compile_loop(batches: tuple[str, ...] | None = None) -> LoopPreparation:
    """Compile, or load from numba's cache, the loop for ``batches`` (default: all of them).

    With a current cache this loads in well under a second; without one it compiles (about
    10 s a specialisation on an idle 2-core machine) and writes the cache for every later
    process. Nothing to do without numba.
    """
    started = time.monotonic()
    signatures = loop_signatures()
    if not signatures:
        return LoopPreparation(0.0, 0, 0)
    before = compiled_count()
    wanted = tuple(signatures) if batches is None else batches
    for name in wanted:
        _LOOP.compile(signatures[name])
    compiled = compiled_count() - before
    return LoopPreparation(time.monotonic() - started, compiled, len(wanted) - compiled)
