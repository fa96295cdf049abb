"""Mechanism-2 linkages over one beat, compiled: the second loop's branch and the towed tail.

The engine builds one mechanism-2 tail at a time (a continuation sweep of 2001 poses that
seeds its solve, some 9 ms). A synthesis asks the same of thousands of designs, so here numba
compiles, into loops over the designs, the engine's own scalar formulas: the drive's pose
(:func:`~fishtail_kinematics.engine.oscillatory_tail.drive_pose`) and the second loop's Newton
closure, rates and tip (:mod:`~fishtail_kinematics.engine.loop_pose`), to the engine's
tolerance. :func:`follow_branches` follows each design's loop from the straight pose, as the
engine's sweep does, over SW's swing and then to every sample of the beat, and says where it
cannot (a toggle, the pin U out of its slot, the slider A past S, a loop that does not close);
:func:`held_loop_cycles` tows each design at its balance speed over a beat as
:func:`~fishtail_plant.fish.cycle_kernel.held_cycles` does mechanism 1's (its balance and towing
compiled into the same kernel). docs/design.md ("Mechanism 2").

Numba is optional (:data:`~fishtail_plant.fish.fused.AVAILABLE`): without it (or with
NUMBA_DISABLE_JIT) :func:`follow_branches` runs the same code in Python and
:func:`held_loop_cycles` returns None (the caller tows through numpy).
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np
import numpy.typing as npt

from fishtail_common.compiled_cache import key_cache_to_sources
from fishtail_kinematics.engine import loop_pose, oscillatory_tail
from fishtail_kinematics.engine.drive_batch import OscillatoryBatch
from fishtail_kinematics.engine.loop_pose import (
    loop_closure,
    loop_rates,
    loop_tip,
    residual_tolerance,
)
from fishtail_kinematics.engine.oscillatory_tail import drive_coefficients
from fishtail_plant.fish import cycle_kernel, figures, formulas, tail_drive
from fishtail_plant.fish.cycle_kernel import (
    TIP_ROWS,
    HeldCycles,
    KernelPreparation,
    balance_speed,
    compiled_drive_pose,
    mean_in_order,
    towed_tail,
)
from fishtail_plant.fish.fish import FloatArray
from fishtail_plant.fish.fused import AVAILABLE, Compiler, _identity

if AVAILABLE:
    import numba

#: Columns of the loop table (one row per design): the loop's lengths, S's distance from O, AS
#: of the straight pose, the squared residual's tolerance and SW's extreme angles from the axis.
LOOP_COLUMNS = (
    "pin_offset_m", "swing_arm_m", "slotted_link_m", "fin_joint_offset_m", "fin_tail_m",
    "pivot_offset_m", "straight_slider_m", "tolerance", "theta3_low", "theta3_high",
)  # fmt: skip
#: What :func:`follow_branches` gives of each sample of the beat (UndulatoryState's names).
STROKE_FIELDS = (
    "slider_position", "theta1", "theta2", "theta3", "theta4", "theta5", "pin_u_distance",
    "slider_a_distance", "tip_y",
)  # fmt: skip
#: Nodes of the branch on each side of the straight pose (the engine's sweep has 1000 a side).
BRANCH_NODES = 64
#: What :func:`follow_branches` says of each design.
FOLLOWED, NOT_FOLLOWED, TOGGLE, PIN_OUT_OF_SLOT, SLIDER_PAST_S, OPEN = range(6)
#: The engine's toggle test: the loop's slope in AS at most this [m] (its sweep's).
_TOGGLE_SLOPE = 1e-9
_ANGLE_STEP_RAD = tail_drive._ANGLE_STEP_RAD
_TWO_PI = 2.0 * math.pi

_formula: Compiler = numba.njit(nogil=True, error_model="numpy") if AVAILABLE else _identity
_kernel_jit: Compiler = (
    numba.njit(cache=True, nogil=True, error_model="numpy") if AVAILABLE else _identity
)
_loop_closure = _formula(loop_closure)
_loop_rates = _formula(loop_rates)
_loop_tip = _formula(loop_tip)


def drive_table(batch: OscillatoryBatch) -> FloatArray:
    """The drive's coefficient table (:data:`cycle_kernel.LINKAGE_COLUMNS`), a row per design."""
    c = batch.constants
    return cycle_kernel.design_table([*drive_coefficients(c), c.phase_rad], batch.size)


def loop_table(
    batch: OscillatoryBatch, pin_offset_m: FloatArray, slotted_link_m: FloatArray,
    fin_link_m: FloatArray, fin_joint_offset_m: FloatArray,
) -> FloatArray:  # fmt: skip
    """The loop table (:data:`LOOP_COLUMNS`) of the drive ``batch`` (SW its tail link)."""
    c, vw = batch.constants, fin_joint_offset_m
    return cycle_kernel.design_table([
        pin_offset_m, c.tail_link_m, slotted_link_m, vw, np.asarray(fin_link_m) - vw,
        c.pivot_offset_m, np.asarray(slotted_link_m) + vw - c.tail_link_m,
        residual_tolerance(np.asarray(vw, dtype=float)), batch.theta2_min - batch.theta2_mid,
        batch.theta2_max - batch.theta2_mid,
    ], batch.size)  # fmt: skip


@_formula
def _close(loop: Any, a: float, cos3: float, sin3: float) -> Any:
    """The loop closed at SW's angle (cos, sin) from the seed AS ``a``: the engine's closure."""
    su, sw, vw = loop[0], loop[1], loop[3]
    return _loop_closure(a, su * cos3, su * sin3, sw * cos3, sw * sin3, loop[2], vw * vw, loop[7])


@_formula
def _verdict(loop: Any, closure: Any, sign: float) -> int:
    """What a closed pose says of the branch: FOLLOWED or why the engine would refuse it."""
    a, au, slope, closed = closure[0], closure[1], closure[7], closure[8]
    if not closed:
        return OPEN
    if not (abs(slope) > _TOGGLE_SLOPE and slope * sign > 0.0):
        return TOGGLE
    if not (au > 0.0 and au < loop[2]):
        return PIN_OUT_OF_SLOT
    if not a > 0.0:
        return SLIDER_PAST_S
    return FOLLOWED


@_formula
def _follow(drive: Any, loop: Any, nodes: Any, stroke: Any) -> int:
    """One design's branch: SW's swing from the straight pose, then the beat's samples.

    ``nodes`` (2, BRANCH_NODES + 1) receives AS at the swing's nodes (each side from 0 to its
    extreme); ``stroke`` (STROKE_FIELDS, samples) the beat's samples at unit carrier speed.
    """
    straight = _close(loop, loop[6], 1.0, 0.0)
    sign = 1.0 if straight[7] > 0.0 else -1.0
    verdict: int = _verdict(loop, straight, sign)
    if verdict != FOLLOWED:
        return verdict
    for side in range(2):
        extreme = loop[8 + side]
        nodes[side, 0] = straight[0]
        for j in range(1, BRANCH_NODES + 1):
            angle = extreme * (j / BRANCH_NODES)
            closure = _close(loop, nodes[side, j - 1], math.cos(angle), math.sin(angle))
            verdict = _verdict(loop, closure, sign)
            if verdict != FOLLOWED:
                return verdict
            nodes[side, j] = closure[0]
    samples = stroke.shape[1]
    step = _TWO_PI / samples
    for k in range(samples):
        carrier = k * step + drive[16]
        pose = compiled_drive_pose(
            math.cos(carrier), math.sin(carrier), 1.0, drive[0], drive[1], drive[2], drive[3],
            drive[4], drive[5], drive[6], drive[7], drive[8], drive[9], drive[10], drive[11],
            drive[12], drive[13], drive[14], drive[15],
        )  # fmt: skip
        angle = pose[11]
        side = 0 if angle < 0.0 else 1
        extreme = loop[8 + side]
        index = round(angle / extreme * BRANCH_NODES) if extreme != 0.0 else 0
        seed = nodes[side, min(max(index, 0), BRANCH_NODES)]
        cos3, sin3 = pose[12], pose[13]
        closure = _close(loop, seed, cos3, sin3)
        verdict = _verdict(loop, closure, sign)
        if verdict != FOLLOWED:
            return verdict
        cos5, sin5 = closure[4] / loop[3], closure[5] / loop[3]
        tip = _loop_tip(loop[5], loop[1], loop[4], cos3, sin3, cos5, sin5, 0.0, 0.0)
        stroke[0, k], stroke[1, k], stroke[2, k], stroke[3, k] = pose[0], pose[2], pose[4], pose[6]
        stroke[4, k] = math.atan2(closure[3], closure[2])
        stroke[5, k] = math.atan2(sin5, cos5)
        stroke[6, k], stroke[7, k], stroke[8, k] = closure[1], closure[0], tip[1]
    return FOLLOWED


@_kernel_jit
def _follow_all(drive: Any, loop: Any, active: Any, status: Any, stroke: Any) -> None:
    nodes = np.empty((2, BRANCH_NODES + 1))
    rows, samples = stroke.shape[0], stroke.shape[1]
    column = np.empty((rows, samples))
    for design in range(drive.shape[0]):
        if not active[design]:
            status[design] = NOT_FOLLOWED
            continue
        status[design] = _follow(drive[design], loop[design], nodes, column)
        if status[design] == FOLLOWED:
            for row in range(rows):
                for k in range(samples):
                    stroke[row, k, design] = column[row, k]


def follow_branches(
    drive: FloatArray, loop: FloatArray, active: npt.NDArray[np.bool_], samples: int
) -> tuple[npt.NDArray[np.int64], FloatArray]:
    """Each design's loop followed from the straight pose over its swing and a beat.

    ``drive``: the drive's coefficient table (:func:`drive_table`), ``loop``: the loop table
    (:func:`loop_table`), ``active``: the designs whose drive assembles and whose loop's
    closed-form conditions hold. Returns the status of each design (FOLLOWED, or the first
    condition that fails) and the :data:`STROKE_FIELDS` at the carrier angles
    ``k 2 pi / samples`` at unit speed, shape (fields, samples, N), NaN where not FOLLOWED.
    """
    count = drive.shape[0]
    status = np.empty(count, dtype=np.int64)
    stroke: FloatArray = np.full((len(STROKE_FIELDS), samples, count), np.nan)
    drive, loop = np.ascontiguousarray(drive), np.ascontiguousarray(loop)
    active = np.ascontiguousarray(active, dtype=np.bool_)
    if kernel_signatures() is not None:
        _FOLLOW(drive, loop, active, status, stroke)
        return status, stroke
    # In Python a division by zero raises where compiled code gives NaN: such a design's loop
    # does not close.
    for design in range(count):
        rows = slice(design, design + 1)
        try:
            _FOLLOW(drive[rows], loop[rows], active[rows], status[rows], stroke[:, :, rows])
        except (ZeroDivisionError, ValueError):
            status[design] = OPEN
            stroke[:, :, design] = np.nan
    return status, stroke


@_formula
def _loop_sample(drive: Any, loop: Any, cos_carrier: float, sin_carrier: float, omega: float,
                 seed: float) -> Any:  # fmt: skip
    """The tip's x, y, x_dot, y_dot, cos and sin theta5, theta5_dot, and whether it closed."""
    pose = compiled_drive_pose(
        cos_carrier, sin_carrier, omega, drive[0], drive[1], drive[2], drive[3], drive[4],
        drive[5], drive[6], drive[7], drive[8], drive[9], drive[10], drive[11], drive[12],
        drive[13], drive[14], drive[15],
    )  # fmt: skip
    cos3, sin3 = pose[12], pose[13]
    a, au, cos4, sin4, ex, ey, _, _, closed = _close(loop, seed, cos3, sin3)
    vw = loop[3]
    cos5, sin5 = ex / vw, ey / vw
    rates = _loop_rates(pose[5], cos3, sin3, cos4, sin4, cos5, sin5, au, loop[0], loop[1],
                        loop[2], vw)  # fmt: skip
    tip = _loop_tip(loop[5], loop[1], loop[4], cos3, sin3, cos5, sin5, pose[5], rates[3])
    return tip[0], tip[1], tip[2], tip[3], cos5, sin5, rates[3], closed


@_formula
def _loop_beat(drive: Any, loop: Any, slider: Any, omega: float, cos_carrier: Any,
               sin_carrier: Any, seeds: Any, has_chord: bool, tip: Any) -> bool:  # fmt: skip
    """The design at each sample into ``tip`` (cycle_kernel's rows); False where one is open.

    ``seeds``: the index of the branch's sample nearest each sample's carrier angle.
    """
    cos_step, sin_step = math.cos(_ANGLE_STEP_RAD), math.sin(_ANGLE_STEP_RAD)
    scale = 0.5 / _ANGLE_STEP_RAD
    squared = omega**2
    for k in range(tip.shape[1]):
        cos_k, sin_k, seed = cos_carrier[k], sin_carrier[k], slider[seeds[k]]
        here = _loop_sample(drive, loop, cos_k, sin_k, omega, seed)
        if not here[7]:
            return False
        tip[0, k], tip[1, k], tip[2, k], tip[3, k] = here[0], here[1], here[2], here[3]
        tip[4, k], tip[5, k], tip[6, k] = here[4], here[5], here[6]
        if not has_chord:
            tip[7, k] = tip[8, k] = tip[9, k] = 0.0
            continue
        ahead = _loop_sample(drive, loop, cos_k * cos_step - sin_k * sin_step,
                             sin_k * cos_step + cos_k * sin_step, 1.0, seed)  # fmt: skip
        behind = _loop_sample(drive, loop, cos_k * cos_step + sin_k * sin_step,
                              sin_k * cos_step - cos_k * sin_step, 1.0, seed)  # fmt: skip
        if not (ahead[7] and behind[7]):
            return False
        tip[7, k] = (ahead[2] - behind[2]) * scale * squared
        tip[8, k] = (ahead[3] - behind[3]) * scale * squared
        tip[9, k] = (ahead[6] - behind[6]) * scale * squared
    return True


@_kernel_jit
def _held_loop_cycles(
    drive: Any, loop: Any, slider: Any, fish: Any, carrier_speed: Any, has_plate: bool,
    has_chord: bool, balance: Any, push: Any, power: Any, excursion: Any,
) -> None:  # fmt: skip
    samples, branch = power.shape[0], slider.shape[0]
    tip = np.empty((TIP_ROWS, samples))
    cos_carrier, sin_carrier = np.empty(samples), np.empty(samples)
    seeds = np.empty(samples, dtype=np.int64)
    forces, loads = np.empty(samples), np.empty(samples)
    for design in range(drive.shape[0]):
        c, f, omega = drive[design], fish[design], carrier_speed[design]
        # The samples' carrier angles as constant_carrier_speed makes them.
        period = _TWO_PI / omega
        for k in range(samples):
            motor = omega * (k / samples * period)
            carrier = motor + c[16]
            cos_carrier[k], sin_carrier[k] = math.cos(carrier), math.sin(carrier)
            # The branch's sample nearest in the carrier's angle seeds the closure.
            nearest = round((motor % _TWO_PI) / _TWO_PI * branch) if motor == motor else 0
            seeds[k] = nearest % branch
        closed = slider[0, design] == slider[0, design] and _loop_beat(
            c, loop[design], slider[:, design], omega, cos_carrier, sin_carrier, seeds,
            has_chord, tip,
        )  # fmt: skip
        if not closed:
            balance[design] = push[design] = excursion[design] = math.nan
            power[:, design] = math.nan
            continue
        lowest, highest = tip[1, 0], tip[1, 0]
        for k in range(1, samples):
            lowest, highest = min(lowest, tip[1, k]), max(highest, tip[1, k])
        excursion[design] = highest - lowest
        speed = balance_speed(f, tip, has_plate, forces)
        balance[design] = speed
        towed_tail(f, tip, speed, has_plate, has_chord, forces, loads)
        push[design] = mean_in_order(forces)
        for k in range(samples):
            power[k, design] = loads[k]


#: The compiled kernels' numba dispatchers (the plain functions without numba).
_FOLLOW: Any = _follow_all
_KERNEL: Any = _held_loop_cycles
for _dispatcher in (_FOLLOW, _KERNEL):
    key_cache_to_sources(_dispatcher, formulas, oscillatory_tail, loop_pose, figures, tail_drive,
                         cycle_kernel)  # fmt: skip


def held_loop_cycles(
    drive: FloatArray, loop: FloatArray, slider: FloatArray, fish: FloatArray,
    carrier_speed_rad_s: FloatArray, has_plate: bool, has_chord: bool, samples: int,
) -> HeldCycles | None:  # fmt: skip
    """Each design at its constant carrier speed, towed at its balance speed over one beat.

    What :func:`~fishtail_plant.fish.figures.steady_surge_speed` (not strict) and then
    :func:`~fishtail_plant.fish.figures.held_tail` give at the times
    ``(k / samples) (2 pi / Omega)`` on the designs' drive; ``slider``: AS at the branch's
    samples (:func:`follow_branches`), the seeds of each sample's closure (NaN: no pose);
    ``fish``: :data:`cycle_kernel.FISH_COLUMNS` per design. None without numba.
    """
    if kernel_signatures() is None:
        return None
    count = drive.shape[0]
    result = HeldCycles(np.empty(count), np.empty(count), np.empty((samples, count)),
                        np.empty(count))  # fmt: skip
    _KERNEL(np.ascontiguousarray(drive), np.ascontiguousarray(loop),
            np.ascontiguousarray(slider), np.ascontiguousarray(fish),
            np.array(carrier_speed_rad_s, dtype=float), has_plate, has_chord, *result)  # fmt: skip
    return result


def kernel_signatures() -> tuple[tuple[Any, ...], tuple[Any, ...]] | None:
    """The argument types of the branch kernel and the towing kernel (None without numba)."""
    if not hasattr(_KERNEL, "compile"):
        return None
    from numba import types as numba_types

    types: Any = numba_types
    vector, matrix = types.Array(types.float64, 1, "C"), types.Array(types.float64, 2, "C")
    flags, codes = types.Array(types.boolean, 1, "C"), types.Array(types.int64, 1, "C")
    follow = (matrix, matrix, flags, codes, types.Array(types.float64, 3, "C"))
    towing = (matrix, matrix, matrix, matrix, vector, types.boolean, types.boolean, vector,
              vector, matrix, vector)  # fmt: skip
    return follow, towing


def is_cached() -> bool | None:
    """Whether numba's cache holds both current kernels (None: cannot tell, or no numba)."""
    signatures = kernel_signatures()
    if signatures is None:
        return None
    try:
        for dispatcher, signature in zip((_FOLLOW, _KERNEL), signatures, strict=True):
            cache = dispatcher._cache
            key = cache._index_key(signature, dispatcher.targetctx.codegen())
            if key not in cache._cache_file._load_index():
                return False
    except Exception:  # noqa: BLE001 - numba internals: unknown rather than wrong
        return None
    return True


def compile_kernel() -> KernelPreparation | None:
    """Compile both kernels, or load them from numba's cache (None without numba)."""
    signatures = kernel_signatures()
    if signatures is None:
        return None
    started = time.monotonic()
    compiled = False
    for dispatcher, signature in zip((_FOLLOW, _KERNEL), signatures, strict=True):
        before = sum(dispatcher.stats.cache_misses.values())
        dispatcher.compile(signature)
        compiled = compiled or sum(dispatcher.stats.cache_misses.values()) > before
    return KernelPreparation(time.monotonic() - started, compiled)
