"""Offline analysis: bags written here with rosbags from engine-generated messages, and the CSV.

The bags imitate the node suite: the driver's ``motor/joint_state`` at 200 Hz, the kinematics node's
``tail/state`` solved per sample with the engine's scalar path (as the node does) and stamped like
its input, the monitor's ``tail/symmetry``. The analysis recomputes them with the vectorised path,
so the disagreement is rounding only. Damaged, truncated, empty and foreign inputs must end with a
one-line error and exit status 2.
"""

from __future__ import annotations

import math
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from rosbags.rosbag2 import Writer
from rosbags.rosbag2.enums import StoragePlugin
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from fishtail_common.parameter_files import load_parameter_file
from fishtail_kinematics.engine.mechanisms import UndulatoryTail, make_tail
from fishtail_kinematics.engine.parameters import geometry_from_parameters, geometry_parameters_in
from fishtail_kinematics.engine.symmetry import SymmetryTolerances, Verdict, beats_of, judge
from fishtail_kinematics.offline import analyse_cli, analysis, cli

ROOT = Path(__file__).resolve().parents[4]
CONFIG = ROOT / "config"
MSG_DIR = ROOT / "src" / "fishtail_msgs" / "msg"
SPEED_RAD_S = 12.0
RATE_HZ = 200.0
T0_NS = 1_700_000_000_123_456_789
STORAGES = {"mcap": StoragePlugin.MCAP, "sqlite3": StoragePlugin.SQLITE3}
MECHANISM_CODE = {"oscillatory": 1, "undulatory": 2}


@pytest.fixture(scope="module")
def store():
    typestore = get_typestore(Stores.ROS2_JAZZY)
    definitions = {}
    for path in sorted(MSG_DIR.glob("*.msg")):
        definitions.update(get_types_from_msg(path.read_text(), f"fishtail_msgs/msg/{path.stem}"))
    typestore.register(definitions)
    return typestore


def geometry_of(config: Path):
    return geometry_from_parameters(geometry_parameters_in(load_parameter_file(config)))


def header(store, stamp_ns: int, frame_id: str = ""):
    types_ = store.types
    stamp = types_["builtin_interfaces/msg/Time"](
        sec=stamp_ns // 1_000_000_000, nanosec=stamp_ns % 1_000_000_000
    )
    return types_["std_msgs/msg/Header"](stamp=stamp, frame_id=frame_id)


def tail_state(store, tail, stamp_ns: int, angle: float, velocity: float):
    """A TailState as the kinematics node fills it (scalar engine path)."""
    s = tail.solve(float(angle), float(velocity))
    undulatory = isinstance(tail, UndulatoryTail)
    nan = math.nan
    point = store.types["geometry_msgs/msg/Point"]
    vector = store.types["geometry_msgs/msg/Vector3"]
    return store.types["fishtail_msgs/msg/TailState"](
        header=header(store, stamp_ns, "tail_mechanism"),
        mechanism=2 if undulatory else 1,
        motor_angle=s.motor_angle, motor_velocity=s.motor_velocity,
        slider_position=s.slider_position, slider_velocity=s.slider_velocity,
        theta1=s.theta1, theta1_dot=s.theta1_dot, theta2=s.theta2, theta2_dot=s.theta2_dot,
        theta3=s.theta3, theta3_dot=s.theta3_dot,
        theta4=s.theta4 if undulatory else nan, theta4_dot=s.theta4_dot if undulatory else nan,
        pin_u_distance=s.pin_u_distance if undulatory else nan,
        pin_u_distance_rate=s.pin_u_distance_rate if undulatory else nan,
        slider_a_distance=s.slider_a_distance if undulatory else nan,
        slider_a_distance_rate=s.slider_a_distance_rate if undulatory else nan,
        theta5=s.theta5 if undulatory else nan, theta5_dot=s.theta5_dot if undulatory else nan,
        pivot_shift=tail.pivot_shift_m, swing_bias=tail.swing_bias_rad, fin_angle=s.fin_angle,
        tip=point(x=s.tip_x, y=s.tip_y, z=0.0),
        tip_velocity=vector(x=s.tip_x_dot, y=s.tip_y_dot, z=0.0),
    )  # fmt: skip


def write_bag(
    store,
    path: Path,
    storage: str = "mcap",
    config: Path = CONFIG / "oscillatory.yaml",
    seconds: float = 2.0,
    tail_state_topic: bool = True,
    joint_state_topic: bool = True,
    drop_joint_every: int = 0,
    reports: int = 0,
    namespace: str = "",
    pivot_shifts: tuple[float, ...] = (),
    fish_odom_m_s: float | None = None,
    fish_swimming_m_s: float | None = None,
    fish_from_s: float = 0.0,
) -> Path:
    """A bag like a recording of the suite at constant speed (stamps = receive times + 50 us).

    ``pivot_shifts``: the pivot moves through these shifts, each held for an equal share of the
    recording (none: the unshifted tail throughout). ``fish_odom_m_s``: a fish/odom sample with
    this surge at every carrier sample from ``fish_from_s`` on; ``fish_swimming_m_s``: a
    fish/swimming message with this mean speed at the end of every carrier revolution (as the
    simulator publishes them).
    """
    design = make_tail(geometry_of(config))
    shifted = [design.with_pivot_shift(shift) for shift in pivot_shifts] or [design]
    samples = int(seconds * RATE_HZ)
    with Writer(path, version=9, storage_plugin=STORAGES[storage]) as writer:
        add = writer.add_connection
        joints = add(
            f"{namespace}/motor/joint_state", "sensor_msgs/msg/JointState", typestore=store
        )
        states = add(f"{namespace}/tail/state", "fishtail_msgs/msg/TailState", typestore=store)
        report_connection = add(
            f"{namespace}/tail/symmetry", "fishtail_msgs/msg/SymmetryReport", typestore=store
        )
        if fish_odom_m_s is not None:
            odom = add(f"{namespace}/fish/odom", "nav_msgs/msg/Odometry", typestore=store)
        if fish_swimming_m_s is not None:
            swimming = add(
                f"{namespace}/fish/swimming", "fishtail_msgs/msg/SwimFigures", typestore=store
            )
        for k in range(samples):
            stamp = T0_NS + round(k * 1e9 / RATE_HZ)
            angle = 0.3 + SPEED_RAD_S * k / RATE_HZ
            if fish_odom_m_s is not None and k / RATE_HZ >= fish_from_s:
                message = odometry(store, stamp, fish_odom_m_s, k / RATE_HZ)
                writer.write(odom, stamp + 60_000, store.serialize_cdr(message, ODOMETRY))
            revolution = math.floor(angle / (2 * math.pi))
            previous = math.floor((angle - SPEED_RAD_S / RATE_HZ) / (2 * math.pi))
            if fish_swimming_m_s is not None and k and revolution > previous:
                # Stamped where the carrier passed the multiple of 2 pi, as the simulator does.
                end_ns = T0_NS + round((2 * math.pi * revolution - 0.3) / SPEED_RAD_S * 1e9)
                message = swim_figures(store, end_ns, revolution, fish_swimming_m_s)
                data = store.serialize_cdr(message, "fishtail_msgs/msg/SwimFigures")
                writer.write(swimming, stamp + 70_000, data)
            if joint_state_topic and not (drop_joint_every and k % drop_joint_every == 0):
                message = store.types["sensor_msgs/msg/JointState"](
                    header=header(store, stamp), name=["carrier_joint"],
                    position=np.array([angle]), velocity=np.array([SPEED_RAD_S]),
                    effort=np.array([], dtype=float),
                )  # fmt: skip
                data = store.serialize_cdr(message, "sensor_msgs/msg/JointState")
                writer.write(joints, stamp + 50_000, data)
            if tail_state_topic:
                tail = shifted[k * len(shifted) // samples]
                message = tail_state(store, tail, stamp, angle, SPEED_RAD_S)
                data = store.serialize_cdr(message, "fishtail_msgs/msg/TailState")
                writer.write(states, stamp + 80_000, data)
        for index in range(reports):
            message = store.types["fishtail_msgs/msg/SymmetryReport"](
                header=header(store, T0_NS), beat_index=index, positive_peak=0.46,
                negative_peak=-0.46, amplitude=0.46, mean_angle=0.0, positive_time_share=0.5,
                negative_time_share=0.5, period=0.52, frequency=1.9, verdict=0, message="",
            )  # fmt: skip
            data = store.serialize_cdr(message, "fishtail_msgs/msg/SymmetryReport")
            writer.write(report_connection, T0_NS + 1000 + index, data)
    return path


ODOMETRY = "nav_msgs/msg/Odometry"


def odometry(store, stamp_ns: int, surge_m_s: float, time_s: float):
    """The fish swimming along x at ``surge_m_s``, with the sway of a beating tail."""
    types_ = store.types
    vector = types_["geometry_msgs/msg/Vector3"]
    pose = types_["geometry_msgs/msg/Pose"](
        position=types_["geometry_msgs/msg/Point"](x=surge_m_s * time_s, y=0.0, z=0.0),
        orientation=types_["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
    )
    sway = 0.02 * math.sin(SPEED_RAD_S * time_s)
    twist = types_["geometry_msgs/msg/Twist"](
        linear=vector(x=surge_m_s, y=sway, z=0.0), angular=vector(x=0.0, y=0.0, z=0.0)
    )
    return types_[ODOMETRY](
        header=header(store, stamp_ns, "odom"), child_frame_id="base_link",
        pose=types_["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=np.zeros(36)),
        twist=types_["geometry_msgs/msg/TwistWithCovariance"](
            twist=twist, covariance=np.zeros(36)
        ),
    )  # fmt: skip


def swim_figures(store, stamp_ns: int, index: int, speed_m_s: float):
    """The simulator's figures of the carrier revolution that ended at ``stamp_ns``."""
    frequency = SPEED_RAD_S / (2 * math.pi)
    return store.types["fishtail_msgs/msg/SwimFigures"](
        header=header(store, stamp_ns, "odom"), beat_index=index, beat_frequency_hz=frequency,
        mean_speed_m_s=speed_m_s, body_lengths_per_s=speed_m_s / 0.3, tip_excursion_m=0.13,
        strouhal_number=frequency * 0.13 / speed_m_s, mean_thrust_n=0.1, mean_tail_power_w=0.1,
        froude_efficiency=0.2, turning_radius_m=math.inf, heading_change_rad=0.0,
    )  # fmt: skip


def run_cli(capsys, *argv) -> tuple[int, str, str]:
    status = analyse_cli.main([str(a) for a in argv])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def skewed_config(tmp_path: Path) -> Path:
    """The report geometry with the pivot moved and RS not re-derived: about 52.6 % on +side."""
    document = yaml.safe_load((CONFIG / "oscillatory.yaml").read_text())
    document["/**"]["ros__parameters"]["pivot_offset_m"] = 0.17
    path = tmp_path / "skewed.yaml"
    path.write_text(yaml.safe_dump(document))
    return path


# --------------------------------------------------------------------------------------------
# Bags of our own


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
@pytest.mark.parametrize("mechanism", ["oscillatory", "undulatory"])
def test_bag_agrees_with_engine_and_is_symmetric(store, tmp_path, capsys, storage, mechanism):
    bag = write_bag(store, tmp_path / "bag", storage, CONFIG / f"{mechanism}.yaml", reports=3)
    figures = tmp_path / "figures"
    status, out, err = run_cli(capsys, bag, "--output-dir", figures)
    assert status == 0, err
    report = analysis.analyse(bag, output_dir=figures)
    d = report.disagreement
    assert d.samples == 400
    assert d.worst < 1e-12, d.per_field
    assert "motor_angle" in d.per_field and "tip_y_dot" in d.per_field
    if mechanism == "undulatory":
        assert "theta5_dot" in d.per_field
    assert report.recording.mechanism == mechanism
    assert "all 400 tail states matched by stamp" in out
    assert f"mechanism: {mechanism}" in out
    beats = report.beats
    assert len(beats) >= 3
    assert all(b.verdict == Verdict.OK for b in beats)
    assert np.allclose(report.frequencies_hz, SPEED_RAD_S / (2 * math.pi), rtol=1e-3)
    assert f"symmetry: {len(beats)} beats: {len(beats)} OK, 0 WARN, 0 ERROR" in out
    assert "monitor (tail/symmetry in the recording): 3 beats, 3 OK" in out
    names = {p.name for p in figures.iterdir()}
    expected = {"theta3.png", "tip_path.png"}
    if mechanism == "undulatory":
        expected.add("theta3_theta5.png")
    assert names == expected
    assert all((figures / name).stat().st_size > 10_000 for name in names)


@pytest.mark.parametrize("mechanism", ["oscillatory", "undulatory"])
def test_a_recording_with_the_pivot_shifted_is_recomputed_with_its_shifts(
    store, tmp_path, mechanism
):
    bag = write_bag(
        store, tmp_path / "bag", config=CONFIG / f"{mechanism}.yaml", seconds=3.0,
        pivot_shifts=(0.0, 0.02, -0.015),
    )  # fmt: skip
    report = analysis.analyse(bag, output_dir=tmp_path / "f")
    shifts = report.recording.pivot_shift_m
    assert shifts is not None and sorted(set(shifts.tolist())) == [-0.015, 0.0, 0.02]
    d = report.disagreement
    assert d.worst < 1e-12, d.per_field
    assert "fin_angle" in d.per_field and "tip_x" in d.per_field


def test_table_is_the_monitors_statistics(store, tmp_path):
    """The analysis's beats are beats_of + judge on the stamps, theta3 and carrier angle."""
    bag = write_bag(store, tmp_path / "bag", config=skewed_config(tmp_path))
    report = analysis.analyse(bag, config=skewed_config(tmp_path), output_dir=tmp_path / "f")
    recording = report.recording
    expected = beats_of(
        recording.stamp_s, recording.state["theta3"], carrier_rad=recording.carrier_angle
    )
    assert [j.beat for j in report.beats] == expected
    tolerances = SymmetryTolerances()
    assert [(j.verdict, j.reason) for j in report.beats] == [judge(b, tolerances) for b in expected]
    assert all(j.verdict == Verdict.ERROR for j in report.beats)
    assert report.disagreement.agrees


def test_skewed_recording_against_default_geometry_disagrees(store, tmp_path, capsys):
    bag = write_bag(store, tmp_path / "bag", config=skewed_config(tmp_path))
    status, out, _ = run_cli(capsys, bag, "--output-dir", tmp_path / "f")
    assert status == 1
    assert "DISAGREES" in out and "--config" in out
    status, out, _ = run_cli(
        capsys, bag, "--config", skewed_config(tmp_path), "--output-dir", tmp_path / "f"
    )
    assert status == 0
    assert "agrees" in out and "ERROR" in out and "time share off" in out


def test_config_of_the_other_mechanism_is_refused(store, tmp_path, capsys):
    bag = write_bag(store, tmp_path / "bag")
    status, _, err = run_cli(capsys, bag, "--config", CONFIG / "undulatory.yaml")
    assert status == 2
    assert "oscillatory mechanism" in err and len(err.splitlines()) == 1


def test_unmatched_samples_use_the_tail_states_own_carrier_angle(store, tmp_path, capsys):
    bag = write_bag(store, tmp_path / "bag", drop_joint_every=7)
    status, out, _ = run_cli(capsys, bag, "--output-dir", tmp_path / "f")
    assert status == 0
    assert "motor/joint_state for 342 of 400 tail states matched by stamp" in out
    assert "agrees" in out


def test_bag_with_tail_state_only(store, tmp_path, capsys):
    bag = write_bag(store, tmp_path / "bag", joint_state_topic=False)
    status, out, _ = run_cli(capsys, bag, "--output-dir", tmp_path / "f")
    assert status == 0
    assert "motor_angle of tail/state (no motor/joint_state recorded)" in out
    assert "agrees" in out


def test_bag_with_motor_joint_state_only(store, tmp_path, capsys):
    bag = write_bag(store, tmp_path / "bag", "sqlite3", tail_state_topic=False)
    status, out, _ = run_cli(capsys, bag, "--output-dir", tmp_path / "f")
    assert status == 0
    assert "disagreement: n/a" in out
    assert "0 WARN, 0 ERROR" in out


def test_bag_with_two_suites_needs_a_namespace(store, tmp_path, capsys):
    bag = write_bag(store, tmp_path / "bag", namespace="/fish", seconds=1.0)
    with Writer(tmp_path / "bag2", version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        from rosbags.rosbag2 import Reader

        with Reader(bag) as reader:
            added = {}
            for connection, timestamp, raw in reader.messages():
                for topic in (connection.topic, connection.topic.replace("/fish", "/shark")):
                    if topic not in added:
                        added[topic] = writer.add_connection(
                            topic, connection.msgtype, typestore=store
                        )
                    writer.write(added[topic], timestamp, raw)
    expect_clean_error(capsys, tmp_path / "bag2", "/fish/tail/state, /shark/tail/state")
    status, out, _ = run_cli(capsys, tmp_path / "bag2", "--namespace", "shark", "--output-dir",
                             tmp_path / "f")  # fmt: skip
    assert status == 0 and "all 200 tail states matched" in out
    expect_clean_error(
        capsys, tmp_path / "bag2", "in namespace 'whale'", options=("--namespace", "whale")
    )


def test_storage_file_given_directly(store, tmp_path, capsys):
    bag = write_bag(store, tmp_path / "bag")
    status, out, _ = run_cli(capsys, bag / "bag.mcap", "--output-dir", tmp_path / "f")
    assert status == 0 and "agrees" in out


def test_split_bag_with_more_files_than_the_open_file_limit(store, tmp_path):
    """fishtail-record writes one file per segment; rosbags opens them all at once."""
    whole = write_bag(store, tmp_path / "whole", seconds=2.0)
    bag = tmp_path / "split"
    bag.mkdir()
    from rosbags.rosbag2 import Reader

    with Reader(whole) as reader:
        connections = list(reader.connections)
        messages = list(reader.messages())
    names = []
    for segment in range(40):
        name = f"split_{segment}"
        with Writer(bag / name, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
            added = {
                c.topic: writer.add_connection(c.topic, c.msgtype, typestore=store)
                for c in connections
            }
            for connection, timestamp, raw in messages[segment::40]:
                writer.write(added[connection.topic], timestamp, raw)
        (bag / name / f"{name}.mcap").rename(bag / f"{name}.mcap")
        shutil.rmtree(bag / name)
        names.append(f"{name}.mcap")
    metadata = yaml.safe_load((whole / "metadata.yaml").read_text())
    information = metadata["rosbag2_bagfile_information"]
    information["relative_file_paths"] = names
    information["files"] = []
    (bag / "metadata.yaml").write_text(yaml.safe_dump(metadata))
    script = (
        "import resource, sys\n"
        "soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)\n"
        "resource.setrlimit(resource.RLIMIT_NOFILE, (32, hard))\n"
        "from rosbags.rosbag2 import Reader\n"
        "try:\n"
        "    Reader(sys.argv[1]).open()\n"
        "except Exception as error:\n"  # rosbags' ReaderError
        "    print('premise:', error)\n"
        "from fishtail_kinematics.offline.analyse_cli import main\n"
        "sys.exit(main([sys.argv[1], '--output-dir', sys.argv[2]]))\n"
    )
    result = subprocess.run(
        [sys.executable, "-c", script, str(bag), str(tmp_path / "f")],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert "premise:" in result.stdout and "Too many open files" in result.stdout
    assert result.returncode == 0, result.stderr
    assert "40 file(s)" in result.stdout and "agrees" in result.stdout


def test_gap_restarts_the_beat():
    time_s = np.arange(0.0, 4.0, 0.005)
    theta3 = 0.4 * np.sin(2 * math.pi * (time_s - 0.05))
    keep = (time_s < 1.7) | (time_s > 2.4)  # a 0.7 s hole
    beats = analysis.beat_table(time_s[keep], theta3[keep], SymmetryTolerances())
    assert [j.beat.index for j in beats] == list(range(len(beats)))
    assert all(abs(j.beat.period_s - 1.0) < 1e-9 for j in beats)
    assert all(j.beat.end_s < 1.7 or j.beat.start_s > 2.4 for j in beats)


# --------------------------------------------------------------------------------------------
# The CLI's CSV


@pytest.mark.parametrize("mechanism", ["oscillatory", "undulatory"])
def test_csv_of_the_cli(tmp_path, capsys, mechanism):
    table = tmp_path / "cycle.csv"
    assert cli.main(["table", "--mechanism", mechanism, "--samples", "720", "--output",
                     str(table)]) == 0  # fmt: skip
    status, out, err = run_cli(capsys, table, "--output-dir", tmp_path / "f")
    assert status == 0, err
    assert "carrier speed 4 rad/s" in out
    report = analysis.analyse(table, output_dir=tmp_path / "f")
    assert report.disagreement.worst < 1e-9
    assert len(report.beats) == 1 and report.beats[0].verdict == Verdict.OK
    assert report.frequencies_hz[0] == pytest.approx(4.0 / (2 * math.pi), rel=1e-9)
    assert len(report.figures) == (3 if mechanism == "undulatory" else 2)


# --------------------------------------------------------------------------------------------
# Inputs that cannot be analysed: one line, status 2, no traceback


def expect_clean_error(capsys, path, *words, tmp_path=None, options=()):
    argv = [path, *options] + ([] if tmp_path is None else ["--output-dir", tmp_path / "f"])
    status, out, err = run_cli(capsys, *argv)
    assert status == 2, (out, err)
    assert out == ""
    assert len(err.splitlines()) == 1, err
    assert err.startswith("fishtail-analyse: error: ")
    assert "Traceback" not in err
    for word in words:
        assert word in err, err
    return err


def test_missing_path(capsys, tmp_path):
    expect_clean_error(capsys, tmp_path / "nope", "no such file")


def test_directory_without_metadata(capsys, tmp_path):
    (tmp_path / "empty").mkdir()
    expect_clean_error(capsys, tmp_path / "empty", "not a readable rosbag2 bag")


def test_garbage_metadata(store, tmp_path, capsys):
    bag = write_bag(store, tmp_path / "bag", seconds=0.2)
    (bag / "metadata.yaml").write_text("rosbag2_bagfile_information: [1, 2\n")
    expect_clean_error(capsys, bag, "not a readable rosbag2 bag")


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_truncated_storage_file(store, tmp_path, capsys, storage):
    bag = write_bag(store, tmp_path / "bag", storage, seconds=0.5)
    (file,) = [p for p in bag.iterdir() if p.suffix in (".mcap", ".db3")]
    data = file.read_bytes()
    file.write_bytes(data[: len(data) // 2])
    expect_clean_error(capsys, bag, "not a readable rosbag2 bag", tmp_path=tmp_path)


def test_damaged_chunk(store, tmp_path, capsys):
    bag = write_bag(store, tmp_path / "bag", seconds=0.5)
    file = bag / "bag.mcap"
    data = bytearray(file.read_bytes())
    middle = len(data) // 3
    data[middle : middle + 64] = b"\xff" * 64
    file.write_bytes(bytes(data))
    expect_clean_error(capsys, bag, "not a readable rosbag2 bag", tmp_path=tmp_path)


def test_storage_file_missing(store, tmp_path, capsys):
    bag = write_bag(store, tmp_path / "bag", seconds=0.2)
    (bag / "bag.mcap").unlink()
    expect_clean_error(capsys, bag, "missing")


def test_foreign_bag(store, tmp_path, capsys):
    with Writer(tmp_path / "bag", version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        chatter = writer.add_connection("/chatter", "std_msgs/msg/String", typestore=store)
        message = store.types["std_msgs/msg/String"](data="hello")
        writer.write(chatter, T0_NS, store.serialize_cdr(message, "std_msgs/msg/String"))
    expect_clean_error(capsys, tmp_path / "bag", "not a fishtail recording", "/chatter")


def test_empty_bag(store, tmp_path, capsys):
    bag = write_bag(store, tmp_path / "bag", seconds=0.0)
    expect_clean_error(capsys, bag, "no tail/state or motor/joint_state message")


def test_junk_file(tmp_path, capsys):
    junk = tmp_path / "junk.bin"
    junk.write_bytes(bytes(range(256)) * 4)
    expect_clean_error(capsys, junk, "junk.bin")


def test_mcap_file_that_is_junk(tmp_path, capsys):
    junk = tmp_path / "x.mcap"
    junk.write_bytes(b"\x89MCAP0\r\n" + b"\x00" * 10)
    expect_clean_error(capsys, junk, "not a readable rosbag2 bag")


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("", ["empty"]),
        ("a,b\n1,2\n", ["missing column"]),
        ("motor_angle_rad,theta3,theta3_dot,Tx,Ty\n0,1,2,3,x\n1,1,2,3,4\n", ["not a number"]),
        ("motor_angle_rad,theta3,theta3_dot,Tx,Ty\n0,1,2,3,4\n", ["at least 2 data rows"]),
        ("motor_angle_rad,theta3,theta3_dot,Tx,Ty\n0,1,2,3\n1,1,2,3,4\n", ["fields"]),
        ("motor_angle_rad,theta3,theta3_dot,Tx,Ty\n1,1,2,3,4\n0,1,2,3,4\n", ["increasing"]),
    ],
    ids=["empty", "columns", "number", "rows", "ragged", "order"],
)
def test_bad_csv(tmp_path, capsys, text, words):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    expect_clean_error(capsys, path, *words)


@pytest.mark.parametrize("bad", ["nan", "inf", "-inf"])
def test_csv_with_a_non_finite_value_is_bad_input(tmp_path, capsys, bad):
    # A table of the CLI with one theta3 replaced: a one-line error naming the line and the
    # column, status 2 and no figures (not a "disagreement" with figures of a broken table).
    table = tmp_path / "cycle.csv"
    assert cli.main(["table", "--samples", "36", "--output", str(table)]) == 0
    lines = table.read_text().splitlines()
    header = lines[0].split(",")
    row = lines[5].split(",")
    row[header.index("theta3")] = bad
    lines[5] = ",".join(row)
    table.write_text("\n".join(lines) + "\n")
    expect_clean_error(
        capsys, table, "line 6, column theta3", f"not a finite number: '{bad}'", tmp_path=tmp_path
    )
    assert not (tmp_path / "f").exists()


def test_unwritable_output_dir(store, tmp_path, capsys):
    bag = write_bag(store, tmp_path / "bag", seconds=0.6)
    blocker = tmp_path / "file"
    blocker.write_text("")
    status, _, err = run_cli(capsys, bag, "--output-dir", blocker / "sub")
    assert status == 2 and err.startswith("fishtail-analyse: error: cannot create")


# --------------------------------------------------------------------------------------------
# Purity and the swimming figures


def test_analysis_does_not_import_rclpy():
    code = "import sys, fishtail_kinematics.offline.analyse_cli; print('rclpy' in sys.modules)"
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "False"


def test_swimming_figures_take_the_flags_over_the_monitors_defaults(store, tmp_path, capsys):
    bag = write_bag(store, tmp_path / "bag", seconds=1.0)
    status, out, _ = run_cli(capsys, bag, "--output-dir", tmp_path / "f", "--fin-span-m", "0.2")
    assert status == 0
    assert (
        "swimming (U = 0.3 m/s assumed (forward_speed_m_s; the recording has no fish/odom or "
        "fish/swimming), fin span 0.2 m, rho = 1000 kg/m^3): f = " in out
    )
    assert "St = f A / U = " in out and "U recorded" not in out


def strouhal_of(out: str) -> float:
    return float(re.search(r"St = f A / U = ([\d.]+)", out)[1])


def test_swimming_figures_take_u_from_the_recorded_fish_odometry(store, tmp_path, capsys):
    bag = write_bag(store, tmp_path / "bag", seconds=3.0, fish_odom_m_s=0.12)
    status, out, err = run_cli(capsys, bag, "--output-dir", tmp_path / "f")
    assert status == 0, err
    report = analysis.analyse(bag, output_dir=tmp_path / "f")
    swimming = report.swimming
    assert swimming.speed_origin == "recorded" and swimming.speed_sources == ["fish/odom"]
    assert len(swimming.per_beat) == swimming.figures.beats >= 4
    for beat in swimming.per_beat:
        assert beat.forward_speed_m_s == pytest.approx(0.12, rel=1e-9)
        assert beat.figures.strouhal_number == pytest.approx(
            beat.figures.beat_frequency_hz * beat.figures.tip_excursion_m / 0.12
        )
    figures = swimming.figures
    expected = figures.beat_frequency_hz * figures.tip_excursion_m / 0.12
    assert figures.strouhal_number == pytest.approx(expected, rel=1e-9)
    assert expected > 1.0  # 1.9 Hz and 0.134 m at 0.12 m/s: far from the assumed 0.3 m/s's St
    assert "swimming (U recorded per beat (fish/odom), 0.12-0.12 m/s, mean 0.12 m/s" in out
    assert strouhal_of(out) == pytest.approx(expected, abs=1e-3)
    assert "assumed" not in out
    assert re.search(r"^\s+1\s+\S+\s+0\.1200 fish/odom ", out, re.MULTILINE), out

    # Without the fish (or when told to), the assumed U, said so.
    status, out, _ = run_cli(capsys, bag, "--output-dir", tmp_path / "f", "--assumed-speed-only")
    assert status == 0
    assert "swimming (U = 0.3 m/s assumed (forward_speed_m_s; the recorded fish's speed not " in out
    assert strouhal_of(out) == pytest.approx(expected * 0.12 / 0.3, abs=1e-3)
    plain = write_bag(store, tmp_path / "plain", seconds=3.0)
    status, out, _ = run_cli(capsys, plain, "--output-dir", tmp_path / "f")
    assert status == 0
    assert "swimming (U = 0.3 m/s assumed (forward_speed_m_s; the recording has no fish" in out
    assert "U recorded" not in out
    assert analysis.analyse(plain, output_dir=tmp_path / "f").swimming.speed_origin == "assumed"


def test_swimming_figures_take_u_from_fish_swimming_matched_to_the_beats(store, tmp_path, capsys):
    bag = write_bag(store, tmp_path / "bag", seconds=3.0, fish_swimming_m_s=0.15)
    status, out, err = run_cli(capsys, bag, "--output-dir", tmp_path / "f")
    assert status == 0, err
    report = analysis.analyse(bag, output_dir=tmp_path / "f")
    swimming, reported_until = report.swimming, report.recording.fish.swim_end_s[-1]
    assert swimming.speed_sources == ["fish/swimming"]
    # A tail beat (fin angle's zero crossings) and a reported carrier revolution last as long but
    # are out of phase: a beat is covered by the two revolutions it overlaps, and a beat that
    # ends after the last reported revolution has no recorded speed.
    assert sum(beat.end_s <= reported_until for beat in swimming.per_beat) >= 3
    for beat in swimming.per_beat:
        if beat.end_s <= reported_until:
            assert beat.speed_source == "fish/swimming", beat
            assert beat.forward_speed_m_s == pytest.approx(0.15, rel=1e-9)
        else:
            assert beat.speed_source == "assumed", beat
    assert "U recorded per beat (fish/swimming)" in out


def test_beats_outside_the_fish_recording_use_the_assumed_speed(store, tmp_path, capsys):
    bag = write_bag(store, tmp_path / "bag", seconds=3.0, fish_odom_m_s=0.12, fish_from_s=1.5)
    status, out, err = run_cli(capsys, bag, "--output-dir", tmp_path / "f")
    assert status == 0, err
    swimming = analysis.analyse(bag, output_dir=tmp_path / "f").swimming
    assert swimming.speed_origin == "partly recorded"
    for beat in swimming.per_beat:
        recorded = beat.start_s >= 1.5
        assert beat.speed_source == ("fish/odom" if recorded else "assumed"), beat
        assert beat.forward_speed_m_s == pytest.approx(0.12 if recorded else 0.3)
    durations = [b.end_s - b.start_s for b in swimming.per_beat]
    mean = np.dot(durations, [b.forward_speed_m_s for b in swimming.per_beat]) / sum(durations)
    assert swimming.parameters.forward_speed_m_s == pytest.approx(mean)
    assert (
        f"recorded for {swimming.recorded_beats} of {len(swimming.per_beat)} beats, 0.3 m/s "
        "assumed (forward_speed_m_s) for the others" in out
    )


def test_default_output_dir_is_named_after_the_input(store, tmp_path, capsys, monkeypatch):
    write_bag(store, tmp_path / "run1", seconds=0.6)
    monkeypatch.chdir(tmp_path)
    status, out, _ = run_cli(capsys, "run1")
    assert status == 0
    assert (tmp_path / "run1_figures" / "theta3.png").is_file()
    shutil.rmtree(tmp_path / "run1_figures")
