"""Progress on stderr: silent for short work, one updating line on a terminal, plain lines else."""

import io

from fishtail_swim.offline import progress as progress_module
from fishtail_swim.offline.progress import Progress


class _Terminal(io.StringIO):
    def isatty(self):
        return True


def _clock(monkeypatch, times):
    ticks = iter(times)
    monkeypatch.setattr(progress_module.time, "monotonic", lambda: next(ticks))


def test_short_work_shows_nothing(monkeypatch):
    _clock(monkeypatch, [0.0, 0.5, 0.9])
    stream = io.StringIO()
    progress = Progress("run", 10, stream)
    progress.update(5)
    progress.update(9)
    progress.finish()
    assert stream.getvalue() == ""


def test_a_log_gets_plain_lines_now_and_then(monkeypatch):
    _clock(monkeypatch, [0.0, 1.5, 2.0, 7.0])
    stream = io.StringIO()
    progress = Progress("run", 100, stream)
    for done in (10, 20, 70):
        progress.update(done)
    progress.finish()
    assert stream.getvalue().splitlines() == ["run:  10.0 % (1.5 s)", "run:  70.0 % (7.0 s)"]


def test_a_terminal_gets_one_updating_line(monkeypatch):
    _clock(monkeypatch, [0.0, 1.5, 1.6, 2.5])
    stream = _Terminal()
    progress = Progress("run", 100, stream)
    progress.update(10)
    progress.update(60)
    progress.finish()
    text = stream.getvalue()
    assert text.count("\n") == 1 and text.endswith("\n")
    assert text.count("\r") == 3
    assert "run: done (2.5 s)" in text
