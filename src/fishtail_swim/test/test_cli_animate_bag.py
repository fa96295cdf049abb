"""``fishtail-swim animate --bag``: a recorded run read from a bag written here, and bad input.

The bags are written with rosbags as the kinematics offline tests write theirs (``Writer``, version
9, MCAP; their ``tail_state`` and ``header`` helpers, which fill TailState as the kinematics node
does): a fish swimming a known circle on fish/odom at irregular stamps, the carrier on tail/state,
the pivot on pivot/joint_state, goals on goal_pose.
"""

import doctest
import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from rosbags.rosbag2 import Writer
from rosbags.rosbag2.enums import StoragePlugin

import fishtail_common.bag_reading
from fishtail_common.bag_reading import BagError
from fishtail_common.bag_types import suite_typestore
from fishtail_common.interface import (
    FISH_ODOM,
    GOAL_POSE,
    MOTOR_JOINT_STATE,
    PIVOT_JOINT_STATE,
    TAIL_STATE,
)
from fishtail_kinematics.engine.geometry import OscillatoryGeometry
from fishtail_kinematics.engine.mechanisms import make_tail
from fishtail_plant.fish.fish import FishParameters
from fishtail_swim.offline import animate, recorded_run

ROOT = Path(__file__).resolve().parents[3]
CONFIG = ROOT / "config"
OSCILLATORY = CONFIG / "oscillatory.yaml"
FISH = CONFIG / "fish.yaml"


def _bag_helpers():
    """The kinematics offline tests' message helpers (header, tail_state), from their file."""
    path = ROOT / "src/fishtail_kinematics/test/offline/test_analysis.py"
    spec = importlib.util.spec_from_file_location("kinematics_bag_helpers", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


HELPERS = _bag_helpers()
T0_NS = 1_700_000_000_000_000_000
RADIUS_M = 1.0
TURN_RATE = 0.5  # rad/s round the circle: 0.5 m/s along it
CARRIER_RAD_S = 12.0
DURATION_S = 4.0
ODOM_HZ = 50.0
GOALS = [(0.5, (3.0, 1.0)), (1.5, (3.0, 1.0)), (2.5, (-1.0, 2.0))]  # (sent at s, goal); one resent


def odom_times(
    hole: tuple[float, float] | None = None, duration_s: float = DURATION_S, rate_hz=ODOM_HZ
) -> np.ndarray:
    """Irregular fish/odom stamps, s after T0: 50 Hz with +-4 ms of jitter (minus a hole)."""
    k = np.arange(int(duration_s * rate_hz))
    times = k / rate_hz + 0.2 / rate_hz * np.sin(1.7 * k)
    times[0] = 0.0
    if hole is not None:
        times = times[(times <= hole[0]) | (times >= hole[1])]
    return np.round(times * 1e9) / 1e9  # as stamped


def circle(t):
    """X, Y, psi of the fish on the circle at t (anticlockwise, heading along it)."""
    angle = TURN_RATE * np.asarray(t)
    return RADIUS_M * np.cos(angle), RADIUS_M * np.sin(angle), angle + math.pi / 2


def pivot_shift(t):
    """The pivot's shift at t: from 0 to 8 mm over the recording."""
    return 0.002 * np.asarray(t)


def write_bag(
    path: Path,
    hole: tuple[float, float] | None = None,
    topics: tuple[str, ...] = ("odom", "state", "pivot", "goal"),
    duration_s: float = DURATION_S,
    odom_hz: float = ODOM_HZ,
) -> Path:
    """A bag like fishtail-record writes (receive time = stamp + 0.1 ms)."""
    store = suite_typestore()
    types = store.types
    tail = make_tail(OscillatoryGeometry())
    point, vector = types["geometry_msgs/msg/Point"], types["geometry_msgs/msg/Vector3"]
    pose_type, quaternion = types["geometry_msgs/msg/Pose"], types["geometry_msgs/msg/Quaternion"]
    messages = []  # (stamp ns, topic, message)
    if "odom" in topics:
        for t in odom_times(hole, duration_s, odom_hz):
            x, y, psi = circle(t)
            stamp = T0_NS + round(t * 1e9)
            odometry = types["nav_msgs/msg/Odometry"](
                header=HELPERS.header(store, stamp, "world"), child_frame_id="base_link",
                pose=types["geometry_msgs/msg/PoseWithCovariance"](
                    pose=pose_type(position=point(x=x, y=y, z=0.0),
                                   orientation=quaternion(x=0.0, y=0.0, z=math.sin(psi / 2),
                                                          w=math.cos(psi / 2))),
                    covariance=np.zeros(36)),
                twist=types["geometry_msgs/msg/TwistWithCovariance"](
                    twist=types["geometry_msgs/msg/Twist"](
                        linear=vector(x=RADIUS_M * TURN_RATE, y=0.0, z=0.0),
                        angular=vector(x=0.0, y=0.0, z=TURN_RATE)),
                    covariance=np.zeros(36)),
            )  # fmt: skip
            messages.append((stamp, FISH_ODOM, odometry))
    for k in range(int(duration_s * 100) if topics != ("odom",) else 0):
        t = k / 100
        stamp = T0_NS + round(t * 1e9)
        angle = CARRIER_RAD_S * t
        if "state" in topics:
            shifted = tail.with_pivot_shift(float(pivot_shift(t)))
            state = HELPERS.tail_state(store, shifted, stamp, angle, CARRIER_RAD_S)
            messages.append((stamp, TAIL_STATE, state))
        if "joint" in topics:
            joint = types["sensor_msgs/msg/JointState"](
                header=HELPERS.header(store, stamp), name=["carrier_joint"],
                position=np.array([angle]), velocity=np.array([CARRIER_RAD_S]),
                effort=np.array([], dtype=float),
            )  # fmt: skip
            messages.append((stamp, MOTOR_JOINT_STATE, joint))
        if "pivot" in topics and k % 5 == 0:
            pivot = types["sensor_msgs/msg/JointState"](
                header=HELPERS.header(store, stamp), name=["pivot_joint"],
                position=np.array([pivot_shift(t)]), velocity=np.array([0.002]),
                effort=np.array([], dtype=float),
            )  # fmt: skip
            messages.append((stamp, PIVOT_JOINT_STATE, pivot))
    if "goal" in topics:
        for t, (x, y) in GOALS:
            stamp = T0_NS + round(t * 1e9)
            goal = types["geometry_msgs/msg/PoseStamped"](
                header=HELPERS.header(store, stamp, "world"),
                pose=pose_type(position=point(x=x, y=y, z=0.0),
                               orientation=quaternion(x=0.0, y=0.0, z=0.0, w=1.0)),
            )  # fmt: skip
            messages.append((stamp, GOAL_POSE, goal))
    messages.sort(key=lambda item: item[0])
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        connections = {}
        for _, topic, _ in messages:
            if topic.name not in connections:
                connections[topic.name] = writer.add_connection(
                    f"/{topic.name}", topic.type, typestore=store
                )
        for stamp, topic, message in messages:
            data = store.serialize_cdr(message, topic.type)
            writer.write(connections[topic.name], stamp + 100_000, data)
    return path


@pytest.fixture(scope="module")
def circle_bag(tmp_path_factory):
    return write_bag(tmp_path_factory.mktemp("bags") / "circle")


def assert_same_angle(actual, expected):
    np.testing.assert_allclose(np.angle(np.exp(1j * (actual - expected))), 0.0, atol=1e-12)


def test_frame_poses_are_the_recorded_samples_interpolated_by_time(circle_bag):
    run = recorded_run.read_recorded_run(circle_bag, fps=10.0, start_s=0.5, duration_s=3.0)
    np.testing.assert_allclose(run.time_s, 0.5 + np.arange(31) / 10.0)
    # The expected pose: the recorded samples, linear in their (irregular) stamps.
    times = odom_times()
    x, y, psi = circle(times)
    np.testing.assert_allclose(run.x_m, np.interp(run.time_s, times, x), rtol=0, atol=1e-12)
    np.testing.assert_allclose(run.y_m, np.interp(run.time_s, times, y), rtol=0, atol=1e-12)
    # The heading crosses +-pi at t = pi s: interpolated the shorter way round, not through 0.
    assert_same_angle(run.psi_rad, np.interp(run.time_s, times, psi))
    np.testing.assert_allclose(run.speed_m_s, RADIUS_M * TURN_RATE)
    # By time, not by sample index: a frame between two jittered samples is not their midpoint,
    # and the recorded circle is met to within the chord's sag (R (w dt)^2 / 8 at 24 ms).
    circle_x, circle_y, _ = circle(run.time_s)
    assert np.max(np.hypot(run.x_m - circle_x, run.y_m - circle_y)) < 2e-4
    # The carrier angle and pivot shift: tail/state's and pivot/joint_state's, interpolated.
    np.testing.assert_allclose(run.carrier_angle_rad, CARRIER_RAD_S * run.time_s, atol=1e-9)
    np.testing.assert_allclose(run.pivot_shift_m, pivot_shift(run.time_s), atol=1e-12)
    assert run.carrier_source == "motor_angle of /tail/state"
    assert run.pivot_source == "pivot_joint of /pivot/joint_state"
    assert run.mechanism == "oscillatory" and run.gaps == 0 and run.notes == []
    # Goals: the resent one once, at its first sending (before the window: still current).
    np.testing.assert_allclose(run.goals, [[3.0, 1.0], [-1.0, 2.0]])
    np.testing.assert_allclose(run.goal_time_s, [0.5, 2.5], atol=1e-9)


def test_the_drawn_fish_and_goals_are_the_runs(circle_bag):
    tail, fish = make_tail(OscillatoryGeometry()), FishParameters()
    run = recorded_run.read_recorded_run(circle_bag, fps=10.0, start_s=0.5, duration_s=3.0)
    frames = animate.recorded_frames(run, tail, fish)
    np.testing.assert_array_equal(frames.x_m, run.x_m)
    np.testing.assert_array_equal(frames.psi_rad, run.psi_rad)
    # The hull is centred on the frame's C.
    np.testing.assert_allclose(
        frames.outline[:, :-1].mean(axis=1), np.column_stack((run.x_m, run.y_m)), atol=1e-12
    )
    # Frame 10 (t = 1.5 s): the linkage solved at its carrier angle with its pivot shift.
    k = 10
    shifted = tail.with_pivot_shift(round(run.pivot_shift_m[k] / 1e-4) * 1e-4)
    solved = shifted.solve(float(run.carrier_angle_rad[k]))
    offset = float(fish.tail_origin_offset_m)
    tip_body = np.array([-offset - float(solved.tip_x), float(solved.tip_y)])
    c, s = math.cos(run.psi_rad[k]), math.sin(run.psi_rad[k])
    expected_tip = [run.x_m[k] + c * tip_body[0] - s * tip_body[1],
                    run.y_m[k] + s * tip_body[0] + c * tip_body[1]]  # fmt: skip
    np.testing.assert_allclose(frames.tip[k], expected_tip, atol=1e-12)
    points = animate.shifted_link_points(
        tail, run.carrier_angle_rad, run.carrier_velocity_rad_s, run.pivot_shift_m
    )
    design_os = tail.geometry.pivot_offset_m
    np.testing.assert_allclose(points.pivot_s[:, 0], design_os + run.pivot_shift_m, atol=6e-5)
    # The goals: the first is current from frame 0 (sent at 0.5 s), the second from t = 2.5 s.
    assert frames.goals.shape == (2, 2)
    assert frames.goals_until(0) == 1 and frames.goals_until(19) == 1
    assert frames.goals_until(20) == 2 and frames.goals_until(30) == 2
    # The view takes in the goals: the whole path and (3, 1) span more than 3 fish widths.
    assert animate.follows_fish(frames)


def test_a_gap_is_no_pose_and_a_break_in_the_path(tmp_path):
    bag = write_bag(tmp_path / "holed", hole=(1.0, 1.6))
    run = recorded_run.read_recorded_run(bag, fps=10.0)
    times = odom_times(hole=(1.0, 1.6))
    in_gap = (run.time_s > times[times <= 1.0][-1]) & (run.time_s < times[times >= 1.6][0])
    assert 6 <= in_gap.sum() <= 7  # 1.1 ... 1.6 s, and 1.0 s unless a sample falls on it
    assert np.all(np.isnan(run.x_m[in_gap])) and np.all(np.isfinite(run.x_m[~in_gap]))
    expected_x = np.interp(run.time_s[~in_gap], times, circle(times)[0])
    np.testing.assert_allclose(run.x_m[~in_gap], expected_x, rtol=0, atol=1e-12)
    assert run.gaps == 1
    # One NaN row in the path, right after the last sample before the hole.
    broken = np.flatnonzero(np.isnan(run.path[:, 0]))
    assert broken.size == 1
    assert run.path_time_s[broken[0]] == pytest.approx(times[times <= 1.0][-1])
    frames = animate.recorded_frames(run, make_tail(OscillatoryGeometry()), FishParameters())
    after = int(np.flatnonzero(run.time_s > 1.6)[0])
    assert np.isnan(frames.path_until(after)[:, 0]).sum() == 1
    # The carrier was recorded through the hole: the linkage is still solved there.
    assert np.all(np.isfinite(run.carrier_angle_rad))


def test_interpolation_is_by_time_between_brackets():
    times = np.array([0.0, 0.1, 0.4, 0.5])
    values = np.array([[0.0], [1.0], [4.0], [5.0]])
    frames = np.array([0.0, 0.05, 0.25, 0.5, 0.52, 0.6])
    result = recorded_run.interpolate_samples(times, values, frames, gap_s=0.5, edge_s=0.05)
    np.testing.assert_allclose(result[:, 0], [0.0, 0.5, 2.5, 5.0, 5.0, np.nan])
    # A gap: samples 0.3 s apart with gap_s 0.2 give no value between them.
    result = recorded_run.interpolate_samples(times, values, frames, gap_s=0.2, edge_s=0.0)
    np.testing.assert_allclose(result[:, 0], [0.0, 0.5, np.nan, 5.0, np.nan, np.nan])
    # Angles the shorter way round.
    angles = np.array([[3.0], [-3.0]])
    result = recorded_run.interpolate_samples(np.array([0.0, 1.0]), angles, np.array([0.5]),
                                              angle_columns=(0,), gap_s=2.0)  # fmt: skip
    assert abs(abs(result[0, 0]) - (3.0 + (2 * math.pi - 6.0) / 2)) < 1e-12


def test_animate_bag_writes_a_gif_with_a_frame_every_one_over_fps(swim_cli, tmp_path, circle_bag):
    output = tmp_path / "run.gif"
    status, out, err = swim_cli(
        "animate", "--bag", circle_bag, "--config", OSCILLATORY, "--fish", FISH,
        "--fps", 5, "--start", 1.0, "--duration", 2.0, "--output", output,
    )  # fmt: skip
    assert status == 0, err
    assert out.startswith(f"wrote {output} (11 frames, 1.00 to 3.00 s of {circle_bag}")
    assert "2 goals" in out
    with Image.open(output) as gif:
        assert gif.n_frames == 11 and gif.size == animate.FIGURE_SIZE_PX
        assert gif.info["duration"] == 200


def test_animate_bag_to_its_end_with_the_default_output(
    swim_cli, tmp_path, circle_bag, monkeypatch
):
    monkeypatch.chdir(tmp_path)
    status, out, err = swim_cli("animate", "--bag", circle_bag, "--fps", 2)
    assert status == 0, err
    last = odom_times()[-1]
    frames = math.floor(last * 2) + 1
    assert out.startswith(f"wrote circle.gif ({frames} frames, 0.00 to {(frames - 1) / 2:.2f} s")
    with Image.open(tmp_path / "circle.gif") as gif:
        assert gif.n_frames == frames


def test_the_carrier_from_motor_joint_state_without_tail_state(tmp_path):
    bag = write_bag(tmp_path / "joints", topics=("odom", "joint"))
    run = recorded_run.read_recorded_run(bag, fps=10.0, duration_s=1.0)
    np.testing.assert_allclose(run.carrier_angle_rad, CARRIER_RAD_S * run.time_s, atol=1e-9)
    assert run.carrier_source == "carrier_joint of /motor/joint_state"
    np.testing.assert_array_equal(run.pivot_shift_m, 0.0)
    assert run.goals.shape == (0, 2)


def _garbage_bag(tmp_path):
    bag = tmp_path / "garbage"
    bag.mkdir()
    (bag / "metadata.yaml").write_text("rosbag2_bagfile_information: [not, a, bag\n")
    return bag


@pytest.mark.parametrize(
    ("bag", "arguments", "words"),
    [
        ("{tmp}/no_such_bag", (), "no_such_bag: no such file or directory"),
        ("no_odom", (), "no fish/odom messages, which the animation draws the fish from"),
        ("garbage", (), "not a readable rosbag2 bag"),
        ("circle", ("--start", 10), "--start 10 s is past the end of fish/odom"),
        ("long", ("--fps", 50), "s of recording from --start 0 s at --fps 50 is 29"),
        ("long", ("--fps", 50, "--start", 5, "--duration", 50), "50.0 s of recording from "
         "--start 5 s at --fps 50 is 2501 frames, but a GIF takes 2 to 2000: choose a shorter "
         "window"),
        ("circle", ("--speed", 8), "--speed is for a simulated run, not with --bag"),
        ("circle", ("--output", "{tmp}/run.png"), "name it *.gif"),
    ],
)  # fmt: skip
def test_bad_bag_input_is_one_line_and_exit_2(
    swim_cli, tmp_path, circle_bag, bag, arguments, words
):
    paths = {"circle": circle_bag, "garbage": _garbage_bag(tmp_path)}
    if bag == "no_odom":
        paths[bag] = write_bag(tmp_path / "no_odom", topics=("state",))
    if bag == "long":
        paths[bag] = write_bag(tmp_path / "long", topics=("odom",), duration_s=60, odom_hz=1)
    bag_path = paths.get(bag, bag.format(tmp=tmp_path))
    arguments = [str(a).format(tmp=tmp_path) for a in arguments]
    if "--output" not in arguments:
        arguments += ["--output", str(tmp_path / "run.gif")]
    status, out, err = swim_cli("animate", "--bag", bag_path, *arguments)
    assert status == 2 and out == ""
    assert err.startswith("fishtail-swim: error:") and err.count("\n") == 1, err
    assert words in err
    assert "Traceback" not in err
    assert not (tmp_path / "run.gif").exists()


def test_recorded_run_options_need_a_bag(swim_cli, tmp_path):
    status, _, err = swim_cli("animate", "--speed", 8, "--duration", 1, "--start", 1,
                             "--output", tmp_path / "x.gif")  # fmt: skip
    assert status == 2 and "--start is for a recorded run: add --bag DIR" in err


def test_bag_reading_errors_are_bag_errors(tmp_path):
    with pytest.raises(BagError, match="no such file or directory"):
        recorded_run.read_recorded_run(tmp_path / "nothing", fps=10.0)


def test_bag_reading_doctests():
    result = doctest.testmod(fishtail_common.bag_reading)
    assert result.attempted > 0 and result.failed == 0
