"""Steady segments of a recorded run (``offline/recorded_measurements.py``), from bags written here.

The bags are written with rosbags as the other bag tests write theirs (``Writer``, version 9, MCAP;
the kinematics offline tests' ``header`` and ``tail_state`` helpers): a carrier at 200 Hz that
turns at 8 rad/s, then ramps to 12 rad/s, and a fish on fish/odom (100 Hz, irregular stamps) whose
speed relaxes exponentially towards 0.03 m/rad times the carrier speed, turning at a constant
rate, with a wiggle in the carrier's phase that vanishes at every beat end. Its path is integrated
at 1 kHz, so the expected means are its own arc lengths and headings over each segment's window.
"""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest
from rosbags.rosbag2 import Writer
from rosbags.rosbag2.enums import StoragePlugin

from fishtail_common.bag_reading import BagError
from fishtail_common.bag_types import suite_typestore
from fishtail_common.interface import FISH_ODOM, MOTOR_JOINT_STATE, TAIL_STATE
from fishtail_kinematics.engine.geometry import OscillatoryGeometry
from fishtail_kinematics.engine.mechanisms import make_tail
from fishtail_swim.offline.recorded_measurements import CSV_HEADER, measurements_from_bag
from fishtail_swim.offline.steady_segments import (
    NoSteadySegmentError,
    RecordedSamples,
    SteadyCriterion,
    steady_segments,
)

ROOT = Path(__file__).resolve().parents[3]
T0_NS = 1_700_000_000_000_000_000
FINE_HZ = 1000
CARRIER_HZ = 200
ODOM_EVERY = 10  # fish/odom every 10th fine step (100 Hz), stamps jittered by up to 2 ms
SPEEDS = (8.0, 12.0)
CHANGE_S = (24.0, 24.5)  # the carrier ramps from the first speed to the second
DURATION_S = 44.0
SPEED_PER_CARRIER = 0.03  # m/rad: the fish's steady speed per rad/s of carrier
RELAX_S = 1.0
YAW_RATE = -0.01
WIGGLE_M = 0.005  # along the path, in the carrier's phase
WIGGLE_RAD = 0.02  # heading wiggle, in the carrier's phase


def _bag_helpers():
    """The kinematics offline tests' message helpers (header, tail_state), from their file."""
    path = ROOT / "src/fishtail_kinematics/test/offline/test_analysis.py"
    spec = importlib.util.spec_from_file_location("kinematics_bag_helpers", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


HELPERS = _bag_helpers()


class Run:
    """The synthetic run at 1 kHz: carrier speed and angle, the fish's speed, arc, pose."""

    def __init__(self, duration_s=DURATION_S, accelerating=False):
        """The run over ``duration_s``; ``accelerating``: a fish that never settles."""
        t = np.arange(round(duration_s * FINE_HZ) + 1) / FINE_HZ
        ramp = np.clip((t - CHANGE_S[0]) / (CHANGE_S[1] - CHANGE_S[0]), 0.0, 1.0)
        carrier = SPEEDS[0] + (SPEEDS[1] - SPEEDS[0]) * ramp
        angle = np.concatenate([[0.0], np.cumsum(0.5 * (carrier[1:] + carrier[:-1]) / FINE_HZ)])
        if accelerating:  # never steady: the fish speeds up all the time
            speed = 0.01 * t
        else:  # first-order lag of the target speed, from rest
            target, speed = SPEED_PER_CARRIER * carrier, np.zeros_like(t)
            decay = math.exp(-1.0 / (FINE_HZ * RELAX_S))
            for k in range(1, t.size):
                speed[k] = target[k] + (speed[k - 1] - target[k]) * decay
        self.arc = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) / FINE_HZ)])
        heading = YAW_RATE * t
        along = self.arc + WIGGLE_M * np.sin(angle)
        step = np.diff(along, prepend=0.0)
        self.psi = heading + WIGGLE_RAD * np.sin(angle)
        self.x = np.cumsum(step * np.cos(heading))
        self.y = np.cumsum(step * np.sin(heading))
        self.t, self.angle, self.carrier = t, angle, carrier

    def mean_speed(self, start_s, end_s):
        """The fish's mean speed along its path over the window."""
        return float(np.diff(np.interp([start_s, end_s], self.t, self.arc))[0] / (end_s - start_s))


RUN = Run()


def odom_indices(run, hole=None):
    """Fine-step indices of the fish/odom samples: every 10th, jittered, minus a hole."""
    k = np.arange(0, run.t.size - 2, ODOM_EVERY)
    k = k + np.round(2 * np.sin(1.7 * k)).astype(int).clip(-2, 2)
    k[0] = 0
    if hole is not None:
        k = k[(run.t[k] <= hole[0]) | (run.t[k] >= hole[1])]
    return k


def write_bag(path, run=RUN, carrier="joint", odom=True, hole=None, nan_at=None):
    """A bag as fishtail-record writes it (receive time = stamp + 0.1 ms)."""
    store = suite_typestore()
    types = store.types
    vector, point = types["geometry_msgs/msg/Vector3"], types["geometry_msgs/msg/Point"]
    quaternion = types["geometry_msgs/msg/Quaternion"]
    messages = []
    if odom:
        for k in odom_indices(run, hole):
            stamp = T0_NS + int(k) * (1_000_000_000 // FINE_HZ)
            x = math.nan if nan_at is not None and abs(run.t[k] - nan_at) < 0.006 else run.x[k]
            psi = run.psi[k]
            odometry = types["nav_msgs/msg/Odometry"](
                header=HELPERS.header(store, stamp, "odom"), child_frame_id="base_link",
                pose=types["geometry_msgs/msg/PoseWithCovariance"](
                    pose=types["geometry_msgs/msg/Pose"](
                        position=point(x=x, y=run.y[k], z=0.0),
                        orientation=quaternion(x=0.0, y=0.0, z=math.sin(psi / 2),
                                               w=math.cos(psi / 2))),
                    covariance=np.zeros(36)),
                twist=types["geometry_msgs/msg/TwistWithCovariance"](
                    twist=types["geometry_msgs/msg/Twist"](
                        linear=vector(x=0.0, y=0.0, z=0.0), angular=vector(x=0.0, y=0.0, z=0.0)),
                    covariance=np.zeros(36)),
            )  # fmt: skip
            messages.append((stamp, FISH_ODOM, odometry))
    tail = make_tail(OscillatoryGeometry())
    for k in range(0, run.t.size, FINE_HZ // CARRIER_HZ) if carrier else ():
        stamp = T0_NS + k * (1_000_000_000 // FINE_HZ)
        angle, speed = float(run.angle[k]), float(run.carrier[k])
        if carrier == "state":
            messages.append(
                (stamp, TAIL_STATE, HELPERS.tail_state(store, tail, stamp, angle, speed))
            )
        else:
            joint = types["sensor_msgs/msg/JointState"](
                header=HELPERS.header(store, stamp), name=["carrier_joint"],
                position=np.array([angle]), velocity=np.array([speed]),
                effort=np.array([], dtype=float),
            )  # fmt: skip
            messages.append((stamp, MOTOR_JOINT_STATE, joint))
    messages.sort(key=lambda item: item[0])
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        connections = {}
        for stamp, topic, message in messages:
            if topic.name not in connections:
                connections[topic.name] = writer.add_connection(
                    f"/{topic.name}", topic.type, typestore=store
                )
            writer.write(
                connections[topic.name], stamp + 100_000, store.serialize_cdr(message, topic.type)
            )
    return path


@pytest.fixture(scope="module")
def bags(tmp_path_factory):
    root = tmp_path_factory.mktemp("bags")
    return {"joint": write_bag(root / "joint"), "state": write_bag(root / "state", carrier="state")}


def check_segment_means(segment, run=RUN):
    """The segment's means against the synthetic run's own over the same window."""
    window = (segment.start_s, segment.end_s)
    assert segment.speed_m_s == pytest.approx(run.mean_speed(*window), rel=2e-4)
    assert segment.yaw_rate_rad_s == pytest.approx(YAW_RATE, rel=2e-3)
    duration = segment.end_s - segment.start_s
    assert segment.beats == round(np.diff(np.interp(window, run.t, run.angle))[0] / (2 * math.pi))
    assert segment.carrier_speed_rad_s == pytest.approx(2 * math.pi * segment.beats / duration)


def test_two_carrier_speeds_give_two_segments_with_the_runs_means(bags):
    result = measurements_from_bag(bags["joint"])
    assert result.odom_topic == "/fish/odom"
    assert result.carrier_source == "carrier_joint of /motor/joint_state"
    first, second = result.segments
    for segment, speed in zip(result.segments, SPEEDS, strict=True):
        assert segment.carrier_speed_rad_s == pytest.approx(speed, rel=1e-6)
        # Settled: within the speed tolerance of the steady speed, from below.
        assert 0.99 < segment.speed_m_s / (SPEED_PER_CARRIER * speed) <= 1.0
        assert segment.beats >= SteadyCriterion().min_beats
        check_segment_means(segment)
    # The first waits for the fish to come up to speed, the second for the change to settle; each
    # ends with the last whole beat before the ramp (the ramp's beats are not steady) or the data.
    # (The first stretch starts where the first whole beat does, one turn after the start.)
    assert 3.0 < first.start_s
    assert first.settle_s == pytest.approx(first.start_s - 2 * math.pi / SPEEDS[0], abs=1e-9)
    assert CHANGE_S[0] - 2 * math.pi / SPEEDS[0] < first.end_s <= CHANGE_S[0]
    assert CHANGE_S[1] + 2.0 < second.start_s < second.end_s <= DURATION_S
    assert DURATION_S - second.end_s < 2 * math.pi / SPEEDS[1] + 0.01


def test_tail_state_serves_as_the_carrier_when_there_is_no_motor_joint_state(bags):
    by_joint = measurements_from_bag(bags["joint"]).segments
    result = measurements_from_bag(bags["state"])
    assert result.carrier_source == "motor_angle of /tail/state"
    assert result.segments == by_joint


def test_csv_text_is_a_measurements_file(bags):
    result = measurements_from_bag(bags["joint"])
    text = result.csv_text()
    lines = text.splitlines()
    comments = [line for line in lines if line.startswith("#")]
    rows = [line for line in lines if not line.startswith("#")]
    assert lines[: len(comments)] == comments  # comments first
    assert rows[0] == CSV_HEADER and len(rows) == 1 + len(result.segments)
    assert str(bags["joint"]) in comments[0]
    for number, segment in enumerate(result.segments, start=1):
        (line,) = [c for c in comments if c.startswith(f"# segment {number}:")]
        assert f"{segment.start_s:.3f} to {segment.end_s:.3f} s" in line
        assert f"{segment.beats} beats" in line
    table = np.array([[float(field) for field in row.split(",")] for row in rows[1:]])
    np.testing.assert_allclose(table[:, 0], result.carrier_speed_rad_s, rtol=1e-5)
    np.testing.assert_allclose(table[:, 1], result.speed_m_s, rtol=1e-5)
    np.testing.assert_allclose(table[:, 2], result.yaw_rate_rad_s, rtol=1e-5)
    assert text.endswith("\n") and CSV_HEADER == "carrier_speed_rad_s,speed_m_s,yaw_rate_rad_s"


def test_a_gap_splits_a_stretch_and_no_segment_spans_it(tmp_path):
    hole = (15.0, 15.5)
    result = measurements_from_bag(write_bag(tmp_path / "hole", hole=hole))
    assert all(s.end_s <= hole[0] or s.start_s >= hole[1] for s in result.segments)
    # Before the hole the fish has settled: a segment; after it 8.5 s of the first speed, which
    # counts as a new stretch (its settling starts again); then the second speed.
    before = [s for s in result.segments if s.end_s <= hole[0]]
    assert len(before) == 1 and before[0].end_s > hole[0] - 2 * math.pi / SPEEDS[0]
    assert any(s.carrier_speed_rad_s == pytest.approx(SPEEDS[1]) for s in result.segments)
    for segment in result.segments:
        check_segment_means(segment)
    assert any("1 gap(s) over 0.1 s" in line for line in result.csv_text().splitlines())


def test_gaps_closer_than_a_segment_leave_the_stretch_out():
    # A hole every 5 s in the first speed's stretch: no 10 beats without a gap there.
    run = RUN
    holes = [(5.0 * k, 5.0 * k + 0.3) for k in range(1, 5)]
    keep = np.ones(run.t.size, dtype=bool)
    for start, end in holes:
        keep &= (run.t <= start) | (run.t >= end)
    samples = RecordedSamples(
        run.t[keep][::10], run.x[keep][::10], run.y[keep][::10], run.psi[keep][::10],
        run.t[::5], run.angle[::5],
    )  # fmt: skip
    segments, notes = steady_segments(samples, SteadyCriterion())
    assert [round(s.carrier_speed_rad_s) for s in segments] == [12]
    assert notes == ("4 gap(s) over 0.1 s split the recording",)


def one_line(error):
    text = str(error.value)
    assert "\n" not in text
    return text


def test_a_bag_without_fish_odom_is_refused(tmp_path):
    with pytest.raises(BagError) as error:
        measurements_from_bag(write_bag(tmp_path / "no_odom", run=Run(5.0), odom=False))
    assert "no fish/odom messages" in one_line(error)


def test_a_bag_without_a_carrier_is_refused(tmp_path):
    with pytest.raises(BagError) as error:
        measurements_from_bag(write_bag(tmp_path / "no_carrier", run=Run(5.0), carrier=None))
    assert "no carrier (no motor/joint_state or tail/state messages)" in one_line(error)


def test_a_short_bag_has_no_steady_segment(tmp_path):
    with pytest.raises(NoSteadySegmentError) as error:
        measurements_from_bag(write_bag(tmp_path / "short", run=Run(7.0)))
    text = one_line(error)
    assert "no steady segment: too short:" in text
    assert "at most 7 whole beats (at 8 rad/s), 10 needed" in text


def test_a_fish_that_keeps_accelerating_is_never_steady(tmp_path):
    with pytest.raises(NoSteadySegmentError) as error:
        measurements_from_bag(write_bag(tmp_path / "accelerating", run=Run(20.0, True)))
    text = one_line(error)
    assert "no steady segment: the fish's speed never steady:" in text
    assert "1 % allowed" in text


def test_a_bag_with_a_nan_is_refused(tmp_path):
    with pytest.raises(BagError) as error:
        measurements_from_bag(write_bag(tmp_path / "nan", run=Run(6.0), nan_at=3.0))
    assert "/fish/odom has a value that is not a finite number" in one_line(error)


def test_a_missing_bag_is_refused(tmp_path):
    with pytest.raises(BagError) as error:
        measurements_from_bag(tmp_path / "nowhere")
    assert one_line(error).endswith("nowhere: no such file or directory")


@pytest.mark.parametrize(
    "changes", [{"min_beats": 1}, {"carrier_tolerance": 0.0}, {"gap_s": math.nan}]
)
def test_a_criterion_out_of_range_is_refused(changes):
    with pytest.raises(ValueError):
        SteadyCriterion(**changes)


def test_fit_takes_a_bag_and_writes_the_measurements_it_gave(bags, swim_cli, tmp_path):
    """The synthetic fish is no model fish: the fit may be contradicted, but it reads the bag."""
    written = tmp_path / "segments.csv"
    status, out, err = swim_cli(
        "fit", "--bag", bags["joint"], "--write-measurements", written, "--force",
        "--coefficients", "quadratic",
    )  # fmt: skip
    assert status == 0, err
    assert f"2 steady segment(s) in {bags['joint']}" in out
    assert f"wrote {written}" in out
    expected = measurements_from_bag(bags["joint"]).csv_text()
    assert written.read_text("utf-8") == expected


@pytest.mark.parametrize(
    "arguments, words",
    [
        (("fit",), "fit takes a MEASUREMENTS.csv file or --bag DIR (one of them)"),
        (("fit", "m.csv", "--bag", "b"), "fit takes a MEASUREMENTS.csv file or --bag DIR"),
        (("fit", "m.csv", "--write-measurements", "x.csv"),
         "--write-measurements and --namespace go with --bag"),
        (("fit", "--bag", "nowhere"), "nowhere"),
    ],
)  # fmt: skip
def test_fit_refuses_a_wrong_bag_request_in_one_line(swim_cli, arguments, words):
    status, out, err = swim_cli(*arguments)
    assert status == 2
    assert words in err and len(err.strip().splitlines()) == 1, err


def test_fit_of_a_bag_without_a_steady_segment_says_why(swim_cli, tmp_path):
    status, _, err = swim_cli("fit", "--bag", write_bag(tmp_path / "short", run=Run(7.0)))
    assert status == 2
    assert "no steady segment: too short:" in err and len(err.strip().splitlines()) == 1, err
