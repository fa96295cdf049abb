"""Evaluating on Dask: a running cluster (``--scheduler``) or a local one (``--workers``).

:class:`DaskExecutor` is an :class:`~fishtail_design.executors.Executor` on
``distributed.Client``: the batch function goes to every worker once, each batch is a task and the
results stream back as they complete. Before the client, the scheduler's handshake is probed under
a deadline (``distributed.Client`` bounds the TCP connection but not the handshake after it).
How to run a cluster: docs/design.md, "Scaling out".

A Dask nanny starts its worker with ``MALLOC_TRIM_THRESHOLD_=65536`` (Dask's
``distributed.nanny.pre-spawn-environ``), which fixes glibc's thresholds low: every array above
128 kB is then mapped and unmapped afresh, and a batch of designs (arrays of megabytes, made and
dropped by the hundred) costs 15 to 35 % more CPU than in a plain process. The local cluster is
started without it (the numerical libraries still held to one thread), and on any worker the
first task sets glibc's thresholds back to where a plain process's settle (:func:`_task`).
"""

from __future__ import annotations

import asyncio
import ctypes
import ctypes.util
import re
import sys
import threading
import uuid
from collections.abc import Callable, Iterator, Sequence
from typing import TYPE_CHECKING, Any, cast

from fishtail_design.errors import ExecutorError
from fishtail_design.executors import FloatArray, R, _Closing, _failure, _one_line

if TYPE_CHECKING:
    import distributed

#: Seconds a Dask scheduler has to answer (and, without workers, to get one) before giving up.
CONNECT_TIMEOUT_S = 10.0
#: What the local cluster's nannies set before starting a worker: one thread for each numerical
#: library (a worker runs one task at a time), and not Dask's MALLOC_TRIM_THRESHOLD_.
WORKER_ENVIRONMENT = {
    "OMP_NUM_THREADS": 1,
    "MKL_NUM_THREADS": 1,
    "OPENBLAS_NUM_THREADS": 1,
    "NUMBA_NUM_THREADS": 1,
}
#: glibc's largest mmap threshold (32 MB on 64-bit), where a plain process's settles once it has
#: freed arrays that large, and a trim threshold of twice it (mallopt's M_MMAP_THRESHOLD, -3,
#: and M_TRIM_THRESHOLD, -1).
_MMAP_THRESHOLD = 32 * 1024 * 1024
_M_MMAP_THRESHOLD, _M_TRIM_THRESHOLD = -3, -1
_malloc_set = False


def _set_malloc_thresholds() -> None:
    """Set glibc's mmap and trim thresholds where a plain process's settle (once, on Linux).

    Nothing elsewhere, or where the C library has no ``mallopt``.
    """
    global _malloc_set
    if _malloc_set:
        return
    _malloc_set = True
    if not sys.platform.startswith("linux"):
        return
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        libc.mallopt(_M_MMAP_THRESHOLD, _MMAP_THRESHOLD)
        libc.mallopt(_M_TRIM_THRESHOLD, 2 * _MMAP_THRESHOLD)
    except (OSError, AttributeError):
        pass


def _task(function: Callable[[FloatArray], R], batch: FloatArray) -> R:
    """A Dask task: ``function(batch)`` (``function`` arrives as the scattered batch function).

    The first task in a worker process sets glibc's thresholds (:func:`_set_malloc_thresholds`).
    """
    _set_malloc_thresholds()
    return function(batch)


def _import_distributed() -> Any:
    """Dask's ``distributed``, imported on first use (in-process and local runs need no Dask).

    Raises:
        ExecutorError: it is not installed.
    """
    try:
        import distributed
    except ImportError as error:
        raise ExecutorError(
            f"--workers and --scheduler need Dask (pip install distributed): {error}"
        ) from error
    return distributed


def _answers(address: str, timeout_s: float) -> None:
    """Return once a Dask server at ``address`` has answered a handshake.

    ``distributed.Client`` bounds the TCP connection by its timeout but not the handshake that
    follows, so that an address that accepts and stays silent would hang it: this bounds both,
    on an event loop of its own (the caller may be running one). The handshake gets a second
    more than the connection, so that a refusal is reported as one.

    Raises:
        ExecutorError: no answer within ``timeout_s``, naming the address.
    """
    from distributed.comm.core import connect

    async def handshake() -> None:
        comm = await asyncio.wait_for(connect(address, timeout=timeout_s), timeout_s + 1.0)
        await comm.close()

    failure: list[BaseException] = []

    def run() -> None:
        try:
            asyncio.run(handshake())
        except Exception as error:
            failure.append(error)

    thread = threading.Thread(target=run, name="dask-scheduler-probe", daemon=True)
    thread.start()
    thread.join(timeout_s + 6.0)
    if thread.is_alive() or failure:
        error = failure[0] if failure else None
        raise ExecutorError(
            f"the Dask scheduler at {address} does not answer within {timeout_s:g} s"
            + _reason(error)
        ) from error


def _reason(error: BaseException | None) -> str:
    """``: why`` from a failed connection (the refusal under Dask's "timed out"), or nothing."""
    while error is not None and error.__cause__ is not None:
        error = error.__cause__
    if error is None or isinstance(error, TimeoutError) or not str(error):
        return ""
    text = re.sub(r"^in <[^>]*>: ", "", _one_line(str(error)))  # Dask's comm names its connector
    return f": {text}"


class DaskExecutor(_Closing):
    """Runs the batches as the tasks of a Dask cluster (``--workers N``, ``--scheduler ADDRESS``).

    With ``scheduler`` it connects to a running cluster; with ``workers`` it starts a
    ``distributed.LocalCluster`` of single-threaded worker processes (which inherit this
    process's environment) and stops it on :meth:`close`. Each :meth:`map_batches` sends the
    batch function once to every worker and then one task per batch. A cluster's workers must
    import the batch function: the same fishtail install on every machine.
    """

    def __init__(
        self,
        scheduler: str | None = None,
        *,
        workers: int | None = None,
        timeout_s: float | None = None,
    ) -> None:
        """Connect to ``scheduler``, or start a local cluster of ``workers`` workers.

        Args:
            scheduler: a running scheduler's address, ``tcp://HOST:PORT``.
            workers: without ``scheduler``: the local cluster's worker processes.
            timeout_s: how long the scheduler has to answer, and, if it has no workers, to get
                one (default :data:`CONNECT_TIMEOUT_S`).

        Raises:
            ValueError: both or neither of ``scheduler`` and ``workers``, or fewer than one worker.
            ExecutorError: Dask is not installed, the scheduler does not answer or has no
                workers, or the local cluster does not start.
        """
        if (scheduler is None) == (workers is None):
            raise ValueError("DaskExecutor: give a scheduler's address or a number of workers")
        if workers is not None and workers < 1:
            raise ValueError(f"a Dask cluster needs at least one worker, not {workers}")
        timeout_s = CONNECT_TIMEOUT_S if timeout_s is None else timeout_s
        dask = _import_distributed()
        self._cluster: distributed.LocalCluster | None = None
        self._client: distributed.Client
        if scheduler is not None:
            self.address = scheduler
            self._client = self._connect(dask, scheduler, timeout_s)
            place = f"Dask at {scheduler}"
        else:
            try:
                import dask as dask_core

                # No dashboard, so no use for the workers' statistical profiler (which samples
                # the task's stack 100 times a second: some 2 % of a worker's core).
                settings = {
                    "distributed.nanny.pre-spawn-environ": WORKER_ENVIRONMENT,
                    "distributed.worker.profile.enabled": False,
                }
                with dask_core.config.set(settings):
                    self._cluster = dask.LocalCluster(
                        n_workers=workers,
                        threads_per_worker=1,
                        processes=True,
                        dashboard_address=None,
                    )
                self._client = dask.Client(self._cluster, set_as_default=False)
            except Exception as error:
                if self._cluster is not None:
                    self._cluster.close()
                raise ExecutorError(
                    f"could not start a local Dask cluster of {workers} workers: "
                    f"{type(error).__name__}: {_one_line(str(error))}"
                ) from error
            self.address = str(self._cluster.scheduler_address)
            place = f"local Dask cluster at {self.address}"
        self.description = f"{place}, {self._workers()}"

    @staticmethod
    def _connect(dask: Any, address: str, timeout_s: float) -> distributed.Client:
        """A client of the scheduler at ``address`` that has at least one worker."""
        _answers(address, timeout_s)
        try:
            client = dask.Client(address, timeout=timeout_s, set_as_default=False)
        except (OSError, TimeoutError) as error:
            raise ExecutorError(
                f"the Dask scheduler at {address} does not answer within {timeout_s:g} s"
                + _reason(error)
            ) from error
        try:
            client.wait_for_workers(1, timeout=timeout_s)
        except (OSError, TimeoutError) as error:
            client.close()
            raise ExecutorError(
                f"the Dask scheduler at {address} has no workers after {timeout_s:g} s: start "
                f"`dask worker {address}` on each machine"
            ) from error
        return client

    def _workers(self) -> str:
        """``2 workers`` (``2 workers, 8 threads`` when a worker runs several tasks at once)."""
        threads = cast(dict[str, int], self._client.nthreads())
        count, total = len(threads), sum(threads.values())
        text = f"{count} worker{'' if count == 1 else 's'}"
        return text if total == count else f"{text}, {total} threads"

    def map_batches(
        self, function: Callable[[FloatArray], R], batches: Sequence[FloatArray]
    ) -> Iterator[tuple[int, R]]:
        """``(index, function(batches[index]))`` as each task completes on the cluster.

        The batch function is scattered to every worker once, then each batch is a task.

        Raises:
            ExecutorError: the workers cannot take the batch function (they lack its module),
                a batch's task raised (its exception's text), or the scheduler went away.
        """
        from distributed import as_completed

        client = self._client
        try:
            shared = client.scatter(function, broadcast=True, hash=False)
        except Exception as error:
            raise ExecutorError(
                f"the Dask workers at {self.address} cannot take the batch function (every "
                f"worker needs the same fishtail install): {type(error).__name__}: "
                f"{_one_line(str(error))}"
            ) from error
        run = uuid.uuid4().hex[:8]
        pending = {
            client.submit(_task, shared, batch, key=f"fishtail-batch-{run}-{index}"): index
            for index, batch in enumerate(batches)
        }
        try:
            for future in as_completed(list(pending), loop=client.loop):
                index = pending.pop(future)
                try:
                    result = cast("R", future.result())
                except Exception as error:
                    raise ExecutorError(
                        _failure(index, f"on Dask at {self.address}", error)
                    ) from error
                future.release()  # the worker may drop the result
                yield index, result
        finally:
            if pending:
                client.cancel(list(pending))
            shared.release()

    def close(self) -> None:
        """Disconnect; stop the local cluster if this executor started it."""
        self._client.close()
        if self._cluster is not None:
            self._cluster.close()
