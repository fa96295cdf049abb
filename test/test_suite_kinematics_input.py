"""The kinematics node's input checks, its data-loss warning and its geometry-change log.

The probe publishes ``motor/joint_state`` itself, so the test decides every sample: stamps on a
grid of the probe's clock, starting in the past (never ahead of the node's clock unless a sample
is meant to be), the carrier angle advancing at a constant speed. Best effort may lose a sample;
the assertions hold whatever is lost (they count "at least" and check what was published).
"""

from __future__ import annotations

import math
from collections.abc import Callable

from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rcl_interfaces.srv import SetParameters
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import JointState

from fishtail_common.parameter_files import load_parameter_file
from fishtail_kinematics.engine.parameters import geometry_parameters_in
from fishtail_msgs.msg import TailState

SPEED_RAD_S = 4.0
WARN = 1
#: Reasons the node names in its diagnostics (values ``dropped_<reason>``).
REASONS = (
    "non_finite",
    "angle_out_of_range",
    "backwards",
    "stamp_not_increasing",
    "stamp_in_future",
)


class MotorStream:
    """Publishes motor/joint_state samples on a timer; ``make(k)`` gives sample k or None (skip).

    ``make`` returns (stamp_ns, angle, velocity); the published messages are kept in ``sent``.
    """

    def __init__(self, ros, period_s: float, make: Callable[[int], tuple | None]) -> None:
        """Create the publisher and the timer."""
        self.make = make
        self.k = 0
        self.sent: list[tuple[int, float]] = []
        self.publisher = ros.node.create_publisher(
            JointState, "motor/joint_state", qos_profile_sensor_data
        )
        self.timer = ros.node.create_timer(period_s, self._tick)

    def _tick(self) -> None:
        sample = self.make(self.k)
        self.k += 1
        if sample is None:
            return
        stamp_ns, angle, velocity = sample
        message = JointState(name=["carrier_joint"], position=[angle], velocity=[velocity])
        message.header.stamp.sec, message.header.stamp.nanosec = divmod(stamp_ns, 1_000_000_000)
        self.publisher.publish(message)
        self.sent.append((stamp_ns, angle))


def kinematics_statuses(ros, diagnostics) -> list[tuple[int, object]]:
    """(level, status) of the kinematics node's statuses, in arrival order."""
    return [(level, status) for _, level, status in ros.statuses(diagnostics, "kinematics")]


def test_implausible_samples_are_dropped_and_counted(start_node, ros, config_dir):
    """NaN, 1e12 rad, backwards, repeated and future stamps never reach tail/state; WARN names them.

    Every tenth sample is bad, the five kinds in turn; the good ones advance at 4 rad/s.
    """
    start_node("kinematics", params_file=config_dir / "oscillatory.yaml")
    states = ros.record(TailState, "tail/state")
    diagnostics = ros.record_diagnostics()
    ros.wait_for_subscribers("motor/joint_state")
    ros.wait_for_publishers("tail/state")
    period_s = 0.01
    base_ns = ros.node.get_clock().now().nanoseconds - 5_000_000_000
    bad_stamps: set[int] = set()

    def make(k: int) -> tuple:
        stamp = base_ns + k * 10_000_000
        angle = SPEED_RAD_S * k * period_s
        if k % 10 != 5:
            return stamp, angle, SPEED_RAD_S
        kind = REASONS[(k // 10) % len(REASONS)]
        if kind == "non_finite":
            angle = math.nan
        elif kind == "angle_out_of_range":
            angle = 1e12
        elif kind == "backwards":
            angle -= 1.0
        elif kind == "stamp_not_increasing":
            stamp -= 10_000_000  # the previous (good) sample's stamp
        else:
            stamp = ros.node.get_clock().now().nanoseconds + 3_600_000_000_000
        if kind != "stamp_not_increasing":
            bad_stamps.add(stamp)
        return stamp, angle, SPEED_RAD_S

    stream = MotorStream(ros, period_s, make)

    def warned_about_all() -> bool:
        for level, status in kinematics_statuses(ros, diagnostics):
            values = ros.values(status)
            if level == WARN and all(
                int(values.get(f"dropped_{reason}", "0")) >= 2 and reason in status.message
                for reason in REASONS
            ):
                return True
        return False

    ros.spin_until(warned_about_all, 30.0, "a kinematics WARN counting every kind of bad sample")
    assert stream.sent
    stamps = [ros.stamp_ns(m) for m in states.messages]
    assert len(stamps) == len(set(stamps)), "a repeated stamp was passed on"
    assert not bad_stamps & set(stamps), "a bad sample was passed on"
    angles = [m.motor_angle for m in states.messages]
    assert all(math.isfinite(a) and abs(a) < 1e9 for a in angles)
    assert angles == sorted(angles), "the carrier angle went backwards"
    assert all(math.isfinite(m.theta3) for m in states.messages)


def test_gaps_in_the_input_are_a_warning(start_node, ros, config_dir):
    """Samples lost in runs of 65 ms at 200 Hz: kinematics and monitor WARN, with rate and gap.

    Twelve of every hundred samples are not published: 88 % of the rate, a 65 ms gap every
    half second; the monitor sees the same gaps in tail/state.
    """
    start_node("kinematics", params_file=config_dir / "oscillatory.yaml")
    start_node("monitor")
    diagnostics = ros.record_diagnostics()
    ros.wait_for_subscribers("motor/joint_state")
    ros.wait_for_subscribers("tail/state")
    period_s = 0.005
    base_ns = ros.node.get_clock().now().nanoseconds - 5_000_000_000

    def make(k: int) -> tuple | None:
        if 50 <= k % 100 < 62:
            return None
        return base_ns + k * 5_000_000, SPEED_RAD_S * k * period_s, SPEED_RAD_S

    MotorStream(ros, period_s, make)

    def gap_warning(node: str) -> tuple | None:
        for _, level, status in ros.statuses(diagnostics, node):
            values = ros.values(status)
            if level == WARN and float(values.get("longest_gap_ms", "0")) >= 60.0:
                return status, values
        return None

    ros.spin_until(
        lambda: gap_warning("kinematics") and gap_warning("monitor"),
        30.0,
        "a WARN about the gaps from the kinematics node and the monitor",
    )
    for node in ("kinematics", "monitor"):
        status, values = gap_warning(node)
        assert "gap" in status.message, status.message
        # Measured over the stamps of what arrived in one diagnostics period. The period is
        # wall-clock time, not aligned with the 0.5 s loss pattern, and a busy test process
        # publishes unevenly, so a period's stamps may hold one gap in just under a second:
        # (198 - 12) / 0.99 s = 188 Hz at most, below the 200 Hz of an intact stream.
        assert 0.0 < float(values["input_rate_hz"]) <= 200.0 * 0.95, values
        assert math.isclose(float(values["sample_interval_ms"]), 5.0, abs_tol=0.5), values
        assert float(values["longest_gap_ms"]) >= 60.0, values


def parameter(name: str, value: object) -> Parameter:
    """An rcl_interfaces Parameter of type double or string."""
    if isinstance(value, str):
        content = ParameterValue(type=ParameterType.PARAMETER_STRING, string_value=value)
    else:
        content = ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=float(value))
    return Parameter(name=name, value=content)


def test_geometry_change_is_logged_only_when_something_changed(start_node, ros, config_dir):
    """Setting the loaded geometry again logs nothing; a real change logs only what changed."""
    config_path = config_dir / "oscillatory.yaml"
    values = geometry_parameters_in(load_parameter_file(config_path))
    process = start_node("kinematics", params_file=config_path)

    def set_parameters(changes: dict) -> None:
        request = SetParameters.Request(
            parameters=[parameter(name, value) for name, value in changes.items()]
        )
        results = ros.call(SetParameters, "/kinematics/set_parameters", request).results
        assert all(result.successful for result in results), results

    set_parameters(values)  # what `ros2 param load` of the same file does
    set_parameters({**values, "phase_rad": 0.3})
    ros.spin_until(
        lambda: "geometry changed" in process.stderr(), 15.0, "the log of the geometry change"
    )
    lines = [line for line in process.stderr().splitlines() if "geometry changed" in line]
    assert len(lines) == 1, lines
    assert "phase_rad" in lines[0] and "0.3" in lines[0], lines
    assert not any(name in lines[0] for name in values if name != "phase_rad"), lines


def test_an_empty_motor_joint_name_is_refused(start_node, ros, config_dir):
    """``motor_joint_name:=''`` at run time is refused with the reason; the node keeps following."""
    start_node("kinematics", params_file=config_dir / "oscillatory.yaml")
    request = SetParameters.Request(parameters=[parameter("motor_joint_name", "")])
    (result,) = ros.call(SetParameters, "/kinematics/set_parameters", request).results
    assert not result.successful
    assert result.reason == "motor_joint_name must not be empty"
    request = SetParameters.Request(parameters=[parameter("motor_joint_name", "wheel")])
    (result,) = ros.call(SetParameters, "/kinematics/set_parameters", request).results
    assert result.successful, result.reason
