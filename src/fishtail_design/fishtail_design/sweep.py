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
With ``parts=True`` (:func:`sweep`) the output is instead a folder of Parquet files, one per
chunk (:func:`part_name`), each scored and written by the worker that runs the chunk: the client
only hands out designs and gathers a count per chunk, so that it does not become the bottleneck of
a cluster; read back as one dataset, the folder holds the same table as the single file. Once
every part is written the folder gets :data:`COMPLETE_NAME` (which dataset readers skip): a folder
without it is a sweep that stopped part-way, whose missing chunks a reader would not notice.
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
import json
import math
import os
import time
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
#: Chunks in one executor map when the workers write the parts; two maps are open at a time, so
#: that up to twice as many chunks are queued or running (each a task, a few designs x variables
#: of input and a count of output) and no worker waits for the client.
PARTS_PER_MAP = 4


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
    """What a sweep wrote: its designs and how many of them are feasible.

    A parts sweep also says what its tasks took, summed over the chunks: seconds scoring and
    seconds making and writing the parts (wall time in the task), and the tasks' CPU seconds
    (0 for a sweep that writes one file).
    """

    designs: int
    feasible: int
    scoring_s: float = 0.0
    writing_s: float = 0.0
    task_cpu_s: float = 0.0


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
    parts: bool = False,
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
        parts: ``path`` (``.parquet``) is a folder, and each chunk is one task that scores the
            chunk and writes it there as a Parquet file of its own (:func:`part_name`), where it
            runs: on a cluster the folder must be on a filesystem that every worker shares.
            ``batch_size`` does not apply (a chunk is a task). The client holds at most
            2 x :data:`PARTS_PER_MAP` chunks of designs. A sweep that stops part-way leaves the
            parts done, which need not be consecutive: part k holds chunk k's designs; only a
            whole sweep writes :data:`COMPLETE_NAME` last.

    Raises:
        DesignError: an output file of another suffix, parts of a CSV file, or a parts folder
            whose name is an existing file.
        ExecutorError: a batch that failed.
        OSError: the file cannot be written.
    """
    suffix = output_format(path)
    if batch_size < 1:
        raise ValueError(f"the batch size must be at least 1, not {batch_size}")
    if parts:
        if suffix != ".parquet":
            raise DesignError(f"{path}: parts are Parquet files: name the folder *.parquet")
        return _sweep_parts(problem, points, path, executor, chunk_size, progress, function)
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


#: The file a parts sweep writes last, once every part is in the folder: ``{"parts": chunks,
#: "designs": rows, "feasible": rows}``. The leading underscore makes Parquet readers skip it.
COMPLETE_NAME = "_complete.json"


def part_name(index: int) -> str:
    """The file of chunk ``index`` in a parts folder: ``part-000042.parquet``.

    Zero-padded, so that the files sort in the chunks' order (as a Parquet dataset's readers
    take them) up to a million chunks, and by number beyond.
    """
    return f"part-{index:06d}.parquet"


def write_part(
    problem: Problem,
    folder: str,
    function: Callable[[FloatArray], Scores] | None,
    batch: FloatArray,
) -> FloatArray:
    """A parts sweep's task: score a chunk and write it to ``folder`` as its part file.

    ``batch``: the chunk's index in the first column, then its designs (the optimiser's rows).
    The file is written under a name that readers skip (a leading dot) and renamed when whole,
    so that the folder never holds a part cut short. Returns ``[[index, designs, feasible,
    seconds scoring, seconds writing, CPU seconds]]``.
    """
    started, cpu = time.perf_counter(), time.process_time()
    index = int(batch[0, 0])
    rows = np.ascontiguousarray(batch[:, 1:])
    scores = (function or functools.partial(evaluate_rows, problem))(rows)
    scored = time.perf_counter()
    table = sweep_table(problem, rows, scores)
    final = Path(folder) / part_name(index)
    partial = final.with_name(f".{final.name}.{os.getpid()}")
    try:
        with _ParquetWriter(partial, sweep_columns(problem)) as writer:
            writer.write(table)
        os.replace(partial, final)
    finally:
        partial.unlink(missing_ok=True)
    feasible = int(np.count_nonzero(table[sweep_columns(problem).index("feasible")]))
    now = time.perf_counter()
    spent = (scored - started, now - scored, time.process_time() - cpu)
    return np.array([[index, rows.shape[0], feasible, *spent]], dtype=float)


def _parts_folder(path: Path) -> None:
    """Make the folder ``path``, or empty an existing one of its part files.

    Raises:
        DesignError: ``path`` is an existing file.
    """
    if path.exists() and not path.is_dir():
        raise DesignError(f"{path}: a parts sweep writes a folder, and this is a file")
    path.mkdir(parents=True, exist_ok=True)
    stale_files = (*path.glob("part-*.parquet"), *path.glob(".part-*.parquet.*"))
    for stale in (path / COMPLETE_NAME, *stale_files):
        stale.unlink(missing_ok=True)


def _sweep_parts(
    problem: Problem,
    points: FloatArray | Grid,
    folder: Path,
    executor: Executor,
    chunk_size: int,
    progress: Callable[[int], None] | None,
    function: Callable[[FloatArray], Scores] | None,
) -> SweepResult:
    """:func:`sweep` with ``parts``: a task per chunk, writing its part; counts gathered."""
    _parts_folder(folder)
    task = functools.partial(write_part, problem, str(folder.resolve()), function)
    written = feasible = parts = 0
    spent = np.zeros(3)
    for summary in _mapped_in_groups(executor, task, _tagged(chunks(points, chunk_size))):
        written += int(summary[0, 1])
        feasible += int(summary[0, 2])
        parts += 1
        spent += summary[0, 3:6]
        if progress is not None:
            progress(written)
    complete = {"parts": parts, "designs": written, "feasible": feasible}
    (folder / COMPLETE_NAME).write_text(json.dumps(complete) + "\n", encoding="utf-8")
    return SweepResult(written, feasible, *(float(value) for value in spent))


def _tagged(source: Iterable[FloatArray]) -> Iterator[FloatArray]:
    """Each chunk with its index in a first column (the task names its part by it)."""
    for index, rows in enumerate(source):
        batch = np.empty((rows.shape[0], rows.shape[1] + 1))
        batch[:, 0] = index
        batch[:, 1:] = rows
        yield batch


def _mapped_in_groups(
    executor: Executor, task: Callable[[FloatArray], FloatArray], source: Iterator[FloatArray]
) -> Iterator[FloatArray]:
    """``task`` over every batch of ``source``, :data:`PARTS_PER_MAP` batches a map.

    The next map starts before the current one's results are all in (the executors submit a
    map's batches when its first result is asked for), so that the workers always have tasks
    queued; at most two maps' batches are held. Results come as each map's complete.

    Raises:
        ExecutorError: a task that failed, or one without a result.
    """
    running: Iterator[tuple[int, FloatArray]] | None = None
    following: Iterator[tuple[int, FloatArray]] | None = None
    held: list[FloatArray] = []
    expected = 0
    try:
        while True:
            group = [batch for _, batch in zip(range(PARTS_PER_MAP), source, strict=False)]
            following = executor.map_batches(task, group) if group else None
            first = next(following, None) if following is not None else None
            if running is not None:
                results = held + [result for _, result in running]
                _close(running)
                if len(results) != expected:
                    raise ExecutorError("the executor returned no result for a part of the sweep")
                yield from results
            if following is None:
                return
            running, held, expected = following, [first[1]] if first else [], len(group)
            following = None
    finally:
        for stream in (following, running):
            if stream is not None:
                _close(stream)


def _close(stream: Iterator[object]) -> None:
    """Stop a map (the executor cancels the batches not yet run)."""
    close = getattr(stream, "close", None)
    if close is not None:
        close()


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
