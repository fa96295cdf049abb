"""Sweeps: many designs of a problem, on a grid or a Latin hypercube, scored and written in chunks.

The design points are the optimiser's rows (one column per free variable of the problem's
:class:`~fishtail_design.variables.DesignSpace`): a Latin hypercube of ``count`` points
(scipy's :class:`~scipy.stats.qmc.LatinHypercube`, seeded) or the full factorial
:class:`Grid`, whose rows are made chunk by chunk from their indices and never held whole.
:func:`sweep` scores them chunk by chunk with
:func:`~fishtail_design.evaluation.evaluate_rows` through an executor and writes each chunk, in
the points' order, as soon as it and every chunk before it are scored: a CSV file (flushed per
chunk) or a Parquet file (a row group per chunk), chosen by the file's suffix. At most two
chunks are in memory, whatever the number of designs: the one being written and the next, being
scored, or two being scored. The columns: every variable by name, the objectives, the
constraints' margins, ``feasible`` and the search tier's figures, named as in ``front.csv``.
Usage: docs/design.md ("Sweeps").

>>> from fishtail_design.variables import DesignSpace
>>> space = DesignSpace("oscillatory", {"ring_radius_m": (0.05, 0.1), "crank_link_m": 0.1,
...     "tail_link_m": 0.15, "pivot_offset_m": 0.2, "gear_ratio": (10.0, 30.0),
...     "carrier_speed_rad_s": 10.0}, symmetric_rocker=True)
>>> points = grid(space, 3)
>>> points.count, points.rows(0, 4).round(4).tolist()
(9, [[0.05, 10.0], [0.05, 20.0], [0.05, 30.0], [0.075, 10.0]])
"""

from __future__ import annotations

import csv
import dataclasses
import functools
import math
from collections.abc import Callable, Generator, Iterable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple, TextIO

import numpy as np
from scipy.stats import qmc

from fishtail_design.columns import figure_column, margin_column, objective_column
from fishtail_design.errors import DesignError, ExecutorError
from fishtail_design.evaluation import FIGURES, Scores, constraint_list, evaluate_rows
from fishtail_design.executors import BATCH_SIZE, Executor
from fishtail_design.problem import Problem
from fishtail_design.variables import DesignSpace
from fishtail_plant.fish.fish import FloatArray

if TYPE_CHECKING:
    import pyarrow
    import pyarrow.parquet

#: Designs per chunk (a CSV flush, a Parquet row group) unless told otherwise.
CHUNK_SIZE = 4096
#: The output formats by the file's suffix.
FORMATS = (".csv", ".parquet")
#: The most points of a Latin hypercube: scipy makes them all at once (8 bytes per variable and
#: design, a few times over while it does).
LATIN_HYPERCUBE_MOST = 10_000_000
#: The catalogue index's column: a grid takes every ratio once, at the middle of its share.
GEAR_INDEX = "gear_index"


def latin_hypercube(space: DesignSpace, count: int, seed: int) -> FloatArray:
    """``count`` designs of ``space``, a Latin hypercube, seeded (the same seed, the same designs).

    Each free variable's range is cut into ``count`` equal strata, and each stratum holds one
    design.

    Raises:
        DesignError: no free variable, ``count`` below 1 or above :data:`LATIN_HYPERCUBE_MOST`.
    """
    dimensions = _free(space)
    if not 1 <= count <= LATIN_HYPERCUBE_MOST:
        raise DesignError(
            f"a Latin hypercube takes 1 to {LATIN_HYPERCUBE_MOST} designs (it holds them all in "
            f"memory), not {count}"
        )
    unit = qmc.LatinHypercube(d=dimensions, rng=np.random.default_rng(seed)).random(count)
    return np.asarray(qmc.scale(unit, space.lower, space.upper), dtype=float)


@dataclasses.dataclass(frozen=True)
class Grid:
    """The full factorial of ``axes`` (one array of values per free variable).

    The last variable varies fastest; :meth:`rows` makes any run of rows from their indices.
    """

    axes: tuple[FloatArray, ...]

    @property
    def shape(self) -> tuple[int, ...]:
        """The number of values along each axis."""
        return tuple(axis.size for axis in self.axes)

    @property
    def count(self) -> int:
        """The number of designs, the product of the axes' sizes."""
        return math.prod(self.shape)

    def rows(self, start: int, stop: int) -> FloatArray:
        """Designs ``start`` to ``stop`` (not included), one per row."""
        numbers = np.arange(start, min(stop, self.count), dtype=np.int64)
        indices = np.unravel_index(numbers, self.shape)
        return np.column_stack([axis[i] for axis, i in zip(self.axes, indices, strict=True)])


def grid(space: DesignSpace, points_per_variable: int) -> Grid:
    """The full factorial of ``space``, made chunk by chunk.

    ``points_per_variable`` evenly spaced values from the low to the high bound of each free
    variable, and every ratio of a catalogue once. Its size is ``points_per_variable`` to the
    power of the continuous free variables, times the catalogue's ratios when the gear ratio is
    chosen from one.

    Raises:
        DesignError: no free variable, or fewer than two points per variable.
    """
    _free(space)
    if points_per_variable < 2:
        raise DesignError(f"a grid needs at least 2 points per variable, not {points_per_variable}")
    axes: list[FloatArray] = []
    for name, low, high in zip(space.names, space.lower, space.upper, strict=True):
        if name == GEAR_INDEX:
            axes.append(np.arange(len(space.gear_ratios), dtype=float) + 0.5)
        else:
            axes.append(np.linspace(low, high, points_per_variable, dtype=float))
    return Grid(tuple(axes))


def _free(space: DesignSpace) -> int:
    if not space.names:
        raise DesignError("the problem has no free variable to sweep (every one is fixed)")
    return len(space.names)


def count_of(points: FloatArray | Grid) -> int:
    """The number of designs of a Latin hypercube's array or a grid."""
    return points.count if isinstance(points, Grid) else int(points.shape[0])


def chunks(points: FloatArray | Grid, chunk_size: int) -> Iterator[FloatArray]:
    """The designs ``chunk_size`` at a time (the last chunk may be shorter), each made on demand.

    Raises:
        ValueError: a chunk size below one.
    """
    if chunk_size < 1:
        raise ValueError(f"the chunk size must be at least 1, not {chunk_size}")
    count = count_of(points)
    for start in range(0, count, chunk_size):
        if isinstance(points, Grid):
            yield points.rows(start, start + chunk_size)
        else:
            yield np.array(points[start : start + chunk_size], dtype=float)


def sweep_columns(problem: Problem) -> list[str]:
    """A sweep's columns: variables, objectives, margins, ``feasible``, the search's figures."""
    return [
        *problem.space.variable_names(),
        *(objective_column(objective) for objective in problem.objectives),
        *(margin_column(constraint) for constraint in constraint_list(problem)),
        "feasible",
        *(figure_column("search", field) for field in FIGURES),
    ]


def sweep_table(problem: Problem, rows: FloatArray, scores: Scores) -> list[FloatArray]:
    """The columns of :func:`sweep_columns` for the designs ``rows`` and their ``scores``."""
    values = problem.space.decode(rows)
    return [
        *(values[name] for name in problem.space.variable_names()),
        *scores.objectives.T,
        *scores.margins.T,
        np.all(scores.margins >= 0.0, axis=1),
        *scores.figures.T,
    ]


class SweepResult(NamedTuple):
    """What a sweep wrote: its designs and how many of them are feasible."""

    designs: int
    feasible: int


def output_format(path: Path) -> str:
    """``.csv`` or ``.parquet``: the format of the output file ``path``.

    Raises:
        DesignError: another suffix.
    """
    suffix = path.suffix.lower()
    if suffix not in FORMATS:
        raise DesignError(
            f"{path}: the output must be a .csv or .parquet file, not {suffix or 'no suffix'}"
        )
    return suffix


def sweep(
    problem: Problem,
    points: FloatArray | Grid,
    path: Path,
    executor: Executor,
    chunk_size: int = CHUNK_SIZE,
    batch_size: int = BATCH_SIZE,
    progress: Callable[[int], None] | None = None,
    function: Callable[[FloatArray], Scores] | None = None,
) -> SweepResult:
    """Score ``points`` chunk by chunk on ``executor`` and write them to ``path`` in order.

    Each chunk of ``chunk_size`` designs goes to the executor as batches of at most
    ``batch_size`` (shared out evenly, as :func:`~fishtail_design.executors.evaluate_in_batches`
    does); the next chunk's batches start before the current one is written, so that the
    executor is kept busy while it is. If the sweep stops part-way (a failed batch, Ctrl-C),
    the file holds the chunks written so far, readable.

    Args:
        problem: the problem whose designs they are.
        points: the designs, the optimiser's rows: a Latin hypercube's array or a :class:`Grid`.
        path: the output file, ``.csv`` or ``.parquet``.
        executor: where the batches run.
        chunk_size: designs per chunk (a CSV flush, a Parquet row group).
        batch_size: the most designs in an executor task.
        progress: called with the number of designs scored each time a batch's result arrives.
        function: the batch function (default: the problem's
            :func:`~fishtail_design.evaluation.evaluate_rows`); a test's stand-in.

    Raises:
        DesignError: an output file of another suffix.
        ExecutorError: a batch that failed.
        OSError: the file cannot be written.
    """
    suffix = output_format(path)
    if batch_size < 1:
        raise ValueError(f"the batch size must be at least 1, not {batch_size}")
    batch_function = function or functools.partial(evaluate_rows, problem)
    columns = sweep_columns(problem)
    written = feasible = 0
    writer = _CsvWriter(path, columns) if suffix == ".csv" else _ParquetWriter(path, columns)
    with writer:
        scored = _scored_chunks(executor, batch_function, chunks(points, chunk_size), batch_size,
                                progress)  # fmt: skip
        try:
            for rows, scores in scored:
                table = sweep_table(problem, rows, scores)
                writer.write(table)
                written += rows.shape[0]
                feasible += int(np.count_nonzero(table[columns.index("feasible")]))
                del rows, scores, table  # not held while the next chunks start
        finally:
            scored.close()
    return SweepResult(written, feasible)


class _Chunk:
    """A chunk whose batches are on the executor: its results gathered as they arrive."""

    def __init__(self, rows: FloatArray, batch_size: int) -> None:
        self.rows = rows
        # As evaluate_in_batches shares rows out: evenly, at most batch_size to a batch.
        count = max(1, -(-rows.shape[0] // batch_size))
        self.batches = [batch.copy() for batch in np.array_split(rows, count)]
        self.results: dict[int, Scores] = {}
        self.stream: Iterator[tuple[int, Scores]] = iter(())

    def start(
        self,
        executor: Executor,
        function: Callable[[FloatArray], Scores],
        progress: Callable[[int], None],
    ) -> None:
        """Hand the batches to the executor and wait for the first result.

        The executors submit every batch of a map when its first result is asked for: from here
        on they run (behind the batches already queued) while the caller writes.
        """
        self.stream = executor.map_batches(function, self.batches)
        self._take(progress)

    def _take(self, progress: Callable[[int], None]) -> bool:
        """Gather the next result; False when there is none left."""
        item = next(self.stream, None)
        if item is None:
            return False
        index, result = item
        rows = self.batches[index].shape[0]
        if any(np.shape(part)[:1] != (rows,) for part in result):
            raise ExecutorError(f"batch {index}: the batch function returned no row per design")
        self.results[index] = result
        progress(rows)
        return True

    def finish(self, progress: Callable[[int], None]) -> tuple[FloatArray, Scores]:
        """The chunk's designs and their scores in order, once every batch is back.

        The map is closed and the batches' own results let go.

        Raises:
            ExecutorError: a batch without a result.
        """
        while self._take(progress):
            pass
        missing = sorted(set(range(len(self.batches))) - set(self.results))
        if missing:
            raise ExecutorError(f"the executor returned no result for a chunk's batch {missing[0]}")
        parts = zip(*(self.results[index] for index in range(len(self.batches))), strict=True)
        scores = Scores(*(np.concatenate(part) for part in parts))
        self.close()
        self.results.clear()
        self.batches.clear()
        return self.rows, scores

    def close(self) -> None:
        """Stop the map (the executor cancels the batches not yet run)."""
        close = getattr(self.stream, "close", None)
        if close is not None:
            close()


def _scored_chunks(
    executor: Executor,
    function: Callable[[FloatArray], Scores],
    source: Iterable[FloatArray],
    batch_size: int,
    progress: Callable[[int], None] | None,
) -> Generator[tuple[FloatArray, Scores], None, None]:
    """Each chunk of ``source`` with its scores, in order.

    The next chunk is on the executor while one is written; the one written is let go before the
    chunk after the next starts: at most two chunks are held at a time.
    """
    done = 0

    def advance(rows: int) -> None:
        nonlocal done
        done += rows
        if progress is not None:
            progress(done)

    running: _Chunk | None = None
    following: _Chunk | None = None
    try:
        for rows in source:
            following = _Chunk(rows, batch_size)
            following.start(executor, function, advance)
            if running is not None:
                yield running.finish(advance)
            running, following = following, None
        if running is not None:
            yield running.finish(advance)
    finally:
        for chunk in (following, running):
            if chunk is not None:
                chunk.close()


class _CsvWriter:
    """A CSV file: the header, then each chunk's rows, flushed (floats in full: ``repr``)."""

    def __init__(self, path: Path, columns: list[str]) -> None:
        self.stream: TextIO = path.open("w", newline="", encoding="utf-8")
        self.writer = csv.writer(self.stream)
        self.writer.writerow(columns)
        self.stream.flush()

    def write(self, table: list[FloatArray]) -> None:
        """Append a chunk's rows."""
        self.writer.writerows(zip(*(column.tolist() for column in table), strict=True))
        self.stream.flush()

    def __enter__(self) -> _CsvWriter:
        return self

    def __exit__(self, *_: object) -> None:
        self.stream.close()


class _ParquetWriter:
    """A Parquet file: float64 columns and a boolean ``feasible``, a row group per chunk."""

    def __init__(self, path: Path, columns: list[str]) -> None:
        import pyarrow as pa
        import pyarrow.parquet as pq

        self.pa = pa
        fields = [(name, pa.bool_() if name == "feasible" else pa.float64()) for name in columns]
        self.schema: pyarrow.Schema = pa.schema(fields)
        self.writer: pyarrow.parquet.ParquetWriter = pq.ParquetWriter(path, self.schema)

    def write(self, table: list[FloatArray]) -> None:
        """Append a chunk as one row group."""
        arrays = [self.pa.array(column) for column in table]
        chunk = self.pa.Table.from_arrays(arrays, schema=self.schema)
        self.writer.write_table(chunk, row_group_size=max(chunk.num_rows, 1))

    def __enter__(self) -> _ParquetWriter:
        return self

    def __exit__(self, *_: object) -> None:
        self.writer.close()  # the footer: the row groups written so far stay readable
