"""Batch functions of the executor tests, in a module that worker processes import by its name.

test_executors.py puts this directory on sys.path, which spawned processes (the process pool, a
LocalCluster's workers) inherit; the separately started ``dask worker`` processes get it in
PYTHONPATH. A function of the test module itself would not do: pytest imports it under a name
that other processes cannot import.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]


class Toy(NamedTuple):
    """A problem to bind to the batch function, as the synthesis binds its problem."""

    scale: float
    #: A design with a variable above it makes :func:`score` raise.
    limit: float = np.inf


class ToyScores(NamedTuple):
    """A result of several arrays with a row per design, as the synthesis' Scores."""

    objectives: FloatArray  # (N, 2)
    feasible: npt.NDArray[np.bool_]  # (N,)


def score(toy: Toy, batch: FloatArray) -> ToyScores:
    """Two objectives per design from transcendental functions (any rounding would show)."""
    over = np.flatnonzero(np.any(batch > toy.limit, axis=1))
    if over.size:
        raise ValueError(f"a design is over the limit {toy.limit:g}:\n{batch[over[0]].tolist()}")
    objectives = np.column_stack(
        [np.sin(toy.scale * batch).sum(axis=1), np.exp(-batch[:, 0]) * np.cos(batch[:, -1])]
    )
    return ToyScores(objectives, objectives[:, 0] > 0.0)


def gated(gate: str, batch: FloatArray) -> FloatArray:
    """Twice the batch; a batch whose first value is negative first waits for the file ``gate``.

    Raises:
        TimeoutError: the gate did not open within 60 s.
    """
    if batch[0, 0] < 0.0:
        deadline = time.monotonic() + 60.0
        while not Path(gate).exists():
            if time.monotonic() > deadline:
                raise TimeoutError(f"{gate} did not appear within 60 s")
            time.sleep(0.01)
    return 2.0 * batch
