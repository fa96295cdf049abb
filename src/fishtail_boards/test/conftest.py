"""Fixtures of the board tests: emulated boards, backends, node processes, a ROS probe.

* ``fake_board(**config)``: an emulated board (:class:`fishtail_boards.board_pty.FakeBoard`) on
  a real pty, served by a thread of this process, with a symlink in tmp_path; stopped at teardown.
* ``board_process(link, *args)``: ``python -m fishtail_boards.fake_board`` as a process (what
  ``fishtail-fake-board`` runs), its pty path read from its stdout; killed at teardown.
* ``serial_backend(port, opener=None, **config)``: a started :class:`SerialBackend`; closed at
  teardown.
* ``firmware_build``: the real firmware and its simulator, built by ``make test``'s set-up
  (tools/test-firmware.sh); skips with one line saying why where they are not built.
  ``fishtail_build``: the same for the project's firmware (build/firmware/fishtail).
* ``either_board(encoder_offset=0)``: parametrised over the boards, ``fake`` (the project's
  emulation of the stock firmware, a DC motor), ``fake_fishtail`` (the emulation of the
  project's firmware), ``firmware`` (ROSArduinoBridge in simavr, the same DC motor) and
  ``fishtail`` (the project's firmware in simavr), all the Pololu 37D 30:1 with its 64-count
  encoder: a :class:`BoardUnderTest` (link, reset, the board's own clock; ``project_firmware``
  says whether it runs the project's firmware, which follows a speed profile itself).
* ``raw_port(path)``: the board's serial port in raw mode, one command and its reply at a time.
* ``wait_until``, ``driver_run``, ``ros_probe``: :mod:`fishtail_testkit.driver_nodes`.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import queue
import select
import signal
import subprocess
import sys
import threading
import time
import tty
from collections.abc import Callable
from pathlib import Path

import pytest

from fishtail_boards.avr_board import (
    PROJECT_FIRMWARE_DIR,
    SimulatedBoard,
    built_artifacts,
    encoder_offset_pokes,
    firmware_variables,
)
from fishtail_boards.board_motors import DcChannelMotor
from fishtail_boards.board_pty import BoardConfig, FakeBoard
from fishtail_driver.serial_backend import SerialBackend
from fishtail_driver.serial_config import SerialConfig
from fishtail_plant.motor.board_units import Scale
from fishtail_testkit.driver_nodes import (  # noqa: F401 - fixtures, registered by name
    driver_process,
    driver_run,
    ros,
    ros_domain,
    ros_probe,
    wait_until,
)
from fishtail_testkit.firmware import built_firmware_or_skip

POLL_S = 0.005


class BoardHandle:
    """An in-process FakeBoard served by a thread."""

    def __init__(self, board: FakeBoard, link: Path) -> None:
        """Start serving ``board``."""
        self.board = board
        self.link = link
        self.paths: list[str] = []
        self.thread = threading.Thread(target=board.run, name="fake-board", daemon=True)

    def commands(self, prefix: str = "") -> list[str]:
        """Commands the board ran so far (text, without the CR) starting with ``prefix``."""
        return [text for _, text in list(self.board.commands) if text.startswith(prefix)]

    def stop(self) -> None:
        """Stop the loop and release everything."""
        self.board.stop()
        self.thread.join(5.0)
        self.board.close()


@pytest.fixture
def fake_board(tmp_path) -> Callable[..., BoardHandle]:
    """Start emulated boards: ``fake_board(link=None, log=None, **BoardConfig fields)``."""
    handles: list[BoardHandle] = []

    def start(link: Path | None = None, log: Path | None = None, **config) -> BoardHandle:
        link = link or tmp_path / f"board{len(handles)}"
        holder: list[BoardHandle] = []
        announced = threading.Event()

        def announce(path: str) -> None:
            holder[0].paths.append(path)
            announced.set()

        board = FakeBoard(
            BoardConfig(**config), link=str(link), log_path=str(log) if log else None,
            announce=announce,
        )  # fmt: skip
        handle = BoardHandle(board, link)
        holder.append(handle)
        handles.append(handle)
        handle.thread.start()
        assert announced.wait(5.0), "the fake board did not open its pty"
        return handle

    yield start
    for handle in handles:
        handle.stop()


class BoardProcess:
    """``python -m fishtail_boards.fake_board ...`` with its stdout lines collected."""

    def __init__(self, argv: list[str], stderr_path: Path) -> None:
        """Start it and a thread that reads its stdout (the pty paths it announces)."""
        self.argv = argv
        self.stderr_path = stderr_path
        self.lines: queue.Queue[str] = queue.Queue()
        with open(stderr_path, "wb") as err:
            self.popen = subprocess.Popen(
                argv, env=dict(os.environ), stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                stderr=err, text=True, start_new_session=True,
            )  # fmt: skip
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        for line in self.popen.stdout:
            self.lines.put(line.strip())

    def next_path(self, timeout: float = 10.0) -> str:
        """The next pty path it prints."""
        try:
            return self.lines.get(timeout=timeout)
        except queue.Empty:
            pytest.fail(
                f"fake board printed no path within {timeout} s: "
                f"{self.stderr_path.read_text(errors='replace')}"
            )

    def kill(self, signum: int = signal.SIGKILL) -> None:
        """Signal it and wait for it to end."""
        if self.popen.poll() is None:
            with contextlib.suppress(ProcessLookupError):
                os.kill(self.popen.pid, signum)
            self.popen.wait(5.0)


@pytest.fixture
def board_process(tmp_path) -> Callable[..., BoardProcess]:
    """Start ``fishtail-fake-board`` processes: ``board_process(link, *extra_args, log=None)``."""
    processes: list[BoardProcess] = []

    def start(link: Path, *args: str, log: Path | None = None) -> BoardProcess:
        argv = [sys.executable, "-m", "fishtail_boards.fake_board", "--link", str(link), *args]
        if log is not None:
            argv += ["--log", str(log)]
        process = BoardProcess(argv, tmp_path / f"fake_board{len(processes)}.stderr")
        processes.append(process)
        return process

    yield start
    for process in processes:
        process.kill(signal.SIGTERM)


@pytest.fixture
def serial_backend() -> Callable[..., SerialBackend]:
    """Start backends: ``serial_backend(port, opener=None, **SerialConfig)``; closed at teardown."""
    backends: list[SerialBackend] = []

    def make(port: Path | str, opener=None, **config) -> SerialBackend:
        backend = SerialBackend(SerialConfig(port=str(port), **config), opener=opener)
        backends.append(backend)
        backend.start()
        return backend

    yield make
    for backend in backends:
        backend.close()


# --------------------------------------------------------------------------------------------
# Two boards: the fake board and the real firmware in simavr

#: The Pololu 37D 30:1 with its 64-count encoder, on both boards.
POLOLU = {"counts_per_revolution": 64, "gear_ratio": 30.0}


@pytest.fixture(scope="session")
def firmware_build() -> Path:
    """build/firmware with the firmware ELF and the simulator, built by set-up; else skip."""
    return built_firmware_or_skip()


@pytest.fixture(scope="session")
def fishtail_build(firmware_build: Path) -> Path:
    """build/firmware/fishtail: the project's firmware and a link to the simulator; else skip."""
    folder = firmware_build / PROJECT_FIRMWARE_DIR
    if built_artifacts(folder) is None:
        pytest.skip(
            f"project firmware in simavr: nothing built in {folder} (make firmware builds it "
            "when firmware/fishtail.patch applies to the sketch)"
        )
    return folder


class BoardUnderTest:
    """A board under test on a pty at :attr:`link`, whichever it is.

    :meth:`clock_at` is the board's own clock at a host ``time.monotonic()``: durations the
    firmware keeps (PID frames, auto-stop) and speeds are measured on it, so that no assertion
    depends on whether the host kept a simulator at wall-clock pace.
    """

    kind = ""
    #: Whether it runs the project's firmware (answers ``v``, follows ``f``).
    project_firmware = False
    link: Path

    def clock_at(self, host_s: float) -> float:
        """The board's time [s] at host time ``host_s``."""
        raise NotImplementedError

    def clock(self) -> float:
        """The board's time now [s]."""
        return self.clock_at(time.monotonic())

    def reset(self) -> None:
        """Reset the board, as DTR does."""
        raise NotImplementedError

    def unplug(self) -> None:
        """Pull the USB cable: the port and the link vanish."""
        raise NotImplementedError

    def replug(self) -> None:
        """Plug it back in: a new port at the link, the board power-cycled."""
        raise NotImplementedError

    def stop(self) -> None:
        """End it."""
        raise NotImplementedError


class FakeUnderTest(BoardUnderTest):
    """The project's emulation (in-process FakeBoard, the DC motor); its clock is the host's."""

    kind = "fake"

    def __init__(self, handle: BoardHandle) -> None:
        """Wrap a started fake board."""
        self.handle = handle
        self.link = handle.link
        self.project_firmware = handle.board.config.firmware == "fishtail"
        self.kind = "fake_fishtail" if self.project_firmware else "fake"

    def clock_at(self, host_s: float) -> float:
        """The host's clock."""
        return host_s

    def reset(self) -> None:
        """The fake board's reset switch (SIGUSR1 of fishtail-fake-board)."""
        self.handle.board.request_reset()

    def unplug(self) -> None:
        """The fake board's unplug switch."""
        self.handle.board.unplug()

    def replug(self) -> None:
        """The fake board's replug switch (a power cycle)."""
        self.handle.board.replug()

    def stop(self) -> None:
        """Stopped by the fake_board fixture."""


class FirmwareUnderTest(BoardUnderTest):
    """ROSArduinoBridge in simavr with the DC motors; its clock is the simulated one."""

    kind = "firmware"

    def __init__(self, board: SimulatedBoard, project_firmware: bool) -> None:
        """Wrap a started simulator."""
        self.board = board
        self.link = board.link
        self.project_firmware = project_firmware
        self.kind = "fishtail" if project_firmware else "firmware"

    def clock_at(self, host_s: float) -> float:
        """The simulated time at that host time."""
        return self.board.simulated_at(host_s)

    def reset(self) -> None:
        """SIGUSR1 to the simulator: the ATmega resets."""
        self.board.reset()

    def unplug(self) -> None:
        """Pull the simulated USB cable (:class:`fishtail_boards.usb_cable.UsbCable`)."""
        self.board.unplug()

    def replug(self) -> None:
        """Plug it back in; the ATmega resets as USB power returns."""
        self.board.replug()

    def stop(self) -> None:
        """End the simulator."""
        self.board.stop()


def _dc_motors(count: int) -> list[DcChannelMotor]:
    from fishtail_plant.motor.dc_motor import DcMotorParameters

    scale = Scale(POLOLU["counts_per_revolution"], POLOLU["gear_ratio"])
    parameters = dataclasses.replace(DcMotorParameters(), gear_ratio=scale.gear_ratio)
    return [DcChannelMotor(parameters, scale) for _ in range(count)]


# The firmware board is a simulator process, so its tests are integration tests (conftest.py at the
# root marks the fixtures' users; this one is reached through getfixturevalue).
@pytest.fixture(
    params=[
        "fake",
        "fake_fishtail",
        pytest.param("firmware", marks=pytest.mark.integration),
        pytest.param("fishtail", marks=pytest.mark.integration),
    ]
)
def either_board(request, fake_board, tmp_path) -> Callable[..., BoardUnderTest]:
    """``either_board(encoder_offset=0)``: a fake board, or a firmware in simavr.

    ``firmware`` is the stock ROSArduinoBridge, ``fishtail`` the project's (which keeps every
    stock command and reply); ``fake`` emulates the stock one, ``fake_fishtail`` the project's.
    """
    started: list[BoardUnderTest] = []

    def start(encoder_offset: int = 0) -> BoardUnderTest:
        link = tmp_path / f"either{len(started)}"
        board: BoardUnderTest
        if request.param in ("fake", "fake_fishtail"):
            firmware = "fishtail" if request.param == "fake_fishtail" else "stock"
            handle = fake_board(link=link, variant="joshnewans", motor="dc", firmware=firmware,
                                encoder_offset=encoder_offset, **POLOLU)  # fmt: skip
            board = FakeUnderTest(handle)
        else:
            fixture = "firmware_build" if request.param == "firmware" else "fishtail_build"
            folder = request.getfixturevalue(fixture)
            extra = encoder_offset_pokes(firmware_variables(folder), encoder_offset)
            with open(tmp_path / f"either{len(started)}.stderr", "wb") as stderr:
                simulated = SimulatedBoard(
                    _dc_motors(2), link, folder, extra, stderr=stderr, cable=True
                )
            board = FirmwareUnderTest(simulated, request.param == "fishtail")
            assert simulated.ready.wait(10.0), "the simulator did not start"
        started.append(board)
        return board

    yield start
    for board in started:
        board.stop()


class NoReplyError(AssertionError):
    """The board did not answer a command in time (a failed assertion where a test expects one)."""


class RawPort:
    """The board's serial port in raw mode, one command and its reply line at a time."""

    def __init__(self, path: Path) -> None:
        """Open ``path`` (it must exist)."""
        self.fd = os.open(path, os.O_RDWR | os.O_NOCTTY)
        tty.setraw(self.fd)

    def ask(self, command: str, timeout_s: float = 5.0) -> str:
        """Send ``command`` with its CR; the reply line without CR LF.

        Raises:
            NoReplyError: no whole line within ``timeout_s`` (an AssertionError).
        """
        os.write(self.fd, command.encode("ascii") + b"\r")
        reply, deadline = b"", time.monotonic() + timeout_s
        while not reply.endswith(b"\r\n"):
            left = deadline - time.monotonic()
            if left <= 0:
                raise NoReplyError(f"no reply to {command!r} (got {reply!r})")
            if select.select([self.fd], [], [], left)[0]:
                reply += os.read(self.fd, 256)
        return reply.decode("ascii").strip()

    def counts(self, timeout_s: float = 5.0) -> tuple[int, int]:
        """The encoder counts (``e``)."""
        left, right = self.ask("e", timeout_s).split()
        return int(left), int(right)

    def drain(self) -> bytes:
        """Whatever the board has sent and nobody read (a reply cut short by a reset)."""
        pending = b""
        while select.select([self.fd], [], [], 0.0)[0]:
            pending += os.read(self.fd, 256)
        return pending

    def close(self) -> None:
        """Close the port."""
        os.close(self.fd)


@pytest.fixture
def raw_port() -> Callable[[Path], RawPort]:
    """``raw_port(path)``: a :class:`RawPort`; closed at teardown."""
    opened: list[RawPort] = []

    def open_port(path: Path) -> RawPort:
        opened.append(RawPort(path))
        return opened[-1]

    yield open_port
    for port in opened:
        port.close()
