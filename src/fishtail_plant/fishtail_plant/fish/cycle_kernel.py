"""Mechanism-1 linkages towed over one beat, compiled: the balance speed, the push and the power.

A synthesis asks, for each of many linkages turned at a constant carrier speed, what
:func:`~fishtail_plant.fish.figures.steady_surge_speed` and
:func:`~fishtail_plant.fish.figures.held_tail` give on a
:class:`~fishtail_plant.fish.tail_drive.LinkageBatchDrive`: the fish's balance speed, the tail's
mean push and its power at every sample of the beat. numpy evaluates these a formula at a time
over the whole population, about 25 times over for the balance's root; here numba compiles,
into one loop over the designs, the same formulas: the engine's pose
(:func:`~fishtail_kinematics.engine.oscillatory_tail.drive_pose`) and
:mod:`~fishtail_plant.fish.formulas`. Per design: the beat's samples solved once (the tip's
accelerations from the same central difference in the carrier angle as
:meth:`~fishtail_plant.fish.tail_drive.EngineTailDrive.acceleration`, the angles stepped by
angle-sum identities), the balance by the same Illinois iteration to the same tolerance, then
the towed tail at that speed. The results equal the numpy path's to rounding (about 1e-12;
``src/fishtail_plant/test/fish/test_cycle_kernel.py``).

Numba is optional (:data:`AVAILABLE`); without it :func:`held_cycles` returns None and callers
use numpy. The compiled kernel is cached like the integrator's (:mod:`~fishtail_plant.fish.fused`,
whose ``python -m`` run at ``make setup`` compiles it too), its cache keyed to the sources of the
formulas it compiles.

The kernel's pieces that do not depend on the mechanism are public, for
:mod:`~fishtail_plant.fish.loop_kernel` (mechanism 2) to compile into its own kernel:
:func:`compiled_drive_pose`, the beat's table of :data:`TIP_ROWS` rows, :func:`balance_speed`,
:func:`towed_tail`, :func:`mean_in_order` and :func:`design_table`. A change to them changes
this file, to which both kernels' caches are keyed.
"""

from __future__ import annotations

import math
import time
from typing import Any, NamedTuple

import numpy as np

from fishtail_common.compiled_cache import key_cache_to_sources
from fishtail_kinematics.engine import oscillatory_tail
from fishtail_kinematics.engine.drive_batch import OscillatoryBatch
from fishtail_kinematics.engine.oscillatory_tail import (
    DriveCoefficients,
    drive_coefficients,
    drive_pose,
)
from fishtail_plant.fish import figures, formulas, tail_drive
from fishtail_plant.fish.fish import FishParameters, FloatArray
from fishtail_plant.fish.fused import AVAILABLE, Compiler, _identity

if AVAILABLE:
    import numba

#: Columns of the linkage table the kernel reads (one row per design): the engine's
#: coefficients, in the order drive_pose takes them, then the carrier phase.
LINKAGE_COLUMNS = (*DriveCoefficients._fields, "phase_rad")
_PHASE = len(DriveCoefficients._fields)
#: Columns of the fish table the kernel reads (one row per design).
FISH_COLUMNS = (
    "fin_added_mass_per_length_kg_m", "tail_origin_offset_m", "fin_chord_m",
    "fin_drag_factor_kg_m2", "drag_factor_kg_m", "surge_linear_damping_kg_s",
)  # fmt: skip
#: The carrier-angle step of the tip's accelerations: the drive's own.
_ANGLE_STEP_RAD = tail_drive._ANGLE_STEP_RAD
# The balance's bracket and root: figures.py's settings.
_BRACKET_DOUBLINGS = figures._BRACKET_DOUBLINGS
_BISECTIONS = figures._BISECTIONS
_ROOT_TOLERANCE = figures._ROOT_TOLERANCE
_ROOT_FLOOR_M_S = figures._ROOT_FLOOR_M_S


class HeldCycles(NamedTuple):
    """Each design towed at its balance speed over one beat (NaN: no pose or no balance)."""

    speed_m_s: FloatArray  # (N,) the balance speed U
    push_n: FloatArray  # (N,) the tail's mean push at U
    power_w: FloatArray  # (samples, N) the tail's power at each sample, towed at U
    tip_excursion_m: FloatArray  # (N,) peak to peak of the tip's y over the samples


# The formulas compiled as they stand. Only the kernel is cached (with what it calls compiled
# into it); numba's cache key does not hold the error model, which must be numpy's here (a
# linkage that does not assemble divides NaN by NaN: NaN, not an exception).
_formula: Compiler = numba.njit(nogil=True, error_model="numpy") if AVAILABLE else _identity
_kernel_jit: Compiler = (
    numba.njit(cache=True, nogil=True, error_model="numpy") if AVAILABLE else _identity
)
#: The engine's pose of the drive (drive_pose), compiled to be called from a kernel.
compiled_drive_pose = _formula(drive_pose)
_tip_force = _formula(formulas.tip_force)
_fin_drag = _formula(formulas.fin_drag)
_fin_recoil = _formula(formulas.fin_recoil)
_tip_power = _formula(formulas.tip_power)
_fin_drag_power = _formula(formulas.fin_drag_power)
_recoil_power = _formula(formulas.recoil_power)


# Each loop over the beat's samples below only computes and stores, so that LLVM vectorises it;
# the means then add the stored values in order, one after the other, as numpy's mean over the
# samples does.
#
# The beat of a design, rows of ``tip`` (samples along the row): the tip's x, y, x_dot, y_dot,
# cos th, sin th, th_dot, then the accelerations of the tip (x, y) and of th.
#: Rows of a design's beat table (``tip``), which balance_speed and towed_tail read.
TIP_ROWS = 10


@_formula
def mean_in_order(values: Any) -> float:
    """The mean of ``values``, added in order."""
    total = 0.0
    for value in values:
        total += value
    count: int = values.shape[0]
    return total / count


@_formula
def _beat(
    c: Any, omega: float, cos_carrier: Any, sin_carrier: Any, has_chord: bool, tip: Any
) -> None:
    """The linkage ``c`` (a linkage table row) at each sample, into ``tip``.

    The tip's accelerations are the drive's central difference of the rates at unit carrier
    speed a step either side, times Omega² (the carrier does not accelerate); the stepped
    angles' cosines and sines follow from the sample's by the angle-sum identities.
    """
    cos_step, sin_step = math.cos(_ANGLE_STEP_RAD), math.sin(_ANGLE_STEP_RAD)
    scale = 0.5 / _ANGLE_STEP_RAD
    squared = omega**2
    # Two loops, so that each is straight code that LLVM vectorises.
    for k in range(tip.shape[1]):
        pose = compiled_drive_pose(
            cos_carrier[k], sin_carrier[k], omega, c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7],
            c[8], c[9], c[10], c[11], c[12], c[13], c[14], c[15],
        )  # fmt: skip
        tip[0, k], tip[1, k], tip[2, k], tip[3, k] = pose[7], pose[8], pose[9], pose[10]
        tip[4, k], tip[5, k], tip[6, k] = pose[12], pose[13], pose[5]
    if not has_chord:
        tip[7:].fill(0.0)
        return
    for k in range(tip.shape[1]):
        cos_k, sin_k = cos_carrier[k], sin_carrier[k]
        ahead = compiled_drive_pose(
            cos_k * cos_step - sin_k * sin_step, sin_k * cos_step + cos_k * sin_step, 1.0,
            c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7], c[8], c[9], c[10], c[11], c[12], c[13],
            c[14], c[15],
        )  # fmt: skip
        behind = compiled_drive_pose(
            cos_k * cos_step + sin_k * sin_step, sin_k * cos_step - cos_k * sin_step, 1.0,
            c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7], c[8], c[9], c[10], c[11], c[12], c[13],
            c[14], c[15],
        )  # fmt: skip
        tip[7, k] = (ahead[9] - behind[9]) * scale * squared
        tip[8, k] = (ahead[10] - behind[10]) * scale * squared
        tip[9, k] = (ahead[5] - behind[5]) * scale * squared


@_formula
def _push_lighthill(f: Any, tip: Any, speed: float, out: Any) -> float:
    """Lighthill's mean x force over the beat, the body held at u = ``speed``, v = r = 0."""
    for k in range(tip.shape[1]):
        out[k] = _tip_force(
            f[0], f[1], tip[0, k], tip[1, k], tip[2, k], tip[3, k], tip[4, k], tip[5, k], speed,
            0.0, 0.0,
        )[0]  # fmt: skip
    mean: float = mean_in_order(out)
    return mean


@_formula
def _push_plate(f: Any, tip: Any, speed: float, out: Any) -> float:
    """The plate's mean x force over the beat, the body held at u = ``speed``, v = r = 0."""
    for k in range(tip.shape[1]):
        out[k] = _fin_drag(
            f[3], f[2], f[1], tip[0, k], tip[1, k], tip[2, k], tip[3, k], tip[4, k], tip[5, k],
            tip[6, k], speed, 0.0, 0.0,
        )[0]  # fmt: skip
    mean: float = mean_in_order(out)
    return mean


@_formula
def _net(
    f: Any, tip: Any, at_rest: float, linear: float, quadratic: float, speed: float, out: Any
) -> float:
    """The balance's net force: Lighthill's polynomial, the damping and the plate's mean drag."""
    plate: float = _push_plate(f, tip, speed, out)
    return at_rest + speed * (linear + quadratic * speed) + plate


@_formula
def _illinois(
    f: Any, tip: Any, at_rest: float, linear: float, quadratic: float,
    high: float, f_low: float, f_high: float, out: Any,
) -> float:  # fmt: skip
    """figures._bisect for one design: the root of the net force in [0, high]."""
    low = 0.0
    side = 0.0
    if f_low > 0.0 and f_high <= 0.0:
        for _ in range(_BISECTIONS):
            width = high - low
            if not width > _ROOT_TOLERANCE * max(abs(high), _ROOT_FLOOR_M_S):
                break
            secant = high - f_high * width / (f_high - f_low)
            middle = secant if (secant > low and secant < high) else 0.5 * (low + high)
            f_middle = _net(f, tip, at_rest, linear, quadratic, middle, out)
            if f_middle > 0.0:
                low, f_low = middle, f_middle
                if side > 0.0:
                    f_high = 0.5 * f_high
                side = 1.0
            else:
                high, f_high = middle, f_middle
                if side < 0.0:
                    f_low = 0.5 * f_low
                side = -1.0
    return low if abs(f_low) < abs(f_high) else high


@_formula
def balance_speed(f: Any, tip: Any, has_plate: bool, out: Any) -> float:
    """figures.steady_surge_speed (not strict) for one design, from its beat's samples.

    ``f``: the design's row of the fish table (:data:`FISH_COLUMNS`); ``tip``: its beat,
    :data:`TIP_ROWS` rows by samples; ``out``: scratch, one value per sample. NaN: no balance.
    """
    at_rest = _push_lighthill(f, tip, 0.0, out)
    ahead = _push_lighthill(f, tip, 1.0, out)
    astern = _push_lighthill(f, tip, -1.0, out)
    linear = 0.5 * (ahead - astern) - f[5]
    quadratic = 0.5 * (ahead + astern) - at_rest - f[4]
    discriminant = linear * linear - 4.0 * quadratic * at_rest
    usable = quadratic < 0.0 and at_rest > 0.0 and discriminant >= 0.0
    without_plate = (2.0 * at_rest) / (math.sqrt(discriminant) - linear)
    if not has_plate:
        return without_plate if usable else math.nan
    rest = _net(f, tip, at_rest, linear, quadratic, 0.0, out)
    moving = rest > 0.0
    # The bracket [0, high] by doubling from the balance without the plate's drag.
    high = without_plate if usable else 0.1
    high = high if (high > 1e-3 or high != high) else 1e-3
    high = high if moving else 1e-3
    f_high = _net(f, tip, at_rest, linear, quadratic, high, out)
    for _ in range(_BRACKET_DOUBLINGS):
        if not f_high > 0.0:
            break
        high = 2.0 * high
        f_high = _net(f, tip, at_rest, linear, quadratic, high, out)
    else:
        moving = moving and f_high <= 0.0
    speed = _illinois(f, tip, at_rest, linear, quadratic, high, rest, f_high, out)
    return speed if moving else math.nan


@_formula
def towed_tail(
    f: Any, tip: Any, speed: float, has_plate: bool, has_chord: bool, push: Any, power: Any
) -> None:
    """figures.held_tail at u = ``speed``, v = r = 0: the push and the power at each sample.

    ``f`` and ``tip`` as :func:`balance_speed` takes them; ``push`` and ``power`` (one value per
    sample) receive the tail's x force and power.
    """
    for k in range(tip.shape[1]):
        force = _tip_force(
            f[0], f[1], tip[0, k], tip[1, k], tip[2, k], tip[3, k], tip[4, k], tip[5, k], speed,
            0.0, 0.0,
        )  # fmt: skip
        thrust = force[0]
        load = _tip_power(force[0], force[1], tip[2, k], tip[3, k])
        if has_plate:
            plate = _fin_drag(
                f[3], f[2], f[1], tip[0, k], tip[1, k], tip[2, k], tip[3, k], tip[4, k],
                tip[5, k], tip[6, k], speed, 0.0, 0.0,
            )  # fmt: skip
            thrust = thrust + plate[0]
            load = load + _fin_drag_power(
                plate[0], plate[1], plate[3], tip[2, k], tip[3, k], tip[6, k]
            )
        if has_chord:
            recoil = _fin_recoil(
                f[0], f[2], f[1], tip[0, k], tip[1, k], tip[2, k], tip[3, k], tip[4, k],
                tip[5, k], tip[6, k], tip[7, k], tip[8, k], tip[9, k], speed, 0.0, 0.0,
            )  # fmt: skip
            load = load + _recoil_power(
                f[2], tip[4, k], tip[5, k], tip[2, k], tip[3, k], tip[6, k], recoil[4], recoil[5]
            )
        push[k] = thrust
        power[k] = load


@_kernel_jit
def _held_cycles(
    linkages: Any, fish: Any, carrier_speed: Any, has_plate: bool, has_chord: bool,
    balance: Any, push: Any, power: Any, excursion: Any,
) -> None:  # fmt: skip
    samples = power.shape[0]
    tip = np.empty((TIP_ROWS, samples))
    cos_carrier, sin_carrier = np.empty(samples), np.empty(samples)
    forces, loads = np.empty(samples), np.empty(samples)
    last_omega = last_phase = math.nan
    for design in range(linkages.shape[0]):
        c, f, omega = linkages[design], fish[design], carrier_speed[design]
        if not (omega == last_omega and c[_PHASE] == last_phase):
            # The samples' carrier angles as constant_carrier_speed and the batch make them,
            # (k / samples) * (2 pi / Omega) * Omega + psi; shared by designs that share both.
            period = 2.0 * math.pi / omega
            for k in range(samples):
                carrier = omega * (k / samples * period) + c[_PHASE]
                cos_carrier[k], sin_carrier[k] = math.cos(carrier), math.sin(carrier)
            last_omega, last_phase = omega, c[_PHASE]
        _beat(c, omega, cos_carrier, sin_carrier, has_chord, tip)
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


#: The compiled kernel's numba dispatcher (the plain function without numba).
_KERNEL: Any = _held_cycles
key_cache_to_sources(_KERNEL, formulas, oscillatory_tail, figures, tail_drive)


def design_table(values: list[Any], count: int) -> FloatArray:
    """Per-design values (floats or (N,) arrays) as a C-contiguous (N, columns) table."""
    table = np.empty((count, len(values)))
    for column, value in enumerate(values):
        table[:, column] = np.broadcast_to(np.asarray(value, dtype=float), (count,))
    return table


def held_cycles(
    batch: OscillatoryBatch, fish: FishParameters, carrier_speed_rad_s: FloatArray, samples: int
) -> HeldCycles | None:
    """Each linkage of ``batch`` at its constant carrier speed, towed at its balance speed.

    What :func:`~fishtail_plant.fish.figures.steady_surge_speed` (not strict, ``samples`` a
    beat) and then :func:`~fishtail_plant.fish.figures.held_tail` at the times
    ``(k / samples) * (2 pi / Omega)`` give on ``LinkageBatchDrive(batch,
    constant_carrier_speed(Omega))``; ``fish`` may hold a value per design. None without numba
    or with NUMBA_DISABLE_JIT (the caller then uses those).

    Raises:
        SwimParameterError: a carrier speed that is not finite (as the carrier refuses it).
    """
    if kernel_signature() is None:
        return None
    count = batch.size
    # A writable copy: the one specialisation compile_kernel prepares.
    speed = np.array(np.broadcast_to(np.asarray(carrier_speed_rad_s, dtype=float), count))
    tail_drive.constant_carrier_speed(speed)  # refuses what the numpy path refuses
    c = batch.constants
    linkages = design_table([*drive_coefficients(c), c.phase_rad], count)
    parameters = design_table([getattr(fish, name) for name in FISH_COLUMNS], count)
    has_chord = bool(np.any(np.asarray(fish.fin_chord_m) > 0.0))
    result = HeldCycles(np.empty(count), np.empty(count), np.empty((samples, count)),
                        np.empty(count))  # fmt: skip
    _KERNEL(linkages, parameters, speed, fish.has_fin_drag, has_chord, *result)
    return result


def kernel_signature() -> tuple[Any, ...] | None:
    """The argument types :func:`held_cycles` calls the kernel with (None without numba)."""
    if not hasattr(_KERNEL, "compile"):
        return None
    from numba import types as numba_types

    types: Any = numba_types
    vector, matrix = types.Array(types.float64, 1, "C"), types.Array(types.float64, 2, "C")
    return (
        matrix, matrix, vector, types.boolean, types.boolean, vector, vector, matrix, vector,
    )  # fmt: skip


def is_cached() -> bool | None:
    """Whether numba's cache holds the current compiled kernel (None: cannot tell, or no numba).

    Read from the cache's index without compiling or loading anything.
    """
    signature = kernel_signature()
    if signature is None:
        return None
    try:
        cache = _KERNEL._cache
        key = cache._index_key(signature, _KERNEL.targetctx.codegen())
        return key in cache._cache_file._load_index()
    except Exception:  # noqa: BLE001 - numba internals: unknown rather than wrong
        return None


class KernelPreparation(NamedTuple):
    """What :func:`compile_kernel` did: seconds taken, and whether it compiled or loaded."""

    seconds: float
    compiled: bool


def compile_kernel() -> KernelPreparation | None:
    """Compile the kernel, or load it from numba's cache (None without numba)."""
    signature = kernel_signature()
    if signature is None:
        return None
    started = time.monotonic()
    before = sum(_KERNEL.stats.cache_misses.values())
    _KERNEL.compile(signature)
    compiled = sum(_KERNEL.stats.cache_misses.values()) > before
    return KernelPreparation(time.monotonic() - started, compiled)
