"""Where a population is evaluated: in this process, in local processes or on a Dask cluster.

The synthesis evaluates its designs as batches, 2-D float arrays of designs x variables. An
:class:`Executor` maps a batch function over them and hands each result back as it completes;
:func:`evaluate_in_batches` splits the designs into batches, maps them and joins the results in
row order, the same bit for bit whichever executor ran them and in whatever order they finished.

A batch function is a top-level function, or a :func:`functools.partial` that binds a problem to
one, that takes a batch and returns an array or a NamedTuple of arrays with a row per design. It
travels to the other processes by pickling, as its module and name: every process that runs it,
local or on another machine, must be able to import it, that is have the same fishtail install.

The command line chooses (:mod:`~fishtail_design.executor_options`):
``--processes N`` (:class:`LocalProcessExecutor`), ``--workers N`` (a local Dask cluster) or
``--scheduler tcp://HOST:PORT`` (an existing one, both
:class:`~fishtail_design.dask_executor.DaskExecutor`), else
:class:`InProcessExecutor`; ``--batch-size`` sets the designs per task. docs/design.md, "Scaling
out", says how to run a cluster.

>>> import functools
>>> designs = np.arange(6.0).reshape(3, 2)
>>> with InProcessExecutor() as executor:
...     evaluate_in_batches(executor, functools.partial(np.multiply, 2.0), designs, 2)
array([[ 0.,  2.],
       [ 4.,  6.],
       [ 8., 10.]])
"""

from __future__ import annotations

import concurrent.futures
import multiprocessing
import signal
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures.process import BrokenProcessPool
from typing import TYPE_CHECKING, Protocol, Self, TypeVar, cast

import numpy as np
import numpy.typing as npt

from fishtail_design.errors import ExecutorError

if TYPE_CHECKING:
    from types import TracebackType

FloatArray = npt.NDArray[np.float64]
#: What a batch function returns: an array or a NamedTuple of arrays, a row per design.
R = TypeVar("R")

#: The most designs in a task unless --batch-size says otherwise. The compiled search tier
#: scores a mechanism-1 design in some 50 to 80 µs (numpy's path, and mechanism 2, in 1 to 10
#: ms), so that a task of 1024 takes 0.05 to 0.1 s: well above a task's overhead (under a
#: millisecond in a local pool, 10 to 20 ms on Dask). A population of 100 is then one task: it
#: is scored faster than it could be shipped; a sweep's chunks are many.
BATCH_SIZE = 1024

class Executor(Protocol):
    """Runs a batch function over batches, somewhere, and hands back each result as it completes.

    Use it as a context manager, or call :meth:`close`: it may own processes or a connection.
    """

    @property
    def description(self) -> str:
        """Where the batches run, for progress lines: ``in-process``, ``4 local processes``."""
        ...

    def map_batches(
        self, function: Callable[[FloatArray], R], batches: Sequence[FloatArray]
    ) -> Iterator[tuple[int, R]]:
        """``(index, function(batches[index]))`` for every batch, in the order they complete.

        Args:
            function: a picklable batch function (see the module's docstring).
            batches: the batches, 2-D float arrays (designs x variables).

        Raises:
            ExecutorError: a batch that failed (naming its index and the exception's text), or
                an executor that stopped answering; the batches not yet run are cancelled.
        """
        ...

    def close(self) -> None:
        """Stop what the executor started (processes, a cluster, a connection)."""
        ...

    def __enter__(self) -> Self:
        """The executor itself."""
        ...

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        """:meth:`close`."""
        ...


class _Closing:
    """Context-manager use of an executor: ``close()`` on the way out."""

    def close(self) -> None:
        """Nothing to stop."""

    def __enter__(self) -> Self:
        """The executor itself."""
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        error: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        """:meth:`close`."""
        self.close()


def _one_line(text: str) -> str:
    """``text`` with its lines joined by `` | `` (a worker's message may span several)."""
    return " | ".join(line.strip() for line in text.strip().splitlines() if line.strip())


def _failure(index: int, where: str, error: BaseException) -> str:
    """The message of a failed batch: its index, where it ran, the exception's type and text."""
    text = _one_line(str(error))
    return f"batch {index} failed {where}: {type(error).__name__}" + (f": {text}" if text else "")


class InProcessExecutor(_Closing):
    """Runs the batches one after the other in this process (the default)."""

    description = "in-process"

    def map_batches(
        self, function: Callable[[FloatArray], R], batches: Sequence[FloatArray]
    ) -> Iterator[tuple[int, R]]:
        """``(index, function(batches[index]))`` in batch order.

        Raises:
            ExecutorError: a batch whose function raised (chained to the exception).
        """
        for index, batch in enumerate(batches):
            try:
                result = function(batch)
            except Exception as error:
                raise ExecutorError(_failure(index, "in-process", error)) from error
            yield index, result


def _ignore_interrupts() -> None:
    """A pool process's start: Ctrl-C is the parent's to handle (it cancels and shuts down)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


class LocalProcessExecutor(_Closing):
    """Runs the batches in a pool of local processes (``--processes N``).

    The processes are spawned (new interpreters, not forks: the caller may hold threads) on the
    first batches and kept until :meth:`close`; the batch function is pickled with each batch.
    """

    def __init__(self, processes: int) -> None:
        """Prepare a pool of ``processes`` processes.

        Raises:
            ValueError: fewer than one process.
        """
        if processes < 1:
            raise ValueError(f"a process pool needs at least one process, not {processes}")
        self.processes = processes
        self.description = f"{processes} local process{'' if processes == 1 else 'es'}"
        self._pool = concurrent.futures.ProcessPoolExecutor(
            max_workers=processes,
            mp_context=multiprocessing.get_context("spawn"),
            initializer=_ignore_interrupts,
        )

    def map_batches(
        self, function: Callable[[FloatArray], R], batches: Sequence[FloatArray]
    ) -> Iterator[tuple[int, R]]:
        """``(index, function(batches[index]))`` as each batch completes in the pool.

        Raises:
            ExecutorError: a batch whose function raised, or a process that died.
        """
        index_of: dict[concurrent.futures.Future[R], int] = {}
        try:
            for index, batch in enumerate(batches):
                try:
                    index_of[self._pool.submit(function, batch)] = index
                except BrokenProcessPool as error:
                    raise ExecutorError(_failure(index, "to start", error)) from error
            for future in concurrent.futures.as_completed(index_of):
                index = index_of[future]
                try:
                    result = future.result()
                except BrokenProcessPool as error:
                    message = "a local process died (killed, out of memory?) while running it"
                    raise ExecutorError(f"batch {index}: {message}: {error}") from error
                except Exception as error:
                    raise ExecutorError(_failure(index, "in a local process", error)) from error
                yield index, result
        finally:
            for future in index_of:
                future.cancel()

    def close(self) -> None:
        """Cancel the batches not started, wait for the running ones and end the processes."""
        self._pool.shutdown(wait=True, cancel_futures=True)


def evaluate_in_batches(
    executor: Executor,
    function: Callable[[FloatArray], R],
    designs: npt.ArrayLike,
    batch_size: int,
    progress: Callable[[int], None] | None = None,
) -> R:
    """``function`` over the rows of ``designs``, batch by batch on ``executor``, joined in order.

    The rows are shared out evenly over as few batches of at most ``batch_size`` rows as will do
    (100 rows at 64 a batch: two of 50), each batch a copy; no rows make one empty batch. The
    results are joined in row order whatever order they complete in: arrays, or each field of a
    NamedTuple of arrays, concatenated along their first axis.

    Args:
        executor: where the batches run.
        function: a picklable batch function returning an array or a NamedTuple of arrays with
            a row per design.
        designs: the designs, a 2-D float array (designs x variables).
        batch_size: the most designs in a batch, at least one.
        progress: called with the number of designs done each time a batch's result arrives.

    Raises:
        ValueError: ``designs`` not 2-D, a batch size below one, or a result that is not an
            array or NamedTuple of arrays with a row per design of its batch.
        ExecutorError: a batch that failed, from the executor.
    """
    rows = np.asarray(designs, dtype=np.float64)
    if rows.ndim != 2:
        raise ValueError(f"designs must be a 2-D array (designs x variables), not {rows.ndim}-D")
    if batch_size < 1:
        raise ValueError(f"batch size must be at least 1, not {batch_size}")
    count = max(1, -(-rows.shape[0] // batch_size))
    batches = [batch.copy() for batch in np.array_split(rows, count)]
    results: dict[int, R] = {}
    done = 0
    for index, result in executor.map_batches(function, batches):
        _check_rows(index, result, batches[index].shape[0])
        results[index] = result
        done += batches[index].shape[0]
        if progress is not None:
            progress(done)
    if len(results) != len(batches):
        missing = sorted(set(range(len(batches))) - set(results))
        raise ExecutorError(f"{executor.description} returned no result for batches {missing}")
    return _joined([results[index] for index in range(len(batches))])


def _parts(result: object) -> tuple[tuple[str, object], ...]:
    """A result's arrays by name: the fields of a NamedTuple, or ``result`` for an array."""
    fields = getattr(result, "_fields", None)
    if isinstance(result, tuple) and fields is not None:
        return tuple(zip(fields, result, strict=True))
    return (("result", result),)


def _check_rows(index: int, result: object, rows: int) -> None:
    """Refuse a result whose arrays do not have a row per design of batch ``index``."""
    for name, value in _parts(result):
        if not isinstance(value, np.ndarray) or value.ndim == 0 or value.shape[0] != rows:
            shape = value.shape if isinstance(value, np.ndarray) else type(value).__name__
            raise ValueError(
                f"batch {index}: {name} must be an array with a row per design ({rows}), "
                f"not {shape}"
            )


def _joined(results: list[R]) -> R:
    """The results of the batches in order, joined: arrays (or NamedTuple fields) concatenated."""
    first = results[0]
    if isinstance(first, np.ndarray):
        return cast("R", np.concatenate(cast(list[np.ndarray], results)))
    columns = zip(*cast(list[tuple[np.ndarray, ...]], results), strict=True)
    return type(first)(*(np.concatenate(column) for column in columns))
