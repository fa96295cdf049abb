"""Driver + kinematics as separate processes: published pose against the engine, swing range.

Each tail/state (and tail/joint_states, tail/tip) sample is stamped with the stamp of the
motor/joint_state sample it was computed from, so the test matches them by stamp and recomputes
the expected pose from the published carrier angle and speed with the engine itself.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from geometry_msgs.msg import PointStamped
from sensor_msgs.msg import JointState

from fishtail_common.parameter_files import load_parameter_file
from fishtail_kinematics.engine.mechanisms import UndulatoryTail, make_tail
from fishtail_kinematics.engine.parameters import geometry_from_parameters, geometry_parameters_in
from fishtail_msgs.msg import TailState

#: Same code, same float inputs: the results should be bit-identical; 1e-12 leaves room for a
#: different but equivalent evaluation order.
TOLERANCE = 1e-12
REPORT_SWING_DEG = 53.13  # the report's figure, rounded to 0.01 deg
STREAM_TIMEOUT_S = 20.0


def engine_for(config_path):
    """The engine for a parameter file, as the kinematics node builds it."""
    values = geometry_parameters_in(load_parameter_file(config_path))
    return make_tail(geometry_from_parameters(values))


class Matched:
    """motor/joint_state and the tail topics, joined on the header stamp."""

    def __init__(self, ros) -> None:
        """Subscribe to the four topics."""
        self.ros = ros
        self.motor = ros.record(JointState, "motor/joint_state")
        self.state = ros.record(TailState, "tail/state")
        self.joints = ros.record(JointState, "tail/joint_states")
        self.tip = ros.record(PointStamped, "tail/tip")

    def join(self) -> list[tuple]:
        """(motor sample, tail/state, tail/joint_states, tail/tip) with equal stamps, in order."""
        stamp = self.ros.stamp_ns
        state = {stamp(m): m for m in self.state.messages}
        joints = {stamp(m): m for m in self.joints.messages}
        tip = {stamp(m): m for m in self.tip.messages}
        rows = []
        for motor in self.motor.messages:
            key = stamp(motor)
            if key in state and key in joints and key in tip:
                rows.append((motor, state[key], joints[key], tip[key]))
        return rows

    def wait_for_revolution(
        self, revolutions: float, minimum: int, also=lambda rows: True, what: str = ""
    ) -> list:
        """Spin until the joined samples span ``revolutions`` carrier turns and ``minimum`` rows.

        ``also(rows)`` is a further condition on the joined rows, described by ``what``.
        """
        rows: list = []

        def enough() -> bool:
            nonlocal rows
            rows = self.join()
            if len(rows) < minimum:
                return False
            span = rows[-1][0].position[0] - rows[0][0].position[0]
            return span >= revolutions * 2.0 * math.pi and also(rows)

        self.ros.spin_until(
            enough,
            STREAM_TIMEOUT_S,
            f"{minimum} matched samples over {revolutions} carrier revolution(s) "
            f"{what} (so far {len(self.motor)} motor/joint_state, {len(self.state)} tail/state)",
        )
        return rows


def start_suite(start_node, ros, config_path, speed: float) -> Matched:
    """Start driver and kinematics, wait for the topics to connect and command ``speed``."""
    start_node("driver", params={"publish_rate_hz": 200.0})
    start_node("kinematics", params_file=config_path)
    matched = Matched(ros)
    ros.wait_for_publishers("tail/state")
    ros.wait_for_subscribers("motor/joint_state", 2)  # kinematics and the probe
    ros.command_speed(speed)
    return matched


def assert_matches_engine(rows: list, tail) -> int:
    """Every joined sample's pose equals the engine's for its carrier angle and speed."""
    undulatory = isinstance(tail, UndulatoryTail)
    names = ["theta1", "theta2", "theta3", *(["theta4", "theta5"] if undulatory else [])]
    worst = 0.0
    for motor, state, joints, tip in rows:
        angle, velocity = motor.position[0], motor.velocity[0]
        expected = tail.solve(float(angle), float(velocity))
        assert state.mechanism == (
            TailState.MECHANISM_UNDULATORY if undulatory else TailState.MECHANISM_OSCILLATORY
        )
        assert state.motor_angle == angle and state.motor_velocity == velocity
        assert list(joints.name) == names
        published = {
            "tail/state theta3": (state.theta3, expected.theta3),
            "tail/state theta3_dot": (state.theta3_dot, expected.theta3_dot),
            "tail/state tip.x": (state.tip.x, expected.tip_x),
            "tail/state tip.y": (state.tip.y, expected.tip_y),
            "tail/joint_states theta3": (joints.position[2], expected.theta3),
            "tail/tip x": (tip.point.x, expected.tip_x),
            "tail/tip y": (tip.point.y, expected.tip_y),
        }
        if undulatory:
            published["tail/state theta5"] = (state.theta5, expected.theta5)
            published["tail/joint_states theta5"] = (joints.position[4], expected.theta5)
        for field, (got, want) in published.items():
            error = abs(got - want)
            worst = max(worst, error)
            assert error <= TOLERANCE, (
                f"{field} = {got!r} but the engine gives {want!r} for carrier angle {angle!r} "
                f"rad at {velocity!r} rad/s (difference {error:.3g})"
            )
    return worst


@pytest.mark.parametrize("config", ["oscillatory.yaml", "undulatory.yaml"])
def test_published_pose_equals_engine(start_node, ros, config_dir, config):
    """θ3 and the tip on all three tail topics equal the engine's for the published angle."""
    config_path = config_dir / config
    tail = engine_for(config_path)
    matched = start_suite(start_node, ros, config_path, speed=8.0)
    rows = matched.wait_for_revolution(revolutions=1.0, minimum=150)
    assert_matches_engine(rows, tail)
    theta3 = [state.theta3 for _, state, _, _ in rows]
    # Not a frozen or constant output: the samples cover the swing.
    drive = tail.drive if isinstance(tail, UndulatoryTail) else tail
    assert max(theta3) - min(theta3) > 0.9 * drive.swing_range_rad


def test_swing_range_over_a_beat_is_the_reports(start_node, ros, config_dir):
    """tail/joint_states θ3 max - min over more than one beat at 4 rad/s is 53.13°.

    Sampling can only shrink the range. Near an extreme, θ3 ≈ θ* - c (φ - φ*)² / 2 with
    c ≤ max |d²θ3/dφ²| (0.42 rad/rad², from the engine), so a received sample at carrier angle
    distance d (mod 2π) from the extreme's angle φ* misses it by at most c d² / 2. The test waits
    (over more than one beat) until each extreme has a received sample within D_MAX = 0.015 rad
    (samples are 0.02 rad apart at 200 Hz and 4 rad/s, so normally within 0.01 rad) and allows
    c (d_max² + d_min²) / 2 (at most 0.0055°, typically under 0.001°) plus 0.005° for the
    report's rounding to 0.01°.
    """
    config_path = config_dir / "oscillatory.yaml"
    tail = engine_for(config_path)
    phi = np.linspace(0.0, 2.0 * math.pi, 200_001)
    theta3 = tail.solve(phi, np.zeros_like(phi)).theta3
    curvature = float(np.max(np.abs(np.gradient(np.gradient(theta3, phi), phi))))
    extreme_angles = (float(phi[np.argmax(theta3)]), float(phi[np.argmin(theta3)]))
    d_max = 0.015

    def distances(rows) -> list[float]:
        """Carrier-angle distance from each extreme to its nearest received sample."""
        angles = np.array([motor.position[0] for motor, *_ in rows])
        return [
            float(np.min(np.abs(np.remainder(angles - extreme + math.pi, 2 * math.pi) - math.pi)))
            for extreme in extreme_angles
        ]

    matched = start_suite(start_node, ros, config_path, speed=4.0)
    rows = matched.wait_for_revolution(
        revolutions=1.1,
        minimum=100,
        also=lambda rows: max(distances(rows)) <= d_max,
        what=f"a sample within {d_max} rad of both extremes",
    )
    theta3_published = np.array([joints.position[2] for _, _, joints, _ in rows])
    sampling_bound_deg = math.degrees(0.5 * curvature * sum(d * d for d in distances(rows)))

    measured_deg = math.degrees(float(theta3_published.max() - theta3_published.min()))
    exact_deg = math.degrees(tail.swing_range_rad)
    assert measured_deg <= exact_deg + 1e-9, "sampled range exceeds the engine's exact range"
    assert abs(measured_deg - REPORT_SWING_DEG) <= 0.005 + sampling_bound_deg, (
        f"swing range {measured_deg:.4f} deg over {len(rows)} samples, report {REPORT_SWING_DEG}"
        f" deg, allowed {0.005 + sampling_bound_deg:.4f} deg"
    )
