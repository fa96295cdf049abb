"""The simulated DC motor turns the tail in water; the kinematics node and the monitor follow it.

The driver runs ``motor_model:=dc`` with ``motor_load:=water_swimming`` (the report's geometry of
config/oscillatory.yaml, the default fish, the Pololu motor's gearbox and encoder); a second driver,
unloaded, runs beside it in a namespace of its own under the same commands. The water's torque is
quadratic in the carrier speed and changes within every revolution, and the board's speed loop
(33 ms frames, integer gains) hardly corrects within a stroke: the carrier speed ripples within a
revolution, the unloaded motor's does not. The monitor integrates each beat over the carrier angle,
so its verdict on the symmetric geometry must stay OK under that ripple.
"""

from __future__ import annotations

import math
import statistics
import sys

from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState

from fishtail_msgs.msg import SymmetryReport

SPEED_RAD_S = 12.0  # a beat every 0.52 s
#: The Pololu 37D 30:1 and its 64-count encoder, as motor_model dc's defaults describe.
DC_MOTOR = {"motor_model": "dc", "gear_ratio": 30.0, "encoder_counts_per_revolution": 64}
UNLOADED = "/unloaded"
#: Beats from the start (the spin-up) left out; then this many judged beats must be OK.
SPIN_UP_BEATS = 2
JUDGED_BEATS = 4
OK, NOT_JUDGED = 0, 3


def revolutions(messages) -> list[list]:
    """The samples of every complete carrier revolution (angle in [2 pi k, 2 pi (k + 1)))."""
    turns: dict[int, list] = {}
    for message in messages:
        turns.setdefault(math.floor(message.position[0] / (2.0 * math.pi)), []).append(message)
    complete = sorted(turns)[1:-1]  # the first and the last are cut by the recording
    return [turns[k] for k in complete]


def steady_revolutions(messages) -> list[list]:
    """Revolutions after the spin-up: once a whole revolution's mean speed is near the command."""
    turns = revolutions(messages)
    for index, turn in enumerate(turns):
        mean = statistics.fmean(m.velocity[0] for m in turn)
        if abs(mean / SPEED_RAD_S - 1.0) < 0.05:
            return turns[index + 1 :]  # one more for the loop to settle
    return []


def peak_to_peak(values) -> float:
    """The largest value minus the smallest."""
    values = list(values)
    return max(values) - min(values)


def test_the_loaded_motor_ripples_and_the_monitor_stays_ok(
    start_node, start_process, ros, config_dir
):
    start_node(
        "driver",
        params_file=config_dir / "oscillatory.yaml",
        params={**DC_MOTOR, "motor_load": "water_swimming", "publish_rate_hz": 200.0},
    )
    unloaded_argv = [sys.executable, "-m", "fishtail_driver.node", "--ros-args",
                     "-r", f"__ns:={UNLOADED}"]  # fmt: skip
    for name, value in {**DC_MOTOR, "publish_rate_hz": 200.0}.items():
        unloaded_argv += ["-p", f"{name}:={value}"]
    start_process("driver-unloaded", unloaded_argv)
    start_node("kinematics", params_file=config_dir / "oscillatory.yaml")
    start_node("monitor")

    loaded = ros.record(JointState, "motor/joint_state")
    unloaded = ros.record(JointState, f"{UNLOADED}/motor/joint_state")
    reliable = QoSProfile(depth=50, reliability=ReliabilityPolicy.RELIABLE)
    reports = ros.record(SymmetryReport, "tail/symmetry", reliable)
    ros.wait_for_publishers("tail/symmetry")
    ros.wait_for_subscribers("tail/state")
    ros.wait_for_subscribers("motor/cmd_speed", 2)  # driver and monitor
    ros.wait_for_subscribers(f"{UNLOADED}/motor/cmd_speed")
    ros.command_speed(SPEED_RAD_S)
    ros.command_speed(SPEED_RAD_S, topic=f"{UNLOADED}/motor/cmd_speed")

    def judged_after_spin_up():
        return [r for r in reports.messages[SPIN_UP_BEATS:] if r.verdict != NOT_JUDGED]

    ros.spin_until(
        lambda: len(judged_after_spin_up()) >= JUDGED_BEATS
        and len(steady_revolutions(loaded.messages)) >= 3
        and len(steady_revolutions(unloaded.messages)) >= 3,
        25.0,
        f"{JUDGED_BEATS} judged beats after the spin-up, 3 steady revolutions of each motor",
    )

    # The carrier speed ripples within every revolution under the load, not without it.
    loaded_turns = steady_revolutions(loaded.messages)
    loaded_ripple = statistics.median(peak_to_peak(m.velocity[0] for m in t) for t in loaded_turns)
    unloaded_ripple = statistics.median(
        peak_to_peak(m.velocity[0] for m in t) for t in steady_revolutions(unloaded.messages)
    )
    summary = f"ripple {loaded_ripple:.3f} rad/s loaded, {unloaded_ripple:.3f} unloaded"
    assert loaded_ripple > 0.1 * SPEED_RAD_S, summary
    assert loaded_ripple > 5.0 * unloaded_ripple + 0.1, summary
    # ... and the loop still holds the commanded speed on average (its dead band: 2 %).
    for turn in loaded_turns:
        elapsed_s = (ros.stamp_ns(turn[-1]) - ros.stamp_ns(turn[0])) * 1e-9
        mean = (turn[-1].position[0] - turn[0].position[0]) / elapsed_s
        assert abs(mean / SPEED_RAD_S - 1.0) < 0.03, f"mean {mean:.3f} rad/s; {summary}"

    # The torque on the carrier: published, and it changes strongly within each revolution.
    for turn in loaded_turns:
        efforts = [m.effort[0] for m in turn]
        assert max(abs(e) for e in efforts) > 0.05, efforts
        assert peak_to_peak(efforts) > 0.5 * max(abs(e) for e in efforts), efforts
    assert all(list(m.effort) == [0.0] for m in unloaded.messages)

    # The monitor's verdict on the symmetric geometry: OK for every judged beat.
    for report in judged_after_spin_up():
        assert report.verdict == OK, (
            f"beat {report.beat_index}: verdict {report.verdict}, +side share "
            f"{report.positive_time_share:.5f}, '{report.message}'; {summary}"
        )
        assert abs(report.positive_time_share - 0.5) < 0.005, report.message
