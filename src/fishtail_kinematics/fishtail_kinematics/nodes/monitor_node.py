"""Monitor node: is the tail's swing symmetric?

Judges every beat of ``tail/state`` with :mod:`fishtail_kinematics.engine.symmetry` (publishing
``tail/symmetry``) and gives its swimming figures with :mod:`fishtail_kinematics.engine.swimming`,
the same code the offline analysis uses, taking U from the swimming simulator's
``fish/swimming`` while it is fresh. Its input is checked like the kinematics node's. Topics and
parameters: README.md; verdicts and input rules: docs/kinematics.md; the figures and U:
docs/swimming.md.
"""

from __future__ import annotations

import dataclasses
import math
import sys
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
from rcl_interfaces.msg import SetParametersResult
from rclpy.parameter import Parameter
from std_msgs.msg import Float64

from fishtail_common.interface import (
    DIAGNOSTICS,
    FISH_SWIMMING,
    MECHANISM_CODES,
    MOTOR_CMD_SPEED,
    TAIL_STATE,
    TAIL_SYMMETRY,
    Level,
    Status,
)
from fishtail_common.parameters import ParameterSpec, ParameterValue
from fishtail_common.ros import (
    NodeFactory,
    SuiteNodeBase,
    declare,
    diagnostic_array,
    run_node,
    subscriber_qos,
    suite_publisher,
)
from fishtail_common.stream_timing import PersistentStatus, StreamTiming
from fishtail_kinematics.engine.input_guard import (
    GUARD_PARAMETERS,
    GUARD_REASONS,
    REASON_TEXT,
    STALE_TIMEOUT,
    CarrierGuard,
    DropCounts,
    input_status,
)
from fishtail_kinematics.engine.mechanisms import TAIL_TYPES
from fishtail_kinematics.engine.swimming import (
    SWIMMING_PARAMETERS,
    SwimmingParameters,
    TipKinematics,
    TipSampleBuffer,
    choose_forward_speed,
    figures_from_kinematics,
)
from fishtail_kinematics.engine.symmetry import (
    GAP_RESET,
    HYSTERESIS,
    SYMMETRY_PARAMETERS,
    TOLERANCE_PARAMETERS,
    BeatStatistics,
    BeatTracker,
    SymmetryTolerances,
    Verdict,
    judge,
)
from fishtail_msgs.msg import SwimFigures, SymmetryReport, TailState

# Speeds below this are "not commanded" (a beat would take longer than ~2 minutes).
_MIN_COMMANDED_SPEED_RAD_S = 0.05
INPUT_TOPIC = TAIL_STATE.name
DIAGNOSTICS_PERIOD_S = 1.0
BEAT_TIMEOUT = ParameterSpec(
    "beat_timeout_sec",
    5.0,
    "ERROR when commanded but no beat for max(this, 2 expected periods)",
    "s",
    0.5,
    3600.0,
)
#: Every parameter of the node.
PARAMETERS: tuple[ParameterSpec, ...] = (
    *SYMMETRY_PARAMETERS,
    STALE_TIMEOUT,
    BEAT_TIMEOUT,
    *GUARD_PARAMETERS,
    *SWIMMING_PARAMETERS,
)
#: The TailState field of the last link's angle, by TailState mechanism code.
_FIN_ANGLE_FIELD = {
    MECHANISM_CODES[name]: tail.fin_angle_field() for name, tail in TAIL_TYPES.items()
}


def _finite(value: float) -> float:
    # An undefined figure (only in a NOT_JUDGED beat, whose message names it) is published as 0:
    # a NaN in a report breaks consumers that compare or plot it.
    return value if math.isfinite(value) else 0.0


class MonitorNode(SuiteNodeBase):
    """Thin shell around :class:`BeatTracker` and :func:`judge`."""

    def __init__(self, **node_options: Any) -> None:
        """Declare parameters and wire topics."""
        super().__init__("monitor", **node_options)
        values = declare(self, PARAMETERS)
        self.tolerances = self._tolerances_from({})
        self.swimming_parameters = self._swimming_parameters_from({})
        self.tip_samples = TipSampleBuffer()
        self.last_tip_kinematics: TipKinematics | None = None
        self.tracker = BeatTracker(float(values[HYSTERESIS.name]))
        # Read on every tail/state message (1 kHz), so kept here rather than looked up each time.
        self.gap_reset_sec = float(values[GAP_RESET.name])
        self.guard = CarrierGuard()
        self.guard.apply_parameters(values)
        self.drops = DropCounts(GUARD_REASONS)
        self._drop_log = {
            reason: f"{INPUT_TOPIC} sample dropped: {text}" for reason, text in REASON_TEXT.items()
        }
        self.timing = StreamTiming()
        # Gaps and rate WARN once they persist, OK once cleared (no flapping).
        self.timing_status = PersistentStatus()
        self.frame_id = ""
        self.last_beat: BeatStatistics | None = None
        self.last_beat_reason = ""  # why the latest beat was not judged, if it was not
        self.beats_not_judged = 0
        self.last_verdict: tuple[Verdict, str, int] | None = None  # latest judged beat
        self.last_judged_beat: BeatStatistics | None = None
        self.last_sample_time_s: float | None = None
        self.last_input_ns: int | None = None
        self.last_progress_ns = self.get_clock().now().nanoseconds
        self.commanded_speed = 0.0
        self.last_command_ns: int | None = None
        self.report = SymmetryReport()
        # The simulator's latest speed and since when it holds (node clock); the speed, its age
        # and the age allowed when the latest beat completed, for choose_forward_speed.
        self.simulated_speed_m_s = math.nan
        self.simulated_speed_since_ns: int | None = None
        self.beat_simulated_speed_m_s = math.nan
        self.beat_simulated_speed_age_s = math.inf
        self.beat_simulated_speed_max_age_s = 0.0

        # Transient local: a subscriber that joins late still gets the latest verdict.
        self.report_publisher = suite_publisher(self, SymmetryReport, TAIL_SYMMETRY)
        self.diagnostics_publisher = suite_publisher(self, DiagnosticArray, DIAGNOSTICS)
        self.create_subscription(TailState, INPUT_TOPIC, self._on_state, subscriber_qos(TAIL_STATE))
        self.create_subscription(
            Float64, MOTOR_CMD_SPEED.name, self._on_command, subscriber_qos(MOTOR_CMD_SPEED)
        )
        self.create_subscription(
            SwimFigures, FISH_SWIMMING.name, self._on_swimming, subscriber_qos(FISH_SWIMMING)
        )
        self.create_timer(DIAGNOSTICS_PERIOD_S, self._on_diagnostics)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.get_logger().info("monitor up")

    def _current(
        self, specs: tuple[ParameterSpec, ...], changed: dict[str, ParameterValue]
    ) -> dict[str, ParameterValue]:
        """The values of ``specs``: as ``changed`` sets them, else as they are."""
        return {
            spec.name: changed.get(spec.name, self.get_parameter(spec.name).value) for spec in specs
        }

    def _tolerances_from(self, changed: dict[str, ParameterValue]) -> SymmetryTolerances:
        values = self._current(TOLERANCE_PARAMETERS, changed)
        return SymmetryTolerances(**{name: float(value) for name, value in values.items()})

    def _swimming_parameters_from(self, changed: dict[str, ParameterValue]) -> SwimmingParameters:
        return SwimmingParameters.from_values(self._current(SWIMMING_PARAMETERS, changed))

    def _on_set_parameters(self, parameters: list[Parameter]) -> SetParametersResult:
        changed = {p.name: p.value for p in parameters}
        try:
            tolerances = self._tolerances_from(changed)
            swimming = self._swimming_parameters_from(changed)
        except ValueError as error:
            return SetParametersResult(successful=False, reason=str(error))
        self.tolerances = tolerances
        self.swimming_parameters = swimming
        if HYSTERESIS.name in changed:
            # Takes effect at the next arming; the beat count and the beat in progress stay.
            self.tracker.hysteresis_rad = changed[HYSTERESIS.name]
        self.gap_reset_sec = changed.get(GAP_RESET.name, self.gap_reset_sec)
        self.guard.apply_parameters(changed)
        return SetParametersResult(successful=True)

    def _on_command(self, message: Float64) -> None:
        now_ns = self.get_clock().now().nanoseconds
        was_commanded = self._commanded(now_ns)
        self.commanded_speed = message.data if math.isfinite(message.data) else 0.0
        self.last_command_ns = now_ns
        if not was_commanded:
            self.last_progress_ns = now_ns

    def _on_swimming(self, message: SwimFigures) -> None:
        now_ns = self.get_clock().now().nanoseconds
        stamp = message.header.stamp
        self.simulated_speed_m_s = message.mean_speed_m_s
        # The older of stamp and arrival: a latched message from a simulator that stopped long
        # ago arrives now but is stamped then; a stamp ahead of this clock must not keep it fresh.
        self.simulated_speed_since_ns = min(now_ns, stamp.sec * 1_000_000_000 + stamp.nanosec)

    def _commanded(self, now_ns: int) -> bool:
        # A command older than the stale timeout no longer counts: the driver's watchdog has
        # stopped the motor by then.
        if self.last_command_ns is None:
            return False
        age_s = (now_ns - self.last_command_ns) * 1e-9
        return age_s < self.get_parameter(STALE_TIMEOUT.name).value and (
            self.commanded_speed > _MIN_COMMANDED_SPEED_RAD_S
        )

    def _on_state(self, message: TailState) -> None:
        now_ns = self.get_clock().now().nanoseconds
        self.last_input_ns = now_ns
        stamp = message.header.stamp
        # Symmetry is judged on theta3, measured from the swing's current mid-line, not on the
        # body-frame fin angle: a shifted pivot turns the whole swing by its bias on purpose
        # (steering), and judged from the body axis every such beat would read as lopsided.
        # What a shift does change about the swing itself, its uneven timing about the mid-line
        # (the shifted linkage is no longer the symmetric design), does show in theta3.
        theta3 = message.theta3
        tip_y = message.tip.y
        tip_y_velocity = message.tip_velocity.y
        # The swimming figures take the fin's angle to the body axis, which the water sees.
        fin_angle = getattr(message, _FIN_ANGLE_FIELD.get(message.mechanism, "fin_angle"))
        reason = self.guard.check(
            stamp.sec * 1_000_000_000 + stamp.nanosec,
            message.motor_angle,
            theta3 + tip_y + tip_y_velocity + fin_angle,
            now_ns,
        )
        if reason is not None:
            self.drops.count(reason)
            self.get_logger().warning(self._drop_log[reason], throttle_duration_sec=2.0)
            return
        time_s = stamp.sec + stamp.nanosec * 1e-9
        gap = self.timing.observe(time_s)
        if (
            self.last_sample_time_s is not None
            and time_s - self.last_sample_time_s > self.gap_reset_sec
        ):
            self.tracker.reset()
            self.tip_samples.reset()
        self.last_sample_time_s = time_s
        self.frame_id = message.header.frame_id
        self.tip_samples.add(time_s, tip_y, tip_y_velocity, fin_angle)
        beat = self.tracker.add(time_s, theta3, message.motor_angle, gap)
        if beat is not None:
            kinematics = self.tip_samples.complete(beat)
            self._publish_beat(beat, stamp, kinematics)

    def _publish_beat(
        self, beat: BeatStatistics, stamp: Any, kinematics: TipKinematics | None
    ) -> None:
        verdict, text = judge(beat, self.tolerances)
        self.last_beat = beat
        if verdict == Verdict.NOT_JUDGED:
            self.beats_not_judged += 1
            self.last_beat_reason = text
        else:
            self.last_beat_reason = ""
            self.last_verdict = (verdict, text, beat.index)
            self.last_judged_beat = beat
        # The swimming figures are over time, so a carrier angle that did not advance leaves them
        # defined; over a hole in the data they would be as wrong as the symmetry.
        self.last_tip_kinematics = None if beat.gap_s > 0.0 else kinematics
        now_ns = self.get_clock().now().nanoseconds
        self.last_progress_ns = now_ns
        # The simulator publishes once per beat: a speed older than two beats (or the stale
        # timeout, for fast beats) no longer describes this one.
        since_ns = self.simulated_speed_since_ns
        self.beat_simulated_speed_m_s = self.simulated_speed_m_s
        self.beat_simulated_speed_age_s = (
            math.inf if since_ns is None else (now_ns - since_ns) * 1e-9
        )
        self.beat_simulated_speed_max_age_s = max(
            self.get_parameter(STALE_TIMEOUT.name).value, 2.0 * beat.period_s
        )
        report = self.report
        report.header.stamp = stamp
        report.header.frame_id = self.frame_id
        report.beat_index = beat.index
        report.positive_peak = _finite(beat.positive_peak_rad)
        report.negative_peak = _finite(beat.negative_peak_rad)
        report.amplitude = _finite(beat.amplitude_rad)
        report.mean_angle = _finite(beat.mean_angle_rad)
        report.positive_time_share = _finite(beat.positive_time_share)
        report.negative_time_share = _finite(beat.negative_time_share)
        report.period = _finite(beat.period_s)
        report.frequency = _finite(beat.frequency_hz)
        report.verdict = int(verdict)
        report.message = text
        self.report_publisher.publish(report)
        if verdict != Verdict.OK:
            self.get_logger().warning(f"beat {beat.index}: {text}", throttle_duration_sec=5.0)

    def _on_diagnostics(self) -> None:
        now_ns = self.get_clock().now().nanoseconds
        values = {
            "beats": str(self.tracker.beats_completed),
            "beats_not_judged": str(self.beats_not_judged),
        }
        stale_after = self.get_parameter(STALE_TIMEOUT.name).value
        stale = self.last_input_ns is None or (now_ns - self.last_input_ns) * 1e-9 > stale_after
        commanded = self._commanded(now_ns)
        level: int
        if stale:
            level, text = Level.STALE, f"no {INPUT_TOPIC} received recently"
        elif commanded and self._beat_overdue(now_ns):
            waited = (now_ns - self.last_progress_ns) * 1e-9
            level, text = (
                Level.ERROR,
                f"motor commanded at {self.commanded_speed:.3g} rad/s but no tail beat completed "
                f"in {waited:.1f} s",
            )
        else:
            level, text = self._verdict_status()
        # The figures of the beat the verdict quotes (the latest judged one): a later beat that
        # could not be judged (a gap in the input) would put other numbers beside its text.
        beat = self.last_judged_beat or self.last_beat
        if beat is not None:
            values.update(
                beat_index=str(beat.index),
                amplitude_deg=f"{math.degrees(beat.amplitude_rad):.3f}",
                frequency_hz=f"{beat.frequency_hz:.4f}",
            )
            if math.isfinite(beat.mean_angle_rad + beat.positive_time_share):
                values.update(
                    mean_angle_deg=f"{math.degrees(beat.mean_angle_rad):.4f}",
                    positive_time_share=f"{beat.positive_time_share:.5f}",
                )
        if self.last_tip_kinematics is not None:
            # Chosen here rather than at the beat so that a new forward_speed_m_s applies at once.
            speed_m_s, source = choose_forward_speed(
                self.swimming_parameters.forward_speed_m_s,
                self.beat_simulated_speed_m_s,
                self.beat_simulated_speed_age_s,
                self.beat_simulated_speed_max_age_s,
            )
            swimming = figures_from_kinematics(
                self.last_tip_kinematics,
                dataclasses.replace(self.swimming_parameters, forward_speed_m_s=speed_m_s),
            )
            values.update(
                tip_excursion_m=f"{swimming.tip_excursion_m:.5f}",
                strouhal_number=f"{swimming.strouhal_number:.4f}",
                lighthill_mean_thrust_n=f"{swimming.mean_thrust_n:.5g}",
                forward_speed_m_s=f"{speed_m_s:.6g}",
                forward_speed_source=source,
            )
        input_level, input_text, input_values = input_status(
            INPUT_TOPIC,
            self.drops,
            self.timing.take_period(),
            DIAGNOSTICS_PERIOD_S,
            self.timing_status,
        )
        if stale:
            input_level, input_text = Level.STALE, f"no {INPUT_TOPIC} received recently"
        # The verdict last: a reader that keeps the latest status of this node keeps the verdict.
        self.diagnostics_publisher.publish(
            diagnostic_array(
                self,
                Status(f"{INPUT_TOPIC} input", input_level, input_text, input_values),
                Status("tail swing symmetry", level, text, values),
            )
        )

    def _verdict_status(self) -> tuple[int, str]:
        """Level and message from the latest judged beat, saying if later beats were not judged.

        A beat that was not judged says nothing about the linkage: the latest judged verdict
        stands (the input status warns about the gaps). Before any beat could be judged, beats
        that could not are a WARN.
        """
        latest = self.last_beat
        if self.last_verdict is None:
            if latest is None:
                return int(Verdict.OK), "waiting for the first complete beat"
            return int(Verdict.WARN), f"no beat judged yet; beat {latest.index}: " + (
                self.last_beat_reason
            )
        verdict, text, index = self.last_verdict
        if latest is not None and latest.index != index:
            text = f"{text} (beat {index}; beat {latest.index} {self.last_beat_reason})"
        return int(verdict), text

    def _beat_overdue(self, now_ns: int) -> bool:
        expected_period_s = 2.0 * math.pi / self.commanded_speed
        allowed_s = max(self.get_parameter(BEAT_TIMEOUT.name).value, 2.0 * expected_period_s)
        return bool((now_ns - self.last_progress_ns) * 1e-9 > allowed_s)


#: How a process creates this node (its own ``main``, or ``fishtail-run --one-process``).
FACTORY = NodeFactory(MonitorNode, "monitor", (ValueError,))


def main() -> int:
    """Entry point of ``ros2 run fishtail_kinematics monitor``."""
    return run_node(FACTORY.create, FACTORY.label, FACTORY.startup_errors)


if __name__ == "__main__":
    sys.exit(main())
