"""The monitor's swimming figures take the forward speed U from fish/swimming while it is fresh.

The probe publishes tail/state at 200 Hz (a symmetric sine swing, two beats a second, stamped on a
grid of its clock that starts in the past, as in test_suite_monitor_input.py) and, in the middle
phase, a SwimFigures message on fish/swimming every quarter beat: the simulator sends one a beat;
more often here keeps each well inside the monitor's staleness bound, max(2 s, 2 beats). Each phase
waits for the monitor's /diagnostics to say which speed it used; the Strouhal number it reports is
checked against f A / U from its own f and A and the speed of that source.
"""

from __future__ import annotations

import math

import pytest

from fishtail_common.interface import FISH_SWIMMING, TAIL_STATE
from fishtail_common.ros import publisher_qos
from fishtail_msgs.msg import SwimFigures, TailState

SAMPLE_PERIOD_S = 0.005
SPEED_RAD_S = 4.0 * math.pi  # a beat every 0.5 s
AMPLITUDE_RAD = 0.45
TIP_RADIUS_M = 0.15
PARAMETER_SPEED_M_S = 0.3  # the monitor's default forward_speed_m_s
SIMULATED_SPEED_M_S = 0.52
SWIM_PERIOD_S = 0.125
TIMEOUT_S = 30.0


class StateStream:
    """Publishes tail/state on a timer, stamped from ``base_ns`` on a 5 ms grid."""

    def __init__(self, ros, base_ns: int) -> None:
        """Create the publisher and the timer."""
        self.base_ns = base_ns
        self.k = 0
        self.message = TailState(
            mechanism=TailState.MECHANISM_OSCILLATORY, pivot_shift=0.0, swing_bias=0.0
        )
        self.message.header.frame_id = "tail_mechanism"
        self.message.motor_velocity = SPEED_RAD_S
        for name in ("theta4", "theta4_dot", "theta5", "theta5_dot"):
            setattr(self.message, name, math.nan)  # as the kinematics node fills mechanism 1
        self.publisher = ros.node.create_publisher(
            TailState, TAIL_STATE.name, publisher_qos(TAIL_STATE)
        )
        self.timer = ros.node.create_timer(SAMPLE_PERIOD_S, self._tick)

    def _tick(self) -> None:
        t = self.k * SAMPLE_PERIOD_S
        stamp_ns = self.base_ns + self.k * 5_000_000
        self.k += 1
        message = self.message
        message.header.stamp.sec, message.header.stamp.nanosec = divmod(stamp_ns, 1_000_000_000)
        theta3 = AMPLITUDE_RAD * math.sin(SPEED_RAD_S * t)
        theta3_dot = AMPLITUDE_RAD * SPEED_RAD_S * math.cos(SPEED_RAD_S * t)
        message.motor_angle = SPEED_RAD_S * t
        message.theta3 = theta3
        message.fin_angle = theta3  # no pivot shift (pivot_shift = swing_bias = 0)
        message.tip.x = TIP_RADIUS_M * math.cos(theta3)
        message.tip.y = TIP_RADIUS_M * math.sin(theta3)
        message.tip_velocity.y = TIP_RADIUS_M * math.cos(theta3) * theta3_dot
        self.publisher.publish(message)


class SwimStream:
    """Publishes SwimFigures with ``speed`` on fish/swimming, stamped now, while ``on``."""

    def __init__(self, ros, speed_m_s: float) -> None:
        """Create the publisher (transient local, as the simulator's) and the timer."""
        self.ros = ros
        self.on = True
        self.message = SwimFigures(mean_speed_m_s=speed_m_s, beat_frequency_hz=2.0)
        self.message.header.frame_id = "odom"
        self.publisher = ros.node.create_publisher(
            SwimFigures, FISH_SWIMMING.name, publisher_qos(FISH_SWIMMING)
        )
        self.timer = ros.node.create_timer(SWIM_PERIOD_S, self._tick)

    def _tick(self) -> None:
        if not self.on:
            return
        self.message.header.stamp = self.ros.node.get_clock().now().to_msg()
        self.message.beat_index += 1
        self.publisher.publish(self.message)


def swimming_statuses(ros, diagnostics, after: int) -> list[dict[str, str]]:
    """Values of the monitor's symmetry statuses with figures, from the ``after``-th status on."""
    found = []
    for _, _, status in ros.statuses(diagnostics, "monitor")[after:]:
        values = ros.values(status)
        if status.name.endswith("tail swing symmetry") and "strouhal_number" in values:
            found.append(values)
    return found


def wait_for_source(ros, diagnostics, source: str) -> dict[str, str]:
    """The values of the first status after now whose figures used ``source``."""
    after = len(ros.statuses(diagnostics, "monitor"))

    def with_source() -> list[dict[str, str]]:
        return [
            v
            for v in swimming_statuses(ros, diagnostics, after)
            if v["forward_speed_source"] == source
        ]

    ros.spin_until(with_source, TIMEOUT_S, f"a monitor status with figures from the {source} speed")
    return with_source()[0]


def assert_figures_for(values: dict[str, str], speed_m_s: float) -> None:
    """Reported U is ``speed_m_s`` and St = f A / U from the reported f and A."""
    assert float(values["forward_speed_m_s"]) == pytest.approx(speed_m_s, rel=1e-6), values
    frequency_hz = float(values["frequency_hz"])
    excursion_m = float(values["tip_excursion_m"])
    assert frequency_hz == pytest.approx(SPEED_RAD_S / (2.0 * math.pi), rel=0.02), values
    assert excursion_m == pytest.approx(2.0 * TIP_RADIUS_M * math.sin(AMPLITUDE_RAD), rel=0.02)
    # f and A are rounded to 4 and 5 decimals, St to 4.
    expected = frequency_hz * excursion_m / speed_m_s
    assert float(values["strouhal_number"]) == pytest.approx(expected, abs=2e-4), values


def test_monitor_uses_the_simulated_speed_while_it_is_fresh(start_node, ros):
    """U: the parameter without fish/swimming, the simulated speed while fresh, then the parameter.

    The last SwimFigures stays with the monitor (transient local) after the probe stops: only its
    age makes the monitor fall back.
    """
    start_node("monitor")
    diagnostics = ros.record_diagnostics()
    ros.wait_for_subscribers(TAIL_STATE.name)
    ros.wait_for_subscribers(FISH_SWIMMING.name)
    # 5 s in the past, so the stream never runs ahead of the monitor's clock.
    StateStream(ros, ros.node.get_clock().now().nanoseconds - 5_000_000_000)

    without = wait_for_source(ros, diagnostics, "parameter")
    assert_figures_for(without, PARAMETER_SPEED_M_S)

    swim = SwimStream(ros, SIMULATED_SPEED_M_S)
    simulated = wait_for_source(ros, diagnostics, "simulated")
    assert_figures_for(simulated, SIMULATED_SPEED_M_S)
    assert float(simulated["strouhal_number"]) != pytest.approx(
        float(without["strouhal_number"]), abs=0.01
    )

    swim.on = False
    stale = wait_for_source(ros, diagnostics, "parameter")
    assert_figures_for(stale, PARAMETER_SPEED_M_S)
