"""Progress of a long computation on stderr: one updating line on a terminal, plain lines otherwise.

Nothing is shown for work that ends within :data:`QUIET_S`, so fast commands stay silent.
"""

from __future__ import annotations

import sys
import time
from typing import TextIO

#: Work shorter than this shows no progress at all.
QUIET_S = 1.0
# A terminal line is redrawn at most this often; a log (pipe, file) gets a line this often.
_TERMINAL_INTERVAL_S = 0.1
_LOG_INTERVAL_S = 5.0


class Progress:
    """Report ``done`` of ``total`` units of a task called ``label``."""

    def __init__(self, label: str, total: float, stream: TextIO | None = None) -> None:
        """Start the clock; nothing is written yet."""
        self.label = label
        self.total = total
        self.stream = stream if stream is not None else sys.stderr
        self.on_terminal = bool(getattr(self.stream, "isatty", lambda: False)())
        self.started = time.monotonic()
        self.last_shown = self.started
        self.shown = False

    def update(self, done: float) -> None:
        """Show the fraction done if the task has run long enough and the last report is old."""
        now = time.monotonic()
        interval = _TERMINAL_INTERVAL_S if self.on_terminal else _LOG_INTERVAL_S
        if now - self.started < QUIET_S or (self.shown and now - self.last_shown < interval):
            return
        elapsed = now - self.started
        fraction = done / self.total if self.total > 0 else 1.0
        text = f"{self.label}: {100.0 * fraction:5.1f} % ({elapsed:.1f} s)"
        if self.on_terminal:
            self.stream.write(f"\r{text}\033[K")
        else:
            self.stream.write(f"{text}\n")
        self.stream.flush()
        self.shown = True
        self.last_shown = now

    def finish(self) -> None:
        """End the terminal's updating line (if one was shown)."""
        if self.shown and self.on_terminal:
            elapsed = time.monotonic() - self.started
            self.stream.write(f"\r{self.label}: done ({elapsed:.1f} s)\033[K\n")
            self.stream.flush()
