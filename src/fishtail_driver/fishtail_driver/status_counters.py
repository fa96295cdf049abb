"""Named counters and the latest fault, shared between an I/O thread and the threads that report.

>>> counters = StatusCounters(clock=lambda: 12.5)
>>> counters.fault("timeouts", "no reply to 'e' within 0.1 s")
>>> counters.count("polls", "connects")
>>> counters.snapshot()
({'timeouts': 1, 'polls': 1, 'connects': 1}, ('timeouts', "no reply to 'e' within 0.1 s", 12.5))
"""

from __future__ import annotations

import collections
import threading
from collections.abc import Callable


class StatusCounters:
    """Named counters and the latest fault (kind, reason, time), shared across threads."""

    def __init__(self, clock: Callable[[], float]) -> None:
        """No counts, no fault."""
        self._clock = clock
        self._lock = threading.Lock()
        self._counts: collections.Counter[str] = collections.Counter()
        self._last_fault: tuple[str, str, float] | None = None

    def count(self, *names: str, amount: int = 1) -> None:
        """Add ``amount`` to each counter of ``names``, together."""
        with self._lock:
            for name in names:
                self._counts[name] += amount

    def set(self, name: str, value: int) -> None:
        """Set counter ``name``."""
        with self._lock:
            self._counts[name] = value

    def note(self, kind: str, reason: str) -> None:
        """Make this the latest fault, without counting it."""
        with self._lock:
            self._last_fault = (kind, reason, self._clock())

    def fault(self, kind: str, reason: str) -> None:
        """Count a fault under ``kind`` and make it the latest."""
        with self._lock:
            self._counts[kind] += 1
            self._last_fault = (kind, reason, self._clock())

    def __getitem__(self, name: str) -> int:
        """Counter ``name`` (0 if never counted)."""
        with self._lock:
            return self._counts[name]

    @property
    def last_fault(self) -> tuple[str, str, float] | None:
        """(kind, reason, time) of the latest fault, or None."""
        with self._lock:
            return self._last_fault

    def snapshot(self) -> tuple[dict[str, int], tuple[str, str, float] | None]:
        """Every counter and the latest fault, taken together."""
        with self._lock:
            return dict(self._counts), self._last_fault
