"""``fishtail-swim animate``: the GIF, the frames' geometry, and bad input."""

import math
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from fishtail_kinematics.engine.geometry import OscillatoryGeometry, UndulatoryGeometry
from fishtail_kinematics.engine.mechanisms import make_tail
from fishtail_plant.fish.fish import FishParameters
from fishtail_plant.fish.model import PSI, X, Y
from fishtail_plant.fish.outline import body_to_world
from fishtail_swim.offline import animate
from fishtail_swim.offline.inputs import Swimmer
from fishtail_swim.offline.time_run import run_from_rest

CONFIG = Path(__file__).resolve().parents[3] / "config"
OSCILLATORY = CONFIG / "oscillatory.yaml"
FISH = CONFIG / "fish.yaml"
SPEED_RAD_S = 8.0
STEPS_PER_BEAT = 16


def test_animate_writes_a_looping_gif_with_a_frame_every_one_over_fps(swim_cli, tmp_path):
    output = tmp_path / "fish.gif"
    status, out, err = swim_cli(
        "animate", "--config", OSCILLATORY, "--fish", FISH, "--speed", SPEED_RAD_S,
        "--duration", 1.0, "--fps", 10, "--steps-per-beat", STEPS_PER_BEAT, "--output", output,
    )  # fmt: skip
    assert status == 0, err
    assert out == f"wrote {output} (11 frames)\n"
    with Image.open(output) as gif:
        assert gif.format == "GIF"
        assert gif.n_frames == 11  # t = 0, 0.1, ..., 1.0 s
        assert gif.size == animate.FIGURE_SIZE_PX
        assert gif.info["loop"] == 0 and gif.info["duration"] == 100


def test_body_to_world_turns_by_psi_then_moves_to_c():
    # psi = pi/2: the body's x (forward) is the world's y, the body's y (left) the world's -x.
    points = np.array([[1.0, 0.0], [0.0, 1.0]])
    np.testing.assert_allclose(
        body_to_world(points, 2.0, 3.0, math.pi / 2), [[2.0, 4.0], [1.0, 3.0]], atol=1e-12
    )
    # One pose per frame: the same body points in each frame's pose, (F, P, 2).
    moved = body_to_world(points, np.array([0.0, 2.0]), np.array([0.0, 3.0]),
                          np.array([0.0, math.pi / 2]))  # fmt: skip
    np.testing.assert_allclose(moved, [points, [[2.0, 4.0], [1.0, 3.0]]], atol=1e-12)


def _straight_run(speed_m_s, heading_rad, duration_s=2.0):
    """Times and states of a fish gliding at ``speed_m_s`` along ``heading_rad`` from (1, 2)."""
    time_s = np.linspace(0.0, duration_s, 5)
    state = np.zeros((time_s.size, 6))
    state[:, X] = 1.0 + speed_m_s * math.cos(heading_rad) * time_s
    state[:, Y] = 2.0 + speed_m_s * math.sin(heading_rad) * time_s
    state[:, PSI] = heading_rad
    state[:, 3] = speed_m_s  # u
    return time_s, state


def test_frames_at_psi_half_pi_put_the_body_and_tail_where_hand_derived():
    fish = FishParameters()
    tail = make_tail(OscillatoryGeometry())
    time_s, state = _straight_run(0.4, math.pi / 2)
    frames = animate.fish_frames(time_s, state, tail, fish, SPEED_RAD_S, np.array([0.0, 0.75]))
    # At t = 0.75 s, C is 0.3 m up from (1, 2) (interpolated between the samples).
    np.testing.assert_allclose([frames.x_m[1], frames.y_m[1]], [1.0, 2.3], atol=1e-12)
    np.testing.assert_allclose(frames.speed_m_s, 0.4)
    # Facing +Y: the nose (L/2, 0) is L/2 above C, O (-l_O, 0) is l_O below it.
    np.testing.assert_allclose(frames.outline[1, 0], [1.0, 2.3 + 0.25], atol=1e-12)
    np.testing.assert_allclose(frames.crank[1, 0], [1.0, 2.3 - 0.05], atol=1e-12)
    # The tip T at carrier angle 8 * 0.75 rad: (x_t, y_t) in the tail frame is (-l_O - x_t, y_t)
    # in the body, and (X - y_b, Y + x_b) in the world.
    solved = tail.solve(SPEED_RAD_S * 0.75)
    tip_x, tip_y = float(solved.tip_x), float(solved.tip_y)
    np.testing.assert_allclose(frames.tip[1], [1.0 - tip_y, 2.3 - 0.05 - tip_x], atol=1e-12)
    np.testing.assert_allclose(frames.tail_link[1, -1], frames.tip[1], atol=1e-12)
    # The path so far ends at the frame's C and holds the samples before it.
    np.testing.assert_allclose(frames.path_until(1), [[1.0, 2.0], [1.0, 2.2], [1.0, 2.3]])


def test_the_drawn_fish_is_where_the_run_and_the_model_put_it():
    swimmer = Swimmer(FishParameters(), make_tail(UndulatoryGeometry()))
    period = 2.0 * math.pi / SPEED_RAD_S
    step = period / STEPS_PER_BEAT
    run = run_from_rest(swimmer, np.array([SPEED_RAD_S]), step, 2 * STEPS_PER_BEAT)
    time_s, state = run.trajectory.time_s, run.trajectory.state[:, 0]
    # Frames on every fourth sample: the pose is the run's, not interpolated.
    frames = animate.fish_frames(time_s, state, swimmer.tail, swimmer.fish, SPEED_RAD_S,
                                 time_s[::4])  # fmt: skip
    np.testing.assert_allclose(frames.x_m, state[::4, X], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(frames.psi_rad, state[::4, PSI], rtol=1e-12, atol=1e-15)
    assert frames.x_m[-1] > frames.x_m[0] + 1e-3  # it swims forward
    # The tip drawn is the model's trailing edge (in the body frame) carried by the pose.
    flow, _, _ = run.model.forces(time_s[::4, None], run.trajectory.state[::4, :1])
    tip_body = np.stack((flow.tip_body_x[:, 0], flow.tip_body_y[:, 0]), axis=-1)
    expected = body_to_world(tip_body[:, None, :], frames.x_m, frames.y_m, frames.psi_rad)
    np.testing.assert_allclose(frames.tip, expected[:, 0], atol=1e-12)
    # The hull's outline is centred on C in every frame.
    np.testing.assert_allclose(frames.outline[:, :-1].mean(axis=1),
                               np.column_stack((frames.x_m, frames.y_m)), atol=1e-12)  # fmt: skip


def test_a_long_path_is_followed_and_a_short_one_shown_whole(tmp_path):
    tail = make_tail(OscillatoryGeometry())
    times = animate.frame_times(2.0, 1.5)
    np.testing.assert_allclose(times, [0.0, 2.0 / 3.0, 4.0 / 3.0, 2.0])  # ends included
    for speed_m_s, follows in ((5.0, True), (0.1, False)):
        time_s, state = _straight_run(speed_m_s, 0.3)
        frames = animate.fish_frames(time_s, state, tail, FishParameters(), SPEED_RAD_S, times)
        assert animate.follows_fish(frames) is follows
        path = animate.write_gif(frames, tmp_path / f"{speed_m_s}.gif", 1.5, "glide")
        with Image.open(path) as gif:
            assert gif.n_frames == 4 and gif.size == animate.FIGURE_SIZE_PX


@pytest.mark.parametrize(
    ("arguments", "words"),
    [
        (("--speed", 4, "--duration", 1.0), "shorter than one beat"),
        (("--speed", 8, "--duration", 1.0, "--fps", 0), "fps = 0.0 is outside (0.0, 50.0]"),
        (("--speed", 8, "--duration", 1.0, "--fps", 60), "fps = 60.0 is outside (0.0, 50.0]"),
        (("--speed", 8, "--duration", 1.0, "--fps", "nan"), "fps = nan is outside"),
        (("--speed", 8, "--duration", 200, "--fps", 20), "count 4001, but a GIF takes 2 to 2000"),
        (("--speed", 8, "--duration", 1.0, "--fps", 0.5), "frame count 1,"),
        # Refused before the frame times or the run are allocated (149 GiB, 911 GiB).
        (("--speed", 4, "--duration", 1e9), "frame count 2e+10, but a GIF takes 2 to 2000"),
        (("--speed", 4, "--duration", 90, "--steps-per-beat", 20000), "limit of 1000000"),
        (("--speed", 0, "--duration", 1.0), "speed = 0.0 is outside (0.0, inf] rad/s"),
        (("--speed", 8), "--duration"),
    ],
)
def test_bad_animation_input_is_one_line_and_exit_2(swim_cli, tmp_path, arguments, words):
    output = tmp_path / "fish.gif"
    status, out, err = swim_cli(
        "animate", "--config", OSCILLATORY, "--fish", FISH, "--output", output, *arguments
    )
    assert status == 2
    assert out == ""
    assert err.startswith("fishtail-swim: error:") and err.count("\n") == 1, err
    assert words in err
    assert not output.exists()


@pytest.mark.parametrize(
    ("output", "words"),
    [
        ("{tmp}/no/such/dir/fish.gif", "no directory"),
        ("{tmp}/fish.png", "name it *.gif"),
        ("{tmp}/folder.gif", "it is a directory"),
    ],
)
def test_an_unwritable_output_is_refused_before_the_run(swim_cli, tmp_path, output, words):
    (tmp_path / "folder.gif").mkdir()
    status, out, err = swim_cli(
        "animate", "--config", OSCILLATORY, "--fish", FISH, "--speed", SPEED_RAD_S,
        "--duration", 1.0, "--output", output.format(tmp=tmp_path),
    )  # fmt: skip
    assert status == 2 and out == ""
    assert err.startswith("fishtail-swim: error:") and err.count("\n") == 1, err
    assert words in err
    assert sorted(path.name for path in tmp_path.iterdir()) == ["folder.gif"]
