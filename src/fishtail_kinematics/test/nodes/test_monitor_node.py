"""The monitor's swimming figures: from tail/state samples to its /diagnostics values.

The monitor runs in this process (own namespace); the test feeds it TailState messages computed by
the engine and reads the DiagnosticArray it would publish.
"""

from __future__ import annotations

import math
import os
import time

import numpy as np
import pytest

from fishtail_kinematics.engine.geometry import OscillatoryGeometry, UndulatoryGeometry
from fishtail_kinematics.engine.mechanisms import OscillatoryTail, UndulatoryTail
from fishtail_kinematics.engine.swimming import SwimmingParameters, swimming_figures

pytestmark = pytest.mark.filterwarnings("ignore:module 'sre_:DeprecationWarning")
SPEED_RAD_S = 4.0
RATE_HZ = 500.0


@pytest.fixture
def monitor(monkeypatch):
    """A monitor node in this process whose /diagnostics go to ``monitor.published``."""
    import rclpy

    from fishtail_kinematics.nodes.monitor_node import MonitorNode

    rclpy.init(args=["--ros-args", "-r", f"__ns:=/test_swimming_{os.getpid()}_{time.time_ns()}"])
    node = MonitorNode()
    node.published = []
    monkeypatch.setattr(node.diagnostics_publisher, "publish", node.published.append)
    try:
        yield node
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


def feed(monitor, tail, seconds: float):
    """Send the engine's states at RATE_HZ for ``seconds``; return times and states."""
    from fishtail_msgs.msg import TailState

    t = np.arange(0.0, seconds, 1.0 / RATE_HZ) + 100.0
    states = tail.solve(SPEED_RAD_S * (t - 100.0), SPEED_RAD_S)
    undulatory = isinstance(tail, UndulatoryTail)
    for k, time_s in enumerate(t):
        message = TailState()
        message.header.stamp.sec = int(time_s)
        message.header.stamp.nanosec = int(round((time_s - int(time_s)) * 1e9))
        message.mechanism = (
            TailState.MECHANISM_UNDULATORY if undulatory else TailState.MECHANISM_OSCILLATORY
        )
        message.theta3 = float(states.theta3[k])
        message.theta5 = float(states.theta5[k]) if undulatory else math.nan
        message.pivot_shift = tail.pivot_shift_m
        message.swing_bias = tail.swing_bias_rad
        message.fin_angle = float(states.fin_angle[k])
        message.tip.y = float(states.tip_y[k])
        message.tip_velocity.y = float(states.tip_y_dot[k])
        monitor._on_state(message)
    return t, states


def diagnostics_values(monitor) -> dict[str, str]:
    monitor._on_diagnostics()
    (status,) = [s for s in monitor.published[-1].status if s.name.endswith("symmetry")]
    return {pair.key: pair.value for pair in status.values}


def test_monitor_reports_the_swimming_figures_of_the_last_beat(monitor):
    assert "strouhal_number" not in diagnostics_values(monitor)  # no beat yet
    g = OscillatoryGeometry()
    t, s = feed(monitor, OscillatoryTail(g), 4.0)
    values = diagnostics_values(monitor)
    beat = monitor.last_beat
    expected = swimming_figures(
        t, s.tip_y, s.tip_y_dot, s.theta3, SwimmingParameters(0.3, 0.1, 1000.0), beats=[beat]
    )
    assert float(values["frequency_hz"]) == pytest.approx(SPEED_RAD_S / (2 * math.pi), abs=1e-4)
    assert float(values["tip_excursion_m"]) == pytest.approx(expected.tip_excursion_m, abs=1e-5)
    assert float(values["tip_excursion_m"]) == pytest.approx(
        2 * g.tail_link_m * math.sin(math.atan(0.5)), abs=2e-5
    )
    assert float(values["strouhal_number"]) == pytest.approx(expected.strouhal_number, abs=1e-4)
    assert float(values["lighthill_mean_thrust_n"]) == pytest.approx(
        expected.mean_thrust_n, rel=1e-4
    )
    assert values["forward_speed_m_s"] == "0.3"
    assert values["forward_speed_source"] == "parameter"  # no simulator in this test

    # New parameters apply at once to the figures of the last beat.
    from rclpy.parameter import Parameter

    results = monitor.set_parameters(
        [Parameter("forward_speed_m_s", value=0.6), Parameter("fin_span_m", value=0.2)]
    )
    assert all(result.successful for result in results)
    faster = diagnostics_values(monitor)
    assert float(faster["strouhal_number"]) == pytest.approx(expected.strouhal_number / 2, abs=1e-4)
    refit = swimming_figures(
        t, s.tip_y, s.tip_y_dot, s.theta3, SwimmingParameters(0.6, 0.2), beats=[beat]
    )
    assert float(faster["lighthill_mean_thrust_n"]) == pytest.approx(refit.mean_thrust_n, rel=1e-4)
    refused = monitor.set_parameters([Parameter("fin_span_m", value=0.0)])[0]
    assert not refused.successful
    assert monitor.swimming_parameters.fin_span_m == 0.2


def test_monitor_uses_theta5_for_the_undulatory_tail(monitor):
    t, s = feed(monitor, UndulatoryTail(UndulatoryGeometry()), 4.0)
    values = diagnostics_values(monitor)
    expected = swimming_figures(
        t, s.tip_y, s.tip_y_dot, s.theta5, SwimmingParameters(0.3, 0.1), beats=[monitor.last_beat]
    )
    assert float(values["lighthill_mean_thrust_n"]) == pytest.approx(
        expected.mean_thrust_n, rel=1e-4
    )
    # With theta3 as the slope the thrust would differ: the fin link's angle is what counts.
    wrong = swimming_figures(
        t, s.tip_y, s.tip_y_dot, s.theta3, SwimmingParameters(0.3, 0.1), beats=[monitor.last_beat]
    )
    assert abs(wrong.mean_thrust_n - expected.mean_thrust_n) > 1e-3 * abs(expected.mean_thrust_n)
    # Only the samples since the last beat's end are kept (less than a beat's worth).
    assert len(monitor.tip_samples) < RATE_HZ * 2 * math.pi / SPEED_RAD_S


def test_a_shifted_tail_is_judged_about_its_mid_line_and_swims_with_its_body_frame_angle(monitor):
    """A shifted tail: symmetry from theta3, the swimming figures from the body-frame angle.

    The swimming figures take the fin's angle from the body axis (theta3 + bias); the beat's
    statistics stay those of theta3, which is measured from the swing's current mid-line.
    """
    tail = OscillatoryTail(OscillatoryGeometry()).with_pivot_shift(0.04)
    t, s = feed(monitor, tail, 4.0)
    values = diagnostics_values(monitor)
    beat = monitor.last_beat
    expected = swimming_figures(
        t, s.tip_y, s.tip_y_dot, s.fin_angle, SwimmingParameters(0.3, 0.1), beats=[beat]
    )
    assert float(values["lighthill_mean_thrust_n"]) == pytest.approx(
        expected.mean_thrust_n, rel=1e-4
    )
    # The peaks are theta3's, +-half the shifted swing, not shifted by the bias (2.5 degrees).
    half = tail.drive.swing_range_rad / 2
    assert beat.positive_peak_rad == pytest.approx(half, abs=1e-3)
    assert beat.negative_peak_rad == pytest.approx(-half, abs=1e-3)
    assert tail.swing_bias_rad > math.radians(2.0)
