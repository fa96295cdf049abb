"""fishtail-kinematics animate: a GIF of one carrier revolution; bad input exits 2 in one line."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from fishtail_kinematics.offline import cli

CONFIG = Path(__file__).resolve().parents[4] / "config"


def run(capsys, *argv: str) -> tuple[int, str, str]:
    status = cli.main(list(argv))
    captured = capsys.readouterr()
    return status, captured.out, captured.err


@pytest.mark.parametrize(
    ("mechanism", "frames", "fps"), [("oscillatory", 5, 10), ("undulatory", 3, 25)]
)
def test_animate_writes_a_gif_with_the_asked_frames(capsys, tmp_path, mechanism, frames, fps):
    output = tmp_path / f"{mechanism}.gif"
    status, out, err = run(
        capsys, "animate", "--config", str(CONFIG / f"{mechanism}.yaml"), "--output", str(output),
        "--frames", str(frames), "--fps", str(fps),
    )  # fmt: skip
    assert (status, err) == (0, "")
    assert out.strip() == str(output)
    with Image.open(output) as gif:
        assert gif.format == "GIF"
        assert gif.n_frames == frames
        assert gif.info["duration"] == int(1000 / fps)
        assert gif.info["loop"] == 0
        pictures = []
        for index in range(frames):
            gif.seek(index)
            pictures.append(np.asarray(gif.convert("RGB"), dtype=np.int16))
    # The linkage moves from frame to frame.
    assert all(np.abs(a - b).sum() > 0 for a, b in zip(pictures, pictures[1:], strict=False))


@pytest.mark.parametrize(
    "argv",
    [
        ["--frames", "1"],
        ["--frames", "many"],
        ["--frames", "2001"],
        ["--fps", "0"],
        ["--fps", "-3"],
        ["--fps", "nan"],
        ["--fps", "51"],
        ["--fps", "fast"],
    ],
)
def test_animate_bad_flags_exit_2(capsys, tmp_path, argv):
    with pytest.raises(SystemExit) as raised:
        cli.main(["animate", "--output", str(tmp_path / "x.gif"), *argv])
    assert raised.value.code == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and "error:" in err
    assert not (tmp_path / "x.gif").exists()


@pytest.mark.parametrize(
    ("argv", "fragment"),
    [
        (["--output", "{tmp}/tail.png"], "must name a .gif file"),
        (["--output", "{tmp}/missing/tail.gif"], "no directory"),
        (["--output", "{tmp}/tail.gif", "--rocker-link-m", "0.01"], "cannot assemble"),
    ],
)
def test_animate_bad_output_or_geometry_is_one_line_and_status_2(capsys, tmp_path, argv, fragment):
    status, out, err = run(capsys, "animate", *(a.format(tmp=tmp_path) for a in argv))
    assert status == 2 and out == ""
    assert err.startswith("fishtail-kinematics: error:") and fragment in err
    assert len(err.strip().splitlines()) == 1
    assert not list(tmp_path.glob("**/*.gif"))
