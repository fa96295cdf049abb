"""Mechanism 1's batch solve, its algebra compiled: :func:`drive_pose` in one pass over a block.

numpy evaluates :func:`~.oscillatory_tail.solve_drive_arrays` an operation at a time: some 45
passes over each block besides the transcendental calls, which leaves a population's solve
at several times the cost of those calls. Here numba compiles the engine's own scalar formula,
:func:`~.oscillatory_tail.drive_pose`, into one loop over a block of linkages and angles; the
carrier's cosine and sine, and the atan2 and asin of the angles, stay numpy's (its vectorised
atan2 and asin cost a fraction of the C library's, which compiled scalar code would call), from
the arguments the formula returns. The same numbers as the numpy path to rounding
(``src/fishtail_kinematics/test/engine/test_drive_pass.py``).

numba is optional and not imported with the engine: :func:`compiled_pass` imports it (and
loads the compiled pass from numba's disk cache, keyed to the formula's source) the first time
a batch asks, and gives None without it or with NUMBA_DISABLE_JIT; the caller then solves with
numpy. ``python -m fishtail_plant.compiled`` (make setup) compiles it into the cache.
"""

from __future__ import annotations

import importlib
import time
from collections.abc import Mapping
from typing import Any, NamedTuple

import numpy as np

from fishtail_kinematics.engine import oscillatory_tail
from fishtail_kinematics.engine.geometry import FloatArray
from fishtail_kinematics.engine.oscillatory_tail import DriveCoefficients, DriveConstants

#: The fields the compiled pass writes, in its arguments' order after the inputs: the state's
#: that need no inverse function, the tail link's direction, and the arguments of asin and of
#: theta1's atan2 (what :data:`~.oscillatory_tail.DRIVE_POSE_FIELDS` calls them).
PASS_FIELDS = (
    "slider_position", "slider_velocity", "theta1_dot", "theta2_dot", "tip_x", "tip_y",
    "tip_x_dot", "tip_y_dot", "cos_fin", "sin_fin", "sin_beta", "cos_theta1", "sin_theta1",
)  # fmt: skip
#: Those the caller does not keep: the pass's scratch arrays.
SCRATCH_FIELDS = ("sin_beta", "cos_theta1", "sin_theta1")

#: Scratch arrays :func:`solve_block` works in: those, and the carrier's angle, its cosine and
#: the carrier speed where the linkages do not share them.
SCRATCH = len(SCRATCH_FIELDS) + 3

_loaded: dict[str, Any] = {}


class Passes(NamedTuple):
    """The compiled passes (numba's dispatchers).

    ``shared``: angles and speeds shared by the linkages, one of each a row; ``own``: an angle and
    a speed for every linkage and row.
    """

    shared: Any
    own: Any


def compiled_pass() -> Passes | None:
    """The compiled passes, or None without numba or with NUMBA_DISABLE_JIT.

    numba is imported on the first call (each pass is compiled, or loaded from numba's cache,
    on its first use).
    """
    if "passes" not in _loaded:
        try:
            module = importlib.import_module("fishtail_kinematics.engine.drive_pass_numba")
        except ImportError:  # pragma: no cover - exercised where numba is not installed
            _loaded["passes"] = None
        else:
            built = Passes(module.RATES_SHARED, module.RATES_OWN)
            _loaded["passes"] = built if hasattr(built.shared, "compile") else None
    passes: Passes | None = _loaded["passes"]
    return passes


def pass_signatures() -> Passes | None:
    """The argument types :func:`solve_block` calls each pass with (None without numba)."""
    if compiled_pass() is None:
        return None
    types: Any = importlib.import_module("numba").types
    table = types.Array(types.float64, 2, "C")
    rows, block = types.Array(types.float64, 1, "C"), types.Array(types.float64, 2, "C")
    written = (block,) * len(PASS_FIELDS)
    return Passes((table, rows, rows, rows, *written), (table, block, block, block, *written))


class PassPreparation(NamedTuple):
    """What :func:`compile_pass` did: seconds taken, and whether it compiled or loaded."""

    seconds: float
    compiled: bool


def _misses(passes: Passes) -> int:
    return sum(sum(dispatcher.stats.cache_misses.values()) for dispatcher in passes)


def compile_pass() -> PassPreparation | None:
    """Compile both passes, or load them from numba's cache (None without numba)."""
    passes, signatures = compiled_pass(), pass_signatures()
    if passes is None or signatures is None:
        return None
    started = time.monotonic()
    before = _misses(passes)
    for dispatcher, signature in zip(passes, signatures, strict=True):
        dispatcher.compile(signature)
    return PassPreparation(time.monotonic() - started, _misses(passes) > before)


def is_cached() -> bool | None:
    """Whether numba's cache holds both current passes (None: cannot tell, or no numba).

    Read from the caches' indexes without compiling or loading anything.
    """
    passes, signatures = compiled_pass(), pass_signatures()
    if passes is None or signatures is None:
        return None
    try:
        return all(
            dispatcher._cache._index_key(signature, dispatcher.targetctx.codegen())
            in dispatcher._cache._cache_file._load_index()
            for dispatcher, signature in zip(passes, signatures, strict=True)
        )
    except Exception:  # noqa: BLE001 - numba internals: unknown rather than wrong
        return None


def coefficient_table(coefficients: DriveCoefficients, count: int) -> FloatArray:
    """The linkages' coefficients as the pass reads them: shape (16, count), C order."""
    table = np.empty((len(coefficients), count))
    for row, value in enumerate(coefficients):
        table[row] = value
    return table


def solve_block(
    passes: Passes,
    c: DriveConstants,
    table: FloatArray,
    phi: FloatArray,
    phi_dot: FloatArray,
    out: Mapping[str, FloatArray],
    scratch: list[FloatArray],
) -> None:
    """A block of rows (angles) of every linkage, into ``out`` (views of shape (rows, N)).

    ``phi`` and ``phi_dot`` are (rows, 1) or (rows, N); ``out`` holds every field of
    :data:`~.oscillatory_tail.DRIVE_ARRAY_FIELDS` but ``fin_angle`` where the tail link is
    mounted at mid-swing (it is theta3 then); ``scratch``, :data:`SCRATCH` arrays of the block's
    shape. Where the linkages share their carrier phase and the angles and speeds, the carrier's
    cosine and sine are taken once an angle, as on the numpy path.
    """
    phase = oscillatory_tail.shared_value(c.phase_rad)
    sin_beta, cos1, sin1, carrier_work, cos_work, speed_work = scratch
    written = [out[name] for name in PASS_FIELDS if name not in SCRATCH_FIELDS]
    if phi.shape[-1] == 1 and phi_dot.shape[-1] == 1 and np.ndim(phase) == 0:
        carrier = (phi + phase).reshape(-1)
        cos_carrier = np.cos(carrier)
        speed = np.array(phi_dot.reshape(-1), dtype=float)
        passes.shared(
            table, cos_carrier, np.sin(carrier, out=carrier), speed, *written, sin_beta, cos1,
            sin1,
        )  # fmt: skip
    else:
        carrier = np.add(phi, phase, out=carrier_work)
        cos_carrier = np.cos(carrier, out=cos_work)
        np.copyto(speed_work, phi_dot)
        passes.own(
            table, cos_carrier, np.sin(carrier, out=carrier), speed_work, *written, sin_beta,
            cos1, sin1,
        )  # fmt: skip
    # theta2 = atan2(OS, OP) + asin K and theta1 = atan2(sin theta1, cos theta1), as the numpy
    # path forms them.
    theta2 = np.arctan2(c.pivot_offset_m, out["slider_position"], out=out["theta2"])
    theta2 += np.arcsin(sin_beta, out=sin_beta)
    np.arctan2(sin1, cos1, out=out["theta1"])
    np.subtract(theta2, c.theta2_mid, out=out["theta3"])
    if not c.mounted_at_mid:
        np.subtract(theta2, c.tail_mounting_rad, out=out["fin_angle"])
