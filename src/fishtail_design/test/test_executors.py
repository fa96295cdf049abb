"""The executors: the same results in this process, in local processes and on Dask clusters.

The batch functions live in executor_toys (beside this file), which the worker processes import
by name. The tests that start processes are ``integration``; each waits for what it needs with a
deadline, and ends every process it started.
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import importlib
import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from types import ModuleType
from typing import Any, TypeVar

import numpy as np
import psutil
import pytest

from fishtail_common.command_line import OneLineErrorParser
from fishtail_design import dask_executor, executors
from fishtail_design.dask_executor import DaskExecutor
from fishtail_design.errors import ExecutorError
from fishtail_design.executor_options import add_executor_arguments, executor_from_arguments
from fishtail_design.executors import (
    BATCH_SIZE,
    InProcessExecutor,
    LocalProcessExecutor,
    evaluate_in_batches,
)

TEST_DIR = Path(__file__).resolve().parent
#: The directory that holds the fishtail_design package (for the separately started workers).
PACKAGE_ROOT = Path(executors.__file__).resolve().parents[1]
DESIGNS = np.random.default_rng(7).uniform(-2.0, 2.0, size=(203, 3))
T = TypeVar("T")


@pytest.fixture(scope="module")
def toys() -> Iterator[ModuleType]:
    """executor_toys, with this directory on sys.path while the module's tests run."""
    with pytest.MonkeyPatch.context() as patch:
        patch.syspath_prepend(str(TEST_DIR))
        yield importlib.import_module("executor_toys")


def within(seconds: float, what: str, call: Callable[..., T], *arguments: Any) -> T:
    """``call(*arguments)`` on a thread of its own; the test fails unless it returns in time.

    A hang then fails its test instead of stopping the run.
    """
    outcome: list[Any] = []

    def run() -> None:
        try:
            outcome.append((True, call(*arguments)))
        except BaseException as error:  # handed to the test's thread
            outcome.append((False, error))

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    thread.join(seconds)
    if not outcome:
        pytest.fail(f"{what} did not finish within {seconds:g} s")
    returned, value = outcome[0]
    if not returned:
        raise value
    return value  # type: ignore[no-any-return]


def assert_same(first: Any, second: Any) -> None:
    """Bit for bit: the same type, and each array of the same dtype, shape and bytes."""
    assert type(first) is type(second)
    firsts = first if isinstance(first, tuple) else (first,)
    seconds = second if isinstance(second, tuple) else (second,)
    for one, other in zip(firsts, seconds, strict=True):
        assert (one.dtype, one.shape) == (other.dtype, other.shape)
        assert one.tobytes() == other.tobytes()


def new_processes(before: set[int]) -> list[psutil.Process]:
    """This process's descendants not in ``before``, but for multiprocessing's resource tracker.

    (The tracker is one per interpreter, kept until it exits: not a worker.)
    """
    found = []
    for child in psutil.Process().children(recursive=True):
        with contextlib.suppress(psutil.NoSuchProcess):
            if child.pid not in before and "resource_tracker" not in " ".join(child.cmdline()):
                found.append(child)
    return found


def descendants() -> set[int]:
    return {child.pid for child in psutil.Process().children(recursive=True)}


class Reversed(InProcessExecutor):
    """Completes the batches last first: the join must not depend on the order."""

    def map_batches(self, function: Any, batches: Sequence[Any]) -> Iterator[tuple[int, Any]]:
        """The in-process results, last batch first."""
        results = list(super().map_batches(function, batches))
        yield from reversed(results)


# --------------------------------------------------------------------------------------------
# In this process


def test_batches_join_in_row_order_as_one_call_would(toys: ModuleType) -> None:
    function = functools.partial(toys.score, toys.Toy(1.7))
    whole = function(DESIGNS)
    for executor in (InProcessExecutor(), Reversed()):
        for batch_size in (1, 7, 64, 203, 1000):
            assert_same(evaluate_in_batches(executor, function, DESIGNS, batch_size), whole)


def test_progress_counts_the_designs_done_once_per_batch(toys: ModuleType) -> None:
    function = functools.partial(toys.score, toys.Toy(1.0))
    # 203 designs at most 50 a batch: five batches, of 41, 41, 41, 40 and 40.
    for executor, expected in ((InProcessExecutor(), [41, 82, 123, 163, 203]),
                               (Reversed(), [40, 80, 121, 162, 203])):  # fmt: skip
        done: list[int] = []
        evaluate_in_batches(executor, function, DESIGNS, 50, done.append)
        assert done == expected
    done = []
    evaluate_in_batches(InProcessExecutor(), function, DESIGNS[:100], 64, done.append)
    assert done == [50, 100]  # evenly: two batches of 50, not 64 and 36


def test_an_array_result_and_no_designs() -> None:
    double = functools.partial(np.multiply, 2.0)
    with InProcessExecutor() as executor:
        assert_same(evaluate_in_batches(executor, double, DESIGNS, 10), 2.0 * DESIGNS)
        done: list[int] = []
        empty = evaluate_in_batches(executor, double, np.empty((0, 3)), 10, done.append)
    assert empty.shape == (0, 3) and done == [0]


def test_bad_designs_batch_sizes_and_results_are_refused(toys: ModuleType) -> None:
    executor = InProcessExecutor()
    function = functools.partial(toys.score, toys.Toy(1.0))
    with pytest.raises(ValueError, match="2-D"):
        evaluate_in_batches(executor, function, DESIGNS[0], 10)
    with pytest.raises(ValueError, match="at least 1"):
        evaluate_in_batches(executor, function, DESIGNS, 0)
    with pytest.raises(ValueError, match=r"batch 0: result must be an array with a row per"):
        evaluate_in_batches(executor, functools.partial(np.sum, axis=None), DESIGNS, 10)
    with pytest.raises(ValueError, match=r"batch 0: objectives .* \(10\), not \(1, 2\)"):
        evaluate_in_batches(executor, lambda rows: function(rows[:1]), DESIGNS, 10)


def test_a_failing_batch_is_named_in_one_line(toys: ModuleType) -> None:
    designs = DESIGNS.copy()
    designs[25, 1] = 9.0
    function = functools.partial(toys.score, toys.Toy(1.0, limit=5.0))
    with pytest.raises(ExecutorError) as raised:
        evaluate_in_batches(InProcessExecutor(), function, designs, 10)
    message = str(raised.value)
    assert message.startswith("batch 2 failed in-process: ValueError: a design is over the limit 5")
    assert "\n" not in message and "9.0" in message
    assert isinstance(raised.value.__cause__, ValueError)


# --------------------------------------------------------------------------------------------
# The command line


def parse(*argv: str) -> argparse.Namespace:
    parser = OneLineErrorParser(prog="fishtail-design")
    add_executor_arguments(parser)
    return parser.parse_args(argv)


def test_the_options_name_the_executor_and_the_batch_size() -> None:
    arguments = parse()
    assert arguments.batch_size == BATCH_SIZE == 1024
    with executor_from_arguments(arguments) as executor:
        assert isinstance(executor, InProcessExecutor) and executor.description == "in-process"
    arguments = parse("--processes", "3", "--batch-size", "64")
    assert arguments.batch_size == 64
    with executor_from_arguments(arguments) as executor:  # no process starts before a batch
        assert isinstance(executor, LocalProcessExecutor)
        assert executor.description == "3 local processes"
    assert parse("--workers", "4").workers == 4
    assert parse("--scheduler", "tcp://10.0.0.5:8786").scheduler == "tcp://10.0.0.5:8786"
    assert parse("--scheduler", "tcp://[::1]:8786").scheduler == "tcp://[::1]:8786"


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--processes", "0"], "argument --processes: processes = 0 is outside [1, 1024]"),
        (["--workers", "two"], "argument --workers: not an integer: 'two'"),
        (["--batch-size", "0"], "argument --batch-size: batch_size = 0 is outside [1, 1000000]"),
        (["--batch-size", "2.5"], "argument --batch-size: not an integer: '2.5'"),
        (["--scheduler", "10.0.0.5:8786"], "expected tcp://HOST:PORT, got '10.0.0.5:8786'"),
        (["--scheduler", "tcp://10.0.0.5"], "expected tcp://HOST:PORT, got 'tcp://10.0.0.5'"),
        (["--scheduler", "tcp://host:99999"], "expected tcp://HOST:PORT"),
        (["--processes", "2", "--workers", "2"], "--workers: not allowed with argument --proc"),
        (["--workers", "2", "--scheduler", "tcp://h:1"], "not allowed with argument --workers"),
    ],
)
def test_bad_options_are_one_line_usage_errors(
    argv: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as raised:
        parse(*argv)
    assert raised.value.code == 2
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and message in error, error


def test_an_unreachable_scheduler_is_refused_in_one_line(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    pytest.importorskip("distributed")
    # Bound but not listening: refused (given time for the refusal to come back on a loaded
    # machine). Listening but never accepting: a silent scheduler (distributed.Client alone
    # would wait for its handshake for ever).
    with socket.socket() as refusing, socket.socket() as silent:
        refusing.bind(("127.0.0.1", 0))
        silent.bind(("127.0.0.1", 0))
        silent.listen()
        for sock, timeout_s in ((refusing, 5.0), (silent, 0.3)):
            monkeypatch.setattr(dask_executor, "CONNECT_TIMEOUT_S", timeout_s)
            address = f"tcp://127.0.0.1:{sock.getsockname()[1]}"
            # The deadline catches a hang; how fast the refusal comes is the machine's load's.
            with pytest.raises(ExecutorError) as raised:
                within(10.0, "refusing", executor_from_arguments, parse("--scheduler", address))
            # The reason after the address is the operating system's (a refused connection
            # says so; in a process where Dask has run before it may say nothing more).
            text = str(raised.value)
            assert text.startswith(
                f"the Dask scheduler at {address} does not answer within {timeout_s:g} s"
            ), text
            assert "\n" not in text


# --------------------------------------------------------------------------------------------
# Local processes and a LocalCluster


@pytest.fixture(scope="module")
def local_cluster(toys: ModuleType) -> Iterator[DaskExecutor]:
    """A LocalCluster of two workers (spawned with this process's sys.path: they find toys)."""
    pytest.importorskip("distributed")
    before = descendants()
    started = time.monotonic()
    executor = within(60.0, "starting a LocalCluster", lambda: DaskExecutor(workers=2))
    print(f"LocalCluster of 2 workers: {time.monotonic() - started:.2f} s to start")
    try:
        yield executor
    finally:
        started = time.monotonic()
        within(60.0, "stopping the LocalCluster", executor.close)
        print(f"LocalCluster: {time.monotonic() - started:.2f} s to stop")
        assert new_processes(before) == []


@pytest.mark.integration
def test_local_processes_and_a_local_cluster_give_the_in_process_results(
    toys: ModuleType, local_cluster: DaskExecutor
) -> None:
    function = functools.partial(toys.score, toys.Toy(2.3))
    expected = evaluate_in_batches(InProcessExecutor(), function, DESIGNS, 16)
    before = descendants()
    with LocalProcessExecutor(2) as pool:
        in_pool = within(60.0, "the pool", evaluate_in_batches, pool, function, DESIGNS, 16)
        assert len(new_processes(before)) == 2
    assert new_processes(before) == []  # closing ends the pool's processes
    assert_same(in_pool, expected)
    assert local_cluster.description.startswith("local Dask cluster at tcp://127.0.0.1:")
    assert local_cluster.description.endswith(", 2 workers")
    done: list[int] = []
    on_cluster = within(
        60.0, "the cluster", evaluate_in_batches, local_cluster, function, DESIGNS, 16, done.append
    )
    assert_same(on_cluster, expected)
    assert sorted(done) == done and len(done) == 13 and done[-1] == 203


@pytest.mark.integration
def test_a_failing_batch_is_named_with_the_workers_message(
    toys: ModuleType, local_cluster: DaskExecutor
) -> None:
    designs = DESIGNS.copy()
    designs[41, 0] = 7.5
    function = functools.partial(toys.score, toys.Toy(1.0, limit=5.0))
    with LocalProcessExecutor(2) as pool:
        for executor, where in ((pool, "in a local process"), (local_cluster, "on Dask at tcp://")):
            with pytest.raises(ExecutorError) as raised:
                within(60.0, "a failure", evaluate_in_batches, executor, function, designs, 20)
            message = str(raised.value)
            assert message.startswith(f"batch 2 failed {where}"), message
            row = ", ".join(repr(value) for value in designs[41].tolist())
            assert message.endswith(f"ValueError: a design is over the limit 5: | [{row}]"), message
        # Both still work after a failure.
        double = functools.partial(np.multiply, 2.0)
        for executor in (pool, local_cluster):
            result = within(60.0, "again", evaluate_in_batches, executor, double, designs, 50)
            assert_same(result, 2.0 * designs)


@pytest.mark.integration
def test_results_come_back_as_the_batches_complete(
    toys: ModuleType, local_cluster: DaskExecutor, tmp_path: Path
) -> None:
    # Batch 0 waits for a file that the test writes only once batch 1's result is back: the
    # result of a later batch arrives while an earlier one is still running.
    batches = [np.full((4, 2), -1.0), np.full((4, 2), 1.0), np.full((4, 2), 2.0)]
    with LocalProcessExecutor(2) as pool:
        for name, executor in (("pool", pool), ("cluster", local_cluster)):
            gate = tmp_path / f"{name}.gate"
            results = executor.map_batches(functools.partial(toys.gated, str(gate)), batches)
            first = within(60.0, f"the {name}'s first result", next, results)
            assert first[0] != 0
            gate.touch()
            rest = within(60.0, f"the {name}'s other results", list, results)
            assert sorted(index for index, _ in [first, *rest]) == [0, 1, 2]
            for index, result in [first, *rest]:
                assert_same(result, 2.0 * batches[index])


# --------------------------------------------------------------------------------------------
# A cluster of separate processes, started with Dask's own commands


def start(argv: list[str], log: Path, env: dict[str, str]) -> subprocess.Popen[bytes]:
    """``argv`` in a process group of its own (its children too), its output to ``log``."""
    with log.open("wb") as output:
        return subprocess.Popen(
            argv, stdout=output, stderr=subprocess.STDOUT, env=env, start_new_session=True
        )


def stop(process: subprocess.Popen[bytes]) -> None:
    """SIGTERM to the process's group, SIGKILL after 20 s; then none of the group is left."""
    with contextlib.suppress(ProcessLookupError):
        os.killpg(process.pid, signal.SIGTERM)
    try:
        process.wait(20.0)
    except subprocess.TimeoutExpired:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(process.pid, signal.SIGKILL)
        process.wait(10.0)
    deadline = time.monotonic() + 20.0
    while group_members(process.pid) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert group_members(process.pid) == []


def group_members(group: int) -> list[int]:
    """The live (not zombie) processes of process group ``group``."""
    found = []
    for candidate in psutil.process_iter(["status"]):
        with contextlib.suppress(psutil.NoSuchProcess, ProcessLookupError):
            alive = candidate.info["status"] != psutil.STATUS_ZOMBIE
            if alive and os.getpgid(candidate.pid) == group:
                found.append(candidate.pid)
    return found


def scheduler_address_in(path: Path, scheduler: subprocess.Popen[bytes], log: Path) -> str:
    """The address in the scheduler file once it is written (60 s at most)."""
    deadline = time.monotonic() + 60.0
    while time.monotonic() < deadline:
        if scheduler.poll() is not None:
            pytest.fail(f"dask scheduler ended ({scheduler.returncode}):\n{log.read_text()}")
        with contextlib.suppress(FileNotFoundError, json.JSONDecodeError, KeyError):
            return str(json.loads(path.read_text())["address"])
        time.sleep(0.02)
    pytest.fail(f"no scheduler file {path} within 60 s:\n{log.read_text()}")


@pytest.mark.integration
def test_a_scheduler_and_two_workers_started_apart_give_the_in_process_results(
    toys: ModuleType, tmp_path: Path
) -> None:
    distributed = pytest.importorskip("distributed")
    dask = Path(sys.executable).with_name("dask")
    assert dask.exists(), f"no `dask` command beside {sys.executable}"
    scheduler_file = tmp_path / "scheduler.json"
    path = [str(TEST_DIR), str(PACKAGE_ROOT), *os.environ.get("PYTHONPATH", "").split(os.pathsep)]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(part for part in path if part)}
    function = functools.partial(toys.score, toys.Toy(0.9))
    expected = evaluate_in_batches(InProcessExecutor(), function, DESIGNS, 32)
    processes: list[subprocess.Popen[bytes]] = []
    try:
        started = time.monotonic()
        log = tmp_path / "scheduler.log"
        processes.append(start([str(dask), "scheduler", "--host", "127.0.0.1", "--port", "0",
                                "--no-dashboard", "--scheduler-file", str(scheduler_file)],
                               log, env))  # fmt: skip
        address = scheduler_address_in(scheduler_file, processes[0], log)
        print(f"dask scheduler: {time.monotonic() - started:.2f} s to its scheduler file")

        # No workers yet: refused in one line, naming the address.
        with pytest.raises(ExecutorError) as raised:
            within(30.0, "connecting", functools.partial(DaskExecutor, address, timeout_s=1.0))
        assert str(raised.value) == (
            f"the Dask scheduler at {address} has no workers after 1 s: start "
            f"`dask worker {address}` on each machine"
        )

        started = time.monotonic()
        for number in range(2):
            processes.append(start([str(dask), "worker", "--scheduler-file", str(scheduler_file),
                                    "--nthreads", "1", "--no-dashboard", "--local-directory",
                                    str(tmp_path / f"worker-{number}")],
                                   tmp_path / f"worker-{number}.log", env))  # fmt: skip
        with distributed.Client(address, timeout=30, set_as_default=False) as client:
            client.wait_for_workers(2, timeout=60)
        print(f"two dask workers: {time.monotonic() - started:.2f} s until both are registered")

        with DaskExecutor(address) as executor:
            assert executor.description == f"Dask at {address}, 2 workers"
            done: list[int] = []
            result = within(
                60.0, "Dask", evaluate_in_batches, executor, function, DESIGNS, 32, done.append
            )
        assert_same(result, expected)
        assert len(done) == 7 and done[-1] == 203
    except BaseException:
        for log in sorted(tmp_path.glob("*.log")):
            print(f"--- {log.name}\n{log.read_text()[-3000:]}")
        raise
    finally:
        started = time.monotonic()
        for process in reversed(processes):
            stop(process)
        print(f"stopping the dask processes: {time.monotonic() - started:.2f} s")
