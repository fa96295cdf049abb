"""The fixed-step RK4 loop compiled: the model's formulas for one fish at a time, many steps a call.

The tail is solved ahead for a block of steps, so the loop over steps needs only the body's
equations, where numpy's per-call cost would dominate; numba compiles
:mod:`~fishtail_plant.fish.formulas` (the numpy model's own source) into one loop. Numba is
optional (:data:`AVAILABLE`); without it the integrator uses the numpy model. Costs, the cache
and the fallback: docs/swimming-dynamics.md ("Integrator").
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeAlias

import numpy as np
import numpy.typing as npt

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
    force_x, force_y, moment, _, _, _, _ = _tip_force(
        p[3], p[5], s[0], s[1], s[2], s[3], s[4], u, v, r
    )
    hull_x, hull_y, hull_z = _hull_force(p[6], p[7], p[8], p[9], p[10], p[11], p[12], u, v, r)
    plate_x, plate_y, plate_z, _ = _fin_drag(
        p[13], p[4], p[5], s[0], s[1], s[2], s[3], s[4], s[5], u, v, r
    )
    coupling_x, coupling_y, coupling_z = _coupling(p[0], p[1], u, v, r)
    direction_x, direction_y, direction_z, added_mass, rest_x, rest_y, rest_z = _fin_recoil(
        p[3], p[4], p[5], s[0], s[1], s[2], s[3], s[4], s[5], s[6], s[7], s[8], u, v, r
    )
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
