"""The live view's web viewer in headless Chromium: what it has taken in, and a screenshot.

:class:`Chromium` drives Debian's chromium over its DevTools pipe (no extra packages).
:func:`viewer_newest_s` reads the newest time the page's Rerun viewer has on the ``time`` time
line, from the viewer's own state (``WebHandle.viewer_state()``, a protobuf message that the page
keeps as ``window._handle``): how far the view in the browser is behind now. Run as a program it
waits until the page shows data at most ``--within-s`` old, then saves a screenshot::

    python -m fishtail_bringup.view_browser URL --output view.png

docs/visualisation.md ("Keeping up", "A screenshot").
"""

from __future__ import annotations

import argparse
import base64
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

from fishtail_bringup.view_rerun import TIMELINE

#: The page's JavaScript: the viewer's state as a list of bytes, or null before it started.
VIEWER_STATE_JS = "window._handle ? Array.from(window._handle.viewer_state()) : null"


def find_chromium() -> str | None:
    """Chromium's program on PATH, or None."""
    return shutil.which("chromium") or shutil.which("chromium-browser")


class Chromium:
    """Headless Chromium driven over its DevTools pipe (no extra packages)."""

    def __init__(self, executable: str, log_path: Path) -> None:
        """Start it with a blank page; nothing it loads may leave this machine."""
        ours_read, theirs_write = os.pipe()
        theirs_read, ours_write = os.pipe()

        def pipes_on_3_and_4() -> None:  # the DevTools pipe's fixed descriptors
            read, write = os.dup(theirs_read), os.dup(theirs_write)
            os.dup2(read, 3)
            os.dup2(write, 4)

        argv = [
            executable, "--headless=new", "--no-sandbox", "--use-angle=swiftshader",
            "--enable-unsafe-swiftshader", "--window-size=1280,800", "--remote-debugging-pipe",
            "--host-resolver-rules=MAP * ~NOTFOUND, EXCLUDE 127.0.0.1", "--no-first-run",
            f"--user-data-dir={log_path.parent / 'chromium-profile'}", "about:blank",
        ]  # fmt: skip
        with open(log_path, "wb") as log:
            self.process = subprocess.Popen(
                argv, stdin=subprocess.DEVNULL, stdout=log, stderr=log, close_fds=False,
                preexec_fn=pipes_on_3_and_4, start_new_session=True,
            )  # fmt: skip
        for descriptor in (theirs_read, theirs_write):
            os.close(descriptor)
        self._read, self._write = ours_read, ours_write
        self._buffer = b""
        self._next_id = 0
        self.session: str | None = None

    def call(self, method: str, params: dict | None = None, timeout: float = 30.0) -> dict:
        """One DevTools command; its result."""
        self._next_id += 1
        request = {"id": self._next_id, "method": method, "params": params or {}}
        if self.session is not None:
            request["sessionId"] = self.session
        os.write(self._write, json.dumps(request).encode() + b"\0")
        deadline = time.monotonic() + timeout
        while True:
            while b"\0" in self._buffer:
                raw, self._buffer = self._buffer.split(b"\0", 1)
                message = json.loads(raw)
                if message.get("id") == self._next_id:
                    assert "error" not in message, message
                    return message["result"]
            assert time.monotonic() < deadline, f"no answer to {method}"
            chunk = os.read(self._read, 1 << 20)
            assert chunk, "Chromium closed its DevTools pipe"
            self._buffer += chunk

    def open(self, url: str) -> None:
        """A tab at ``url``, to which later calls go."""
        target = self.call("Target.createTarget", {"url": url})["targetId"]
        self.session = self.call("Target.attachToTarget", {"targetId": target, "flatten": True})[
            "sessionId"
        ]
        # A tab in the background gets no animation frames, and the viewer takes in data only
        # when it draws one: in front and focused, as a tab someone looks at.
        self.call("Page.bringToFront")
        self.call("Emulation.setFocusEmulationEnabled", {"enabled": True})

    def evaluate(self, expression: str, timeout: float = 30.0):
        """The value of a JavaScript expression in the tab (awaited if a promise)."""
        result = self.call(
            "Runtime.evaluate",
            {"expression": expression, "returnByValue": True, "awaitPromise": True},
            timeout,
        )
        return result.get("result", {}).get("value")

    def screenshot(self) -> bytes:
        """The tab as PNG."""
        return base64.b64decode(self.call("Page.captureScreenshot", {"format": "png"})["data"])

    def close(self) -> None:
        """End the browser."""
        os.close(self._write)
        os.close(self._read)
        self.process.terminate()
        try:
            self.process.wait(10)
        except subprocess.TimeoutExpired:
            os.killpg(self.process.pid, 9)
            self.process.wait()


def _varint(data: bytes, at: int) -> tuple[int, int]:
    value = shift = 0
    while True:
        byte = data[at]
        at += 1
        value |= (byte & 0x7F) << shift
        shift += 7
        if byte < 0x80:
            return value, at


def protobuf_fields(data: bytes) -> list[tuple[int, int | bytes]]:
    """A protobuf message's fields in order: (number, integer or bytes), not decoded further.

    >>> protobuf_fields(bytes([0x08, 0x96, 0x01, 0x12, 0x02, 0x68, 0x69]))
    [(1, 150), (2, b'hi')]
    """
    fields: list[tuple[int, int | bytes]] = []
    at = 0
    while at < len(data):
        key, at = _varint(data, at)
        number, kind = key >> 3, key & 7
        value: int | bytes
        if kind == 0:
            value, at = _varint(data, at)
        elif kind == 1:
            value, at = int.from_bytes(data[at : at + 8], "little"), at + 8
        elif kind == 5:
            value, at = int.from_bytes(data[at : at + 4], "little"), at + 4
        elif kind == 2:
            length, at = _varint(data, at)
            value, at = data[at : at + length], at + length
        else:
            raise ValueError(f"protobuf wire type {kind} not read here")
        fields.append((number, value))
    return fields


def _message(fields: list, number: int) -> bytes:
    value = dict(fields).get(number, b"")
    return value if isinstance(value, bytes) else b""


def newest_on_timeline(state: bytes, timeline: str = TIMELINE) -> int | None:
    """The newest time (ns) on ``timeline`` over the recordings in a viewer state; None if none.

    The state (Rerun 0.41's GetViewerStateResponse) holds per recording (field 3) its
    timelines (field 2: the timeline's name in 1.1, its time range in 3, whose end is 2).
    """
    newest = None
    for number, recording in protobuf_fields(state):
        if number != 3 or not isinstance(recording, bytes):
            continue
        for inner, entry in protobuf_fields(recording):
            if inner != 2 or not isinstance(entry, bytes):
                continue
            fields = protobuf_fields(entry)
            name = dict(protobuf_fields(_message(fields, 1))).get(1)
            end = dict(protobuf_fields(_message(fields, 3))).get(2)
            if name == timeline.encode() and isinstance(end, int):
                newest = end if newest is None else max(newest, end)
    return newest


def viewer_newest_s(browser: Chromium) -> float | None:
    """The newest time (s) the page's viewer has on the ``time`` time line; None if none yet."""
    state = browser.evaluate(VIEWER_STATE_JS)
    if not state:
        return None
    newest = newest_on_timeline(bytes(state))
    return None if newest is None else newest * 1e-9


def main(argv: list[str] | None = None) -> int:
    """Open the view's page, wait until it shows now, save a screenshot."""
    parser = argparse.ArgumentParser(
        prog="python -m fishtail_bringup.view_browser", description=__doc__.splitlines()[0]
    )
    parser.add_argument("url", help="the address fishtail-view prints")
    parser.add_argument("--output", type=Path, default=Path("view.png"), help="PNG to write")
    parser.add_argument("--within-s", type=float, default=2.0,
                        help="wait until the page's newest data is at most this old")  # fmt: skip
    parser.add_argument("--timeout-s", type=float, default=120.0, help="give up after this")
    parser.add_argument("--settle-s", type=float, default=1.0,
                        help="then wait this long for the page to draw it")  # fmt: skip
    arguments = parser.parse_args(argv)
    executable = find_chromium()
    if executable is None:
        print("no chromium on PATH (Debian: apt-get install chromium)", file=sys.stderr)
        return 2
    profile = Path(os.environ.get("TMPDIR", "/tmp")) / f"fishtail-view-browser-{os.getpid()}"
    profile.mkdir(parents=True, exist_ok=True)
    browser = Chromium(executable, profile / "chromium.log")
    try:
        browser.open(arguments.url)
        deadline = time.monotonic() + arguments.timeout_s
        lag = None
        while time.monotonic() < deadline:
            newest = viewer_newest_s(browser)
            lag = None if newest is None else time.time() - newest
            if lag is not None and lag <= arguments.within_s:
                break
            time.sleep(0.5)
        else:
            said = "no data" if lag is None else f"data {lag:.1f} s old"
            print(f"the page did not catch up within {arguments.timeout_s:g} s ({said})",
                  file=sys.stderr)  # fmt: skip
            return 1
        time.sleep(arguments.settle_s)
        arguments.output.write_bytes(browser.screenshot())
        print(f"{arguments.output}: the view with data {lag:.1f} s old")
        return 0
    finally:
        browser.close()
        shutil.rmtree(profile, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
