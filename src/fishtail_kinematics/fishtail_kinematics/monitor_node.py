"""Monitor node: is the tail's swing symmetric?

Topics (relative names):
  sub ``tail/state``       fishtail_msgs/TailState (theta3, the tip's lateral position and
                           velocity, theta5 for mechanism 2, the stamp), sensor-data QoS
  sub ``motor/cmd_speed``  std_msgs/Float64, to know whether beats are expected
  pub ``tail/symmetry``    fishtail_msgs/SymmetryReport, one per completed beat (reliable)
  pub ``/diagnostics``     diagnostic_msgs/DiagnosticArray: OK / WARN / ERROR from the latest
                           beat against the tolerances, STALE when tail/state stops, ERROR when
                           the motor is commanded but no beat completes; also the swimming
                           figures of the latest beat (tip excursion, Strouhal number, Lighthill
                           mean thrust) for the parameters forward_speed_m_s, fin_span_m and
                           water_density_kg_m3 (docs/swimming.md)

The statistics are :mod:`fishtail_kinematics.symmetry` and :mod:`fishtail_kinematics.swimming`,
the same code the offline analysis uses.
"""

from __future__ import annotations

import math
import sys

from diagnostic_msgs.msg import DiagnosticArray
from rcl_interfaces.msg import SetParametersResult
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, qos_profile_sensor_data
from std_msgs.msg import Float64

from fishtail_kinematics.ros_common import (
    LEVEL_STALE,
    diagnostic_array,
    float_descriptor,
    run_node,
)
from fishtail_kinematics.swimming import (
    SWIMMING_PARAMETERS,
    SwimmingParameters,
    TipKinematics,
    TipSampleBuffer,
    figures_from_kinematics,
)
from fishtail_kinematics.symmetry import (
    BeatStatistics,
    BeatTracker,
    SymmetryTolerances,
    Verdict,
    judge,
)
from fishtail_msgs.msg import SymmetryReport, TailState

_TOLERANCE_NAMES = tuple(f.name for f in SymmetryTolerances.__dataclass_fields__.values())
# Speeds below this are "not commanded" (a beat would take longer than ~2 minutes).
_MIN_COMMANDED_SPEED_RAD_S = 0.05
_SWIMMING_PARAMETERS = SWIMMING_PARAMETERS


class MonitorNode(Node):
    """Thin shell around :class:`BeatTracker` and :func:`judge`."""

    def __init__(self) -> None:
        """Declare parameters and wire topics."""
        super().__init__("monitor")
        defaults = SymmetryTolerances()
        for name in _TOLERANCE_NAMES:
            unit = "rad" if name.endswith("_rad") else "share of the beat, |share - 0.5|"
            level = "WARN" if "warn" in name else "ERROR"
            self.declare_parameter(
                name,
                getattr(defaults, name),
                float_descriptor(f"{level} above this [{unit}]", 0.0, 1.0),
            )
        self.declare_parameter(
            "hysteresis_rad", 0.01,
            float_descriptor("theta3 must go below -hysteresis before an upward zero crossing "
                             "counts as a new beat [rad]", 0.0, 0.5),
        )  # fmt: skip
        self.declare_parameter(
            "stale_timeout_sec", 2.0,
            float_descriptor("STALE after this long without tail/state [s]", 0.1, 600.0),
        )  # fmt: skip
        self.declare_parameter(
            "beat_timeout_sec", 5.0,
            float_descriptor("ERROR when commanded but no beat for max(this, 2 expected periods)"
                             " [s]", 0.5, 3600.0),
        )  # fmt: skip
        self.declare_parameter(
            "gap_reset_sec", 0.5,
            float_descriptor("a gap in tail/state longer than this restarts the beat [s]",
                             0.01, 60.0),
        )  # fmt: skip
        for name, (default, text, low, high) in _SWIMMING_PARAMETERS.items():
            self.declare_parameter(name, default, float_descriptor(text, low, high))
        self.tolerances = self._tolerances_from({})
        self.swimming_parameters = self._swimming_parameters_from({})
        self.tip_samples = TipSampleBuffer()
        self.last_tip_kinematics: TipKinematics | None = None
        self.tracker = BeatTracker(self.get_parameter("hysteresis_rad").value)
        # Read on every tail/state message (1 kHz), so kept here rather than looked up each time.
        self.gap_reset_sec = self.get_parameter("gap_reset_sec").value
        self.last_beat: BeatStatistics | None = None
        self.last_verdict: tuple[Verdict, str] | None = None
        self.last_sample_time_s: float | None = None
        self.last_input_ns: int | None = None
        self.last_progress_ns = self.get_clock().now().nanoseconds
        self.commanded_speed = 0.0
        self.last_command_ns: int | None = None
        self.report = SymmetryReport()

        # Transient local: a subscriber that joins late still gets the latest verdict.
        self.report_publisher = self.create_publisher(
            SymmetryReport,
            "tail/symmetry",
            QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL),
        )
        self.diagnostics_publisher = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self.create_subscription(TailState, "tail/state", self._on_state, qos_profile_sensor_data)
        self.create_subscription(Float64, "motor/cmd_speed", self._on_command, 10)
        self.create_timer(1.0, self._on_diagnostics)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.get_logger().info("monitor up")

    def _tolerances_from(self, changed: dict) -> SymmetryTolerances:
        values = {
            name: changed.get(name, self.get_parameter(name).value) for name in _TOLERANCE_NAMES
        }
        return SymmetryTolerances(**values)

    def _swimming_parameters_from(self, changed: dict) -> SwimmingParameters:
        return SwimmingParameters(
            **{name: changed.get(name, self.get_parameter(name).value) for name in
               _SWIMMING_PARAMETERS}
        )  # fmt: skip

    def _on_set_parameters(self, parameters) -> SetParametersResult:
        changed = {p.name: p.value for p in parameters}
        try:
            tolerances = self._tolerances_from(changed)
            swimming = self._swimming_parameters_from(changed)
        except ValueError as error:
            return SetParametersResult(successful=False, reason=str(error))
        self.tolerances = tolerances
        self.swimming_parameters = swimming
        if "hysteresis_rad" in changed:
            # Takes effect at the next arming; the beat count and the beat in progress stay.
            self.tracker.hysteresis_rad = changed["hysteresis_rad"]
        self.gap_reset_sec = changed.get("gap_reset_sec", self.gap_reset_sec)
        return SetParametersResult(successful=True)

    def _on_command(self, message: Float64) -> None:
        now_ns = self.get_clock().now().nanoseconds
        was_commanded = self._commanded(now_ns)
        self.commanded_speed = message.data if math.isfinite(message.data) else 0.0
        self.last_command_ns = now_ns
        if not was_commanded:
            self.last_progress_ns = now_ns

    def _commanded(self, now_ns: int) -> bool:
        # A command older than the stale timeout no longer counts: the driver's watchdog has
        # stopped the motor by then.
        if self.last_command_ns is None:
            return False
        age_s = (now_ns - self.last_command_ns) * 1e-9
        return age_s < self.get_parameter("stale_timeout_sec").value and (
            self.commanded_speed > _MIN_COMMANDED_SPEED_RAD_S
        )

    def _on_state(self, message: TailState) -> None:
        self.last_input_ns = self.get_clock().now().nanoseconds
        stamp = message.header.stamp
        time_s = stamp.sec + stamp.nanosec * 1e-9
        if (
            self.last_sample_time_s is not None
            and time_s - self.last_sample_time_s > self.gap_reset_sec
        ):
            self.tracker.reset()
            self.tip_samples.reset()
        self.last_sample_time_s = time_s
        fin_angle = (
            message.theta5
            if message.mechanism == TailState.MECHANISM_UNDULATORY
            else message.theta3
        )
        self.tip_samples.add(time_s, message.tip.y, message.tip_velocity.y, fin_angle)
        beat = self.tracker.add(time_s, message.theta3, message.motor_angle)
        if beat is not None:
            self.last_tip_kinematics = self.tip_samples.complete(beat)
            self._publish_beat(beat, stamp)

    def _publish_beat(self, beat: BeatStatistics, stamp) -> None:
        verdict, text = judge(beat, self.tolerances)
        self.last_beat = beat
        self.last_verdict = (verdict, text)
        self.last_progress_ns = self.get_clock().now().nanoseconds
        report = self.report
        report.header.stamp = stamp
        report.beat_index = beat.index
        report.positive_peak = beat.positive_peak_rad
        report.negative_peak = beat.negative_peak_rad
        report.amplitude = beat.amplitude_rad
        report.mean_angle = beat.mean_angle_rad
        report.positive_time_share = beat.positive_time_share
        report.negative_time_share = beat.negative_time_share
        report.period = beat.period_s
        report.frequency = beat.frequency_hz
        report.verdict = int(verdict)
        report.message = text
        self.report_publisher.publish(report)
        if verdict != Verdict.OK:
            self.get_logger().warning(f"beat {beat.index}: {text}", throttle_duration_sec=5.0)

    def _on_diagnostics(self) -> None:
        now_ns = self.get_clock().now().nanoseconds
        values = {"beats": str(self.tracker.beats_completed)}
        stale_after = self.get_parameter("stale_timeout_sec").value
        commanded = self._commanded(now_ns)
        if self.last_input_ns is None or (now_ns - self.last_input_ns) * 1e-9 > stale_after:
            level, text = LEVEL_STALE, "no tail/state received recently"
        elif commanded and self._beat_overdue(now_ns):
            waited = (now_ns - self.last_progress_ns) * 1e-9
            level, text = (
                int(Verdict.ERROR),
                f"motor commanded at {self.commanded_speed:.3g} rad/s but no tail beat completed "
                f"in {waited:.1f} s",
            )
        elif self.last_verdict is None:
            level, text = int(Verdict.OK), "waiting for the first complete beat"
        else:
            level, text = int(self.last_verdict[0]), self.last_verdict[1]
        if self.last_beat is not None:
            beat = self.last_beat
            values.update(
                amplitude_deg=f"{math.degrees(beat.amplitude_rad):.3f}",
                mean_angle_deg=f"{math.degrees(beat.mean_angle_rad):.4f}",
                positive_time_share=f"{beat.positive_time_share:.5f}",
                frequency_hz=f"{beat.frequency_hz:.4f}",
            )
        if self.last_tip_kinematics is not None:
            swimming = figures_from_kinematics(self.last_tip_kinematics, self.swimming_parameters)
            values.update(
                tip_excursion_m=f"{swimming.tip_excursion_m:.5f}",
                strouhal_number=f"{swimming.strouhal_number:.4f}",
                lighthill_mean_thrust_n=f"{swimming.mean_thrust_n:.5g}",
                assumed_forward_speed_m_s=f"{self.swimming_parameters.forward_speed_m_s:g}",
            )
        self.diagnostics_publisher.publish(
            diagnostic_array(self, "tail swing symmetry", level, text, values)
        )

    def _beat_overdue(self, now_ns: int) -> bool:
        expected_period_s = 2.0 * math.pi / self.commanded_speed
        allowed_s = max(self.get_parameter("beat_timeout_sec").value, 2.0 * expected_period_s)
        return (now_ns - self.last_progress_ns) * 1e-9 > allowed_s


def main() -> int:
    """Entry point of ``ros2 run fishtail_kinematics monitor``."""
    return run_node(MonitorNode, "monitor", (ValueError,))


if __name__ == "__main__":
    sys.exit(main())
