"""A tail's array path on any batch: checked inputs, cache-sized blocks, caller-given outputs.

Both tails' ``solve`` hand their array path to :func:`solve_arrays`, so that large batches run a
block at a time (on up to ``workers`` threads, the same bits whatever their number), non-finite
input is refused rather than returned as NaN, and results can go into preallocated arrays
(``out=``, as numpy's ufuncs do). What the caller gets: docs/kinematics.md ("Performance").
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import TypeVar

import numpy as np
import numpy.typing as npt

from fishtail_kinematics.engine.blocks import BLOCK_SAMPLES, run_blocks
from fishtail_kinematics.engine.errors import InvalidInputError
from fishtail_kinematics.engine.geometry import FloatArray, OscillatoryState, UndulatoryState

State = TypeVar("State", OscillatoryState, UndulatoryState)
ArraySolver = Callable[[FloatArray, FloatArray], State]


def finite_array(name: str, value: npt.ArrayLike) -> FloatArray:
    """``value`` as a float array.

    Raises:
        InvalidInputError: a non-finite value (naming the first and its flat index).
    """
    array = np.asarray(value, dtype=float)
    if not np.isfinite(array).all():
        bad = np.flatnonzero(~np.isfinite(array.ravel()))
        raise InvalidInputError(
            f"{bad.size} non-finite {name} value(s), the first at flat index {bad[0]}: "
            f"{array.ravel()[bad[0]]!r}"
        )
    return array


def solve_arrays(
    solver: ArraySolver[State],
    state_type: type[State],
    motor_angle: npt.ArrayLike,
    motor_velocity: npt.ArrayLike,
    out: State | None = None,
    workers: int | None = None,
) -> State:
    """``solver`` over the broadcast inputs, a block at a time, into ``out`` when given.

    0-d input gives 0-d output. Without ``out`` the state's ``motor_angle`` and
    ``motor_velocity`` are the inputs (read-only broadcast views), not copies, and a field the
    solver returns as another field (mechanism 1's theta3_dot is its theta2_dot) is the same
    array, as on the unblocked path.

    Raises:
        InvalidInputError: a non-finite input, or an ``out`` of the wrong type, dtype or shape,
            read-only, broadcast, or sharing memory with another array or an input.
    """
    phi = finite_array("carrier angle", motor_angle)
    phi_dot = finite_array("carrier speed", motor_velocity)
    shape = np.broadcast_shapes(phi.shape, phi_dot.shape)
    size = math.prod(shape)
    if out is None and size <= BLOCK_SAMPLES:
        # One block: the solver's own arrays are the result, nothing to copy.
        if shape:
            return solver(phi, phi_dot)
        # The solver works in place (out=...), which numpy refuses for 0-d results.
        state = solver(phi.reshape(1), phi_dot.reshape(1))
        return state_type._make(np.asarray(value).reshape(()) for value in state)
    flat_phi, flat_phi_dot = _flat_input(phi, shape), _flat_input(phi_dot, shape)

    def solve_block(block: slice) -> State:
        return solver(
            flat_phi if flat_phi.ndim == 0 else flat_phi[block],
            flat_phi_dot if flat_phi_dot.ndim == 0 else flat_phi_dot[block],
        )

    if out is not None:
        targets = dict(enumerate(_flat_targets(state_type, out, shape, phi, phi_dot)))
        run_blocks(lambda block: _write(solve_block(block), targets, block), size, workers)
        return out
    # Fields the solver hands back as another field (mechanism 1's theta3_dot is its theta2_dot)
    # are stored once, as on the unblocked path; the inputs are not copied.
    first_block = slice(0, min(BLOCK_SAMPLES, size))
    first = solve_block(first_block)
    sources = [next(j for j in range(i + 1) if first[j] is value) for i, value in enumerate(first)]
    storage = {i: np.empty(size) for i, source in enumerate(sources) if i >= 2 and source == i}
    _write(first, storage, first_block)

    def solve_later_block(block: slice) -> None:
        if block.start != first_block.start:
            _write(solve_block(block), storage, block)

    run_blocks(solve_later_block, size, workers)
    inputs = [
        value if value.shape == shape else np.broadcast_to(value, shape) for value in (phi, phi_dot)
    ]
    return state_type._make(
        inputs[i] if i < 2 else storage[source].reshape(shape) for i, source in enumerate(sources)
    )


def _write(state: Sequence[npt.ArrayLike], targets: Mapping[int, FloatArray], block: slice) -> None:
    for index, target in targets.items():
        np.copyto(target[block], state[index])


def _flat_input(value: FloatArray, shape: tuple[int, ...]) -> FloatArray:
    """A 1-d view (or, if it must be, copy) of ``value`` broadcast to ``shape``; 0-d stays 0-d."""
    if value.ndim == 0 and shape:
        return value
    return np.broadcast_to(value, shape).reshape(-1)


def _flat_targets(
    state_type: type[State],
    out: State,
    shape: tuple[int, ...],
    phi: FloatArray,
    phi_dot: FloatArray,
) -> list[FloatArray]:
    """1-d views of every array of ``out``, after checking that the results can go there."""
    if not isinstance(out, state_type):
        raise InvalidInputError(
            f"out must be a {state_type.__name__} of arrays, got {type(out).__name__}"
        )
    flat = []
    for name, value in zip(state_type._fields, out, strict=True):
        if not isinstance(value, np.ndarray) or value.dtype != np.float64:
            raise InvalidInputError(f"out.{name} must be a float64 array, got {value!r:.60}")
        if value.shape != shape:
            raise InvalidInputError(
                f"out.{name} has shape {value.shape}, the inputs broadcast to {shape}"
            )
        if any(
            stride == 0 and length > 1 for stride, length in zip(value.strides, shape, strict=True)
        ):
            raise InvalidInputError(f"out.{name} repeats its memory (a broadcast view)")
        if not value.flags.writeable:
            raise InvalidInputError(f"out.{name} is read-only")
        view = value.view()
        try:
            view.shape = (-1,)  # refuses where reshape(-1) would have to copy
        except AttributeError:
            raise InvalidInputError(
                f"out.{name} cannot be written as one flat run of its memory (its strides are "
                f"{value.strides}); pass a contiguous array"
            ) from None
        flat.append(view)
    own_inputs = {"motor_angle": phi, "motor_velocity": phi_dot}
    for i, name in enumerate(state_type._fields):
        for j in range(i):
            if np.may_share_memory(out[i], out[j]):
                other = state_type._fields[j]
                raise InvalidInputError(f"out.{name} and out.{other} share memory")
        for input_name, given in own_inputs.items():
            # An input may be its own output (solve(angle, out=...) with out.motor_angle = angle).
            same = input_name == name and out[i] is given
            if not same and np.may_share_memory(out[i], given):
                raise InvalidInputError(f"out.{name} shares memory with the {input_name} input")
    return flat
