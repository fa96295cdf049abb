"""The monitor against a tail/state stream the test writes: gaps, bad samples, the report's frame.

The probe publishes TailState at 200 Hz on a timer, stamped on a grid of its clock that starts in
the past. The swing is a symmetric sine over the carrier angle, two beats a second:
theta3 = 0.45 sin(phi), phi = 4 pi t, which the monitor judges OK (time share 0.5, mean 0, peaks
+/-0.45 rad). Best effort may lose a sample; the assertions hold whatever is lost.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from rclpy.qos import QoSProfile, ReliabilityPolicy, qos_profile_sensor_data

from fishtail_msgs.msg import SymmetryReport, TailState

PERIOD_S = 0.005
SPEED_RAD_S = 4.0 * math.pi  # a beat every 0.5 s
AMPLITUDE_RAD = 0.45
OK, WARN, ERROR, NOT_JUDGED = 0, 1, 2, 3
FIGURES = (
    "positive_peak", "negative_peak", "amplitude", "mean_angle", "positive_time_share",
    "negative_time_share", "period", "frequency",
)  # fmt: skip


def swing(t: float, carrier_rad: float | None = None) -> dict:
    """TailState fields of the symmetric swing at time t (carrier angle SPEED t unless given)."""
    phi = SPEED_RAD_S * t if carrier_rad is None else carrier_rad
    theta3 = AMPLITUDE_RAD * math.sin(SPEED_RAD_S * t)
    return {"motor_angle": phi, "theta3": theta3}


class StateStream:
    """Publishes tail/state on a timer; ``make(k)``: (stamp_ns, fields) of sample k, or None."""

    def __init__(self, ros, make: Callable[[int], tuple | None], frame_id: str) -> None:
        """Create the publisher and the timer."""
        self.make = make
        self.frame_id = frame_id
        self.k = 0
        self.publisher = ros.node.create_publisher(TailState, "tail/state", qos_profile_sensor_data)
        self.timer = ros.node.create_timer(PERIOD_S, self._tick)

    def _tick(self) -> None:
        sample = self.make(self.k)
        self.k += 1
        if sample is None:
            return
        stamp_ns, fields = sample
        message = TailState(mechanism=TailState.MECHANISM_OSCILLATORY)
        message.header.frame_id = self.frame_id
        message.header.stamp.sec, message.header.stamp.nanosec = divmod(stamp_ns, 1_000_000_000)
        message.motor_velocity = SPEED_RAD_S
        for name in ("theta4", "theta4_dot", "theta5", "theta5_dot"):
            setattr(message, name, math.nan)  # as the kinematics node fills mechanism 1
        message.motor_angle = fields["motor_angle"]
        message.theta3 = fields["theta3"]
        # No pivot shift: the fin's body-frame angle is theta3.
        message.pivot_shift = 0.0
        message.swing_bias = 0.0
        message.fin_angle = fields["theta3"]
        message.tip.x = 0.35
        message.tip.y = 0.15 * math.sin(fields["theta3"])
        message.tip_velocity.y = 0.0
        self.publisher.publish(message)


def start_monitor(start_node, ros):
    """Start the monitor; record its reports and /diagnostics once it listens."""
    start_node("monitor")
    reliable = QoSProfile(depth=50, reliability=ReliabilityPolicy.RELIABLE)
    reports = ros.record(SymmetryReport, "tail/symmetry", reliable)
    diagnostics = ros.record_diagnostics()
    ros.wait_for_subscribers("tail/state")
    ros.wait_for_publishers("tail/symmetry")
    return reports, diagnostics


def past_base_ns(ros) -> int:
    """Stamp of sample 0: 5 s before now, so the stream never runs ahead of the monitor's clock."""
    return ros.node.get_clock().now().nanoseconds - 5_000_000_000


def stamp_s(message) -> float:
    """A header stamp in seconds."""
    return message.header.stamp.sec + message.header.stamp.nanosec * 1e-9


def assert_finite(report) -> None:
    """No figure of the report is NaN or infinite."""
    figures = {name: getattr(report, name) for name in FIGURES}
    bad = {name: value for name, value in figures.items() if not math.isfinite(value)}
    assert not bad, f"beat {report.beat_index}: {bad} ({report.message!r})"


def test_a_beat_with_a_gap_is_not_judged(start_node, ros):
    """A 315 ms hole around a peak: that beat is NOT_JUDGED, saying so; no beat gets WARN/ERROR."""
    reports, _ = start_monitor(start_node, ros)
    base_ns = past_base_ns(ros)
    # Beat b runs from t = 0.5 b to 0.5 (b + 1); the hole is around the + peak of beat 4 (at
    # t = 2.125 s): samples 410..471 are not sent, the samples at 2.045 s and 2.360 s are 315 ms
    # apart.
    hole = range(410, 472)
    hole_s = (base_ns * 1e-9 + 409 * PERIOD_S, base_ns * 1e-9 + 472 * PERIOD_S)

    def make(k: int) -> tuple | None:
        if k in hole:
            return None
        return base_ns + k * 5_000_000, swing(k * PERIOD_S)

    StateStream(ros, make, "tail_mechanism")

    def covers_hole(report) -> bool:
        end = stamp_s(report)
        return end - report.period < hole_s[0] and end > hole_s[1]

    ros.spin_until(
        lambda: any(stamp_s(r) > hole_s[1] + 1.0 for r in reports.messages),
        30.0,
        "the beat with the hole and two more",
    )
    with_hole = [r for r in reports.messages if covers_hole(r)]
    assert len(with_hole) == 1, [(r.beat_index, r.message) for r in reports.messages]
    report = with_hole[0]
    assert report.verdict == NOT_JUDGED, report.message
    assert report.message.startswith("not judged"), report.message
    assert "315 ms" in report.message, report.message
    for report in reports.messages:
        assert_finite(report)
        assert report.verdict in (OK, NOT_JUDGED), report.message


def test_report_carries_the_frame_of_its_input(start_node, ros):
    """SymmetryReport.header.frame_id is the frame_id of the tail/state it was computed from."""
    reports, _ = start_monitor(start_node, ros)
    base_ns = past_base_ns(ros)
    StateStream(ros, lambda k: (base_ns + k * 5_000_000, swing(k * PERIOD_S)), "fish/tail")
    ros.wait_for_messages(reports, 2, 30.0, "tail/symmetry")
    assert [r.header.frame_id for r in reports.messages] == ["fish/tail"] * len(reports)


def test_carrier_that_does_not_advance_gives_no_nan(start_node, ros):
    """motor_angle stuck at 0 (shares and mean undefined): NOT_JUDGED, saying why, never NaN.

    NaN theta3 and hour-ahead stamps in between are dropped and counted on the input status.
    """
    reports, diagnostics = start_monitor(start_node, ros)
    base_ns = past_base_ns(ros)

    def make(k: int) -> tuple:
        stamp, fields = base_ns + k * 5_000_000, swing(k * PERIOD_S, carrier_rad=0.0)
        if k % 50 == 7:
            fields["theta3"] = math.nan
        elif k % 50 == 31:
            stamp = ros.node.get_clock().now().nanoseconds + 3_600_000_000_000
        return stamp, fields

    StateStream(ros, make, "tail_mechanism")

    def counted() -> bool:
        return any(
            level == WARN
            and int(ros.values(status).get("dropped_non_finite", "0")) >= 1
            and int(ros.values(status).get("dropped_stamp_in_future", "0")) >= 1
            for _, level, status in ros.statuses(diagnostics, "monitor")
        )

    ros.spin_until(
        lambda: len(reports) >= 2 and counted(), 30.0, "two reports and the drops counted"
    )
    for report in reports.messages:
        assert_finite(report)
        assert report.verdict == NOT_JUDGED, report.message
        assert "carrier angle did not advance" in report.message, report.message


def test_backwards_carrier_is_dropped_not_blamed_on_the_linkage(start_node, ros):
    """tail/state whose carrier angle runs backwards: dropped and counted, no asymmetry report."""
    reports, diagnostics = start_monitor(start_node, ros)
    base_ns = past_base_ns(ros)
    StateStream(
        ros,
        lambda k: (base_ns + k * 5_000_000, swing(k * PERIOD_S, -SPEED_RAD_S * k * PERIOD_S)),
        "tail_mechanism",
    )

    def dropped() -> int:
        return max(
            (
                int(ros.values(status).get("dropped_backwards", "0"))
                for _, level, status in ros.statuses(diagnostics, "monitor")
                if level == WARN and "backwards" in status.message
            ),
            default=0,
        )

    # 400 samples are two seconds of input: four beats of theta3.
    ros.spin_until(lambda: dropped() >= 400, 30.0, "400 backwards samples counted")
    assert not reports.messages, [(r.verdict, r.message) for r in reports.messages]
