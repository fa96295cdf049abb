"""Large batches a block at a time: cache-sized blocks, run on up to one thread per core.

numpy evaluates an expression one operation at a time over whole arrays, so on a million samples
every temporary goes out to main memory and back. Cut into blocks of :data:`BLOCK_SAMPLES`, a
block's temporaries stay in the processor's cache; and since numpy releases the GIL inside its
loops, blocks evaluated on several threads use several cores without any other dependency.

>>> [(block.start, block.stop) for block in block_slices(5, block_samples=2)]
[(0, 2), (2, 4), (4, 5)]
>>> done = []
>>> run_blocks(lambda block: done.append(block.start), 5, workers=2, block_samples=2)
>>> sorted(done)
[0, 2, 4]
"""

from __future__ import annotations

import itertools
import os
import threading
from collections.abc import Callable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor

#: Samples evaluated together. A block's arrays are 128 kB, so the few dozen temporaries of a
#: solve stay in the processor's L2/L3 cache: about twice as fast as whole arrays of a million
#: samples, and the peak memory is the outputs' alone. Much smaller blocks pay numpy's fixed cost
#: per call instead (about 1 us a call, a few dozen calls a block).
BLOCK_SAMPLES = 16384

#: Threads are used from this many blocks on: handing a block to a thread costs some 10-50 us,
#: a block of the engine takes about 1 ms.
THREADED_MIN_BLOCKS = 2

_pool_lock = threading.Lock()
_pool: ThreadPoolExecutor | None = None
_pool_threads = 0


def block_slices(size: int, block_samples: int = BLOCK_SAMPLES) -> Iterator[slice]:
    """Consecutive slices of at most ``block_samples`` covering ``range(size)``."""
    for start in range(0, size, block_samples):
        yield slice(start, min(start + block_samples, size))


def default_workers() -> int:
    """Threads a big batch uses by default: the cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def _thread_pool(threads: int) -> ThreadPoolExecutor:
    """A process-wide pool with at least ``threads`` threads (kept between calls)."""
    global _pool, _pool_threads
    with _pool_lock:
        if _pool is None or _pool_threads < threads:
            if _pool is not None:
                _pool.shutdown(wait=False)
            _pool = ThreadPoolExecutor(threads, thread_name_prefix="fishtail-blocks")
            _pool_threads = threads
        return _pool


def run_blocks(
    task: Callable[[slice], None],
    size: int,
    workers: int | None = None,
    block_samples: int = BLOCK_SAMPLES,
) -> None:
    """Call ``task`` once for every block of ``range(size)``, on up to ``workers`` threads.

    ``workers`` None means :func:`default_workers`; 1 runs every block on the calling thread. The
    blocks are handed out one at a time, so a worker on a busy core simply takes fewer. The
    tasks must write disjoint outputs.

    Raises:
        ValueError: ``workers`` < 1.
        Exception: the first exception any task raised, after every thread has stopped.
    """
    if workers is None:
        workers = default_workers()
    if workers < 1:
        raise ValueError(f"workers must be at least 1, got {workers}")
    blocks = list(block_slices(size, block_samples))
    threads = min(workers, len(blocks))
    if threads < 2 or len(blocks) < THREADED_MIN_BLOCKS:
        for block in blocks:
            task(block)
        return
    # next() on an itertools.count is atomic under the GIL: each block is taken exactly once.
    next_index = itertools.count()
    failed = threading.Event()

    def work() -> None:
        while not failed.is_set():
            index = next(next_index)
            if index >= len(blocks):
                return
            try:
                task(blocks[index])
            except BaseException:
                failed.set()
                raise

    pool = _thread_pool(threads - 1)
    helpers: list[Future[None]] = [pool.submit(work) for _ in range(threads - 1)]
    error: BaseException | None = None
    try:
        work()  # the calling thread takes blocks too
    except BaseException as caught:
        error = caught
    for helper in helpers:
        helper_error = helper.exception()
        if error is None:
            error = helper_error
    if error is not None:
        raise error
