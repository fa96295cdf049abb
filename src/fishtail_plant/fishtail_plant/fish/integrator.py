"""Fixed-step integration of a batch of fish: classical fourth-order Runge-Kutta.

Explicit and fixed-step because the tail is known exactly at every stage time and the equations
are not stiff, and one step for the whole batch keeps every fish on one time grid with the beats
on samples. Why, and the accuracy measured: docs/swimming-dynamics.md ("Integrator").

>>> import numpy as np
>>> decay = lambda t, y: -y
>>> y = np.ones((1, 1))
>>> for n in range(10):
...     y = rk4_step(decay, 0.1 * n, y, 0.1)
>>> abs(float(y[0, 0]) - float(np.exp(-1.0))) < 1e-6
True
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from fishtail_plant.errors import SwimInputError
from fishtail_plant.fish import fused
from fishtail_plant.fish.fish import FloatArray
from fishtail_plant.fish.model import STATE_SIZE, SwimModel

RightHandSide = Callable[[npt.ArrayLike, FloatArray], FloatArray]


class Trajectory(NamedTuple):
    """Recorded times (K,) and states (K, N, 6), from the initial state on."""

    time_s: FloatArray
    state: FloatArray

    @property
    def step_s(self) -> float:
        """The recording interval."""
        return float(self.time_s[1] - self.time_s[0])


def rk4_step(
    derivatives: RightHandSide, time_s: float, state: FloatArray, step_s: float
) -> FloatArray:
    """One classical Runge-Kutta step of ``state`` (any shape) from ``time_s``."""
    half = 0.5 * step_s
    k1 = derivatives(time_s, state)
    k2 = derivatives(time_s + half, state + half * k1)
    k3 = derivatives(time_s + half, state + half * k2)
    k4 = derivatives(time_s + step_s, state + step_s * k3)
    return state + (step_s / 6.0) * (k1 + 2.0 * (k2 + k3) + k4)


def simulate(
    model: SwimModel,
    fish_count: int,
    step_s: float,
    steps: int,
    initial_state: FloatArray | None = None,
    record_every: int = 1,
    progress: Callable[[int], None] | None = None,
) -> Trajectory:
    """Integrate ``fish_count`` fish for ``steps`` steps of ``step_s`` from t = 0.

    The default start is the documented one: at rest at the origin, heading along world x. Every
    ``record_every``-th state is kept (and the first). ``progress`` is called with the number of
    steps done, a few times a second at most. The loop is the compiled one
    (:mod:`~fishtail_plant.fish.fused`) where numba is installed, else the numpy model's.

    Raises:
        SwimInputError: a step that is not finite and positive, a count below 1, an initial
            state of the wrong shape or not finite, or an integration that diverged.
    """
    if not (math.isfinite(step_s) and step_s > 0.0):
        raise SwimInputError(f"step_s must be finite and positive, got {step_s!r}")
    if steps < 1 or record_every < 1 or fish_count < 1:
        raise SwimInputError(
            f"steps ({steps}), record_every ({record_every}) and fish_count ({fish_count}) "
            "must be at least 1"
        )
    if initial_state is None:
        state = np.zeros((fish_count, STATE_SIZE))
    else:
        state = np.array(initial_state, dtype=float)
        if state.shape != (fish_count, STATE_SIZE) or not np.isfinite(state).all():
            raise SwimInputError(
                f"initial_state must be finite of shape ({fish_count}, {STATE_SIZE}), "
                f"got shape {state.shape}"
            )
    records = steps // record_every + 1
    states = np.empty((records, fish_count, STATE_SIZE))
    states[0] = state
    stepper = Stepper(model, fish_count)
    block = fused.block_steps(fish_count)
    for first in range(0, steps, block):
        count = min(block, steps - first)
        state = stepper.advance(state, 0.0, first, count, step_s, record_every, states)
        if not np.isfinite(state).all():
            break
        if progress is not None:
            progress(first + count)
    if not np.isfinite(states).all() or not np.isfinite(state).all():
        raise SwimInputError("the integration diverged (non-finite state): reduce step_s")
    # Times from the step count, not by accumulation: no drift of the beat boundaries.
    times = np.arange(records, dtype=np.float64) * record_every * step_s
    return Trajectory(times, states)


class Stepper:
    """RK4 steps of a model's batch of fish: the compiled loop where numba is installed, else numpy.

    Both evaluate the same formulas at the same stage times and agree to rounding.
    """

    def __init__(self, model: SwimModel, fish_count: int) -> None:
        """Step ``fish_count`` fish of ``model``."""
        self.model = model
        self.compiled = fused.AVAILABLE
        self._parameters = fused.parameter_table(model, fish_count) if self.compiled else None

    def advance(
        self,
        state: FloatArray,
        start_s: float,
        first_step: int,
        steps: int,
        step_s: float,
        record_every: int,
        records: FloatArray,
    ) -> FloatArray:
        """``state`` (N, 6) after steps ``first_step`` to ``first_step + steps - 1``.

        Step k runs from start_s + k h to start_s + (k + 1) h. After step j (counted from 0 at
        start_s) the state goes to ``records[j // record_every]`` when ``record_every`` divides
        j. ``state`` itself is left as it was.
        """
        if self._parameters is not None:
            advanced = np.array(state, dtype=float)
            fused.rk4_block(
                self.model, self._parameters, advanced, start_s, first_step, steps, step_s,
                record_every, records,
            )  # fmt: skip
            return advanced
        derivatives = self.model.derivatives
        for step in range(first_step + 1, first_step + steps + 1):
            state = rk4_step(derivatives, start_s + (step - 1) * step_s, state, step_s)
            if step % record_every == 0:
                records[step // record_every] = state
        return state
