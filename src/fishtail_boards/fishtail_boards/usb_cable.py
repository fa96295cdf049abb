"""The Nano's USB cable for the simulated board: a pty the host opens, relayed to the UART's pty.

On a real board the host's port is the USB-serial bridge, so pulling the cable makes the port
vanish while the ATmega runs on; :class:`UsbCable` is that bridge for the firmware in simavr, with
:meth:`UsbCable.unplug` and :meth:`UsbCable.replug` at a stable link. docs/serial.md ("The real
firmware in a simulator").
"""

from __future__ import annotations

import contextlib
import os
import queue
import select
import threading
import tty
from collections.abc import Callable
from pathlib import Path


class UsbCable:
    """Relays bytes between a host-side pty at ``link`` and the UART pty at ``uart_path``."""

    def __init__(self, uart_path: str, link: Path) -> None:
        """Open the UART's pty and the host's (plugged in); the relay thread runs until close()."""
        self.link = link
        self._uart = os.open(uart_path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        tty.setraw(self._uart)
        self._master: int | None = None
        self._slave: int | None = None
        self._requests: queue.SimpleQueue[Callable[[], None]] = queue.SimpleQueue()
        self._wake_r, self._wake_w = os.pipe()
        self._done = threading.Event()
        self._closed = False
        self._plug()
        self._thread = threading.Thread(target=self._relay, name="usb-cable", daemon=True)
        self._thread.start()

    @property
    def plugged(self) -> bool:
        """Whether the host's pty is there."""
        return self._master is not None

    def _plug(self) -> None:
        master, slave = os.openpty()
        tty.setraw(slave)
        os.set_blocking(master, False)
        self._master, self._slave = master, slave
        temporary = f"{self.link}.{os.getpid()}.tmp"
        with contextlib.suppress(FileNotFoundError):
            os.unlink(temporary)
        os.symlink(os.ttyname(slave), temporary)
        os.replace(temporary, self.link)

    def _unplug(self) -> None:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(self.link)
        for fd in (self._master, self._slave):
            if fd is not None:
                os.close(fd)
        self._master = self._slave = None

    def _request(self, action: Callable[[], None]) -> None:
        """Run ``action`` in the relay thread (which owns the fds) and wait for it."""
        done = threading.Event()

        def run() -> None:
            action()
            done.set()

        self._requests.put(run)
        os.write(self._wake_w, b"x")
        if not done.wait(5.0):
            raise TimeoutError("the USB cable's relay thread did not answer")

    def unplug(self) -> None:
        """Pull the cable: the host's pty and the link go away (no-op if unplugged)."""
        self._request(lambda: self._unplug() if self.plugged else None)

    def replug(self) -> None:
        """Plug it back in: a new pty at the link (no-op if plugged)."""
        self._request(lambda: None if self.plugged else self._plug())

    def _relay(self) -> None:
        try:
            while not self._closed:
                watched = [self._uart, self._wake_r]
                if self._master is not None:
                    watched.append(self._master)
                readable = select.select(watched, [], [])[0]
                if self._wake_r in readable:
                    os.read(self._wake_r, 64)
                    while not self._requests.empty():
                        self._requests.get()()
                    continue
                if self._uart in readable:
                    data = self._read(self._uart)
                    if data and self._master is not None:
                        with contextlib.suppress(BlockingIOError):  # a host that never reads
                            os.write(self._master, data)
                if self._master is not None and self._master in readable:
                    data = self._read(self._master)
                    if data:
                        # A UART that cannot take them (the simulator gone or ending) loses
                        # them, as a board's would; the relay goes on.
                        with contextlib.suppress(OSError):
                            os.write(self._uart, data)
        finally:
            self._unplug()
            os.close(self._uart)
            self._done.set()

    @staticmethod
    def _read(fd: int) -> bytes:
        """What is there; nothing for EIO (a pty side with no one on the other end)."""
        try:
            return os.read(fd, 4096)
        except (BlockingIOError, OSError):
            return b""

    def close(self) -> None:
        """Stop relaying and remove the host's pty and link."""

        def finish() -> None:
            self._closed = True

        if not self._done.is_set():
            with contextlib.suppress(TimeoutError):
                self._request(finish)
            self._done.wait(5.0)
        for fd in (self._wake_r, self._wake_w):
            with contextlib.suppress(OSError):
                os.close(fd)
