"""The monitor's symmetry verdict on the live suite: OK for the report geometry, not OK when skewed.

The skewed geometry moves the pivot S (pivot_offset_m 0.2 -> 0.17) without re-deriving the
symmetric rocker_link_m: the tail then spends about 52.6 % of each beat on the + side. The speed
is 12 rad/s (under the driver's 20 rad/s maximum) so that a beat takes 0.52 s. Beats from the
spin-up are not judged: a beat that is not at steady speed is asymmetric in time by itself.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from rclpy.qos import QoSProfile, ReliabilityPolicy

from fishtail_common.parameter_files import load_parameter_file
from fishtail_kinematics.engine.mechanisms import make_tail
from fishtail_kinematics.engine.parameters import geometry_from_parameters, geometry_parameters_in
from fishtail_kinematics.engine.symmetry import beats_of
from fishtail_msgs.msg import SymmetryReport

SPEED_RAD_S = 12.0
PERIOD_S = 2.0 * math.pi / SPEED_RAD_S
PUBLISH_RATE_HZ = 200.0
STEADY_BEATS = 3
#: The live time share may differ from the offline one by sampling jitter and lost samples.
TIME_SHARE_TOLERANCE = 0.003
OK, WARN, ERROR, NOT_JUDGED = 0, 1, 2, 3


def offline_beat(config_path):
    """The beat statistics the engine predicts at constant speed, sampled like the driver."""
    tail = make_tail(
        geometry_from_parameters(geometry_parameters_in(load_parameter_file(config_path)))
    )
    time_s = np.arange(0.0, 4.0 * PERIOD_S, 1.0 / PUBLISH_RATE_HZ)
    phi = SPEED_RAD_S * time_s
    theta3 = tail.solve(phi, np.full_like(phi, SPEED_RAD_S)).theta3
    return beats_of(time_s, theta3)[-1]


@pytest.mark.parametrize("skewed", [False, True], ids=["report-geometry", "skewed-pivot"])
def test_monitor_verdict(start_node, ros, config_dir, params_file, skewed):
    """SymmetryReport and /diagnostics: OK for the report geometry, WARN/ERROR quoting the bias."""
    config_path = (
        params_file("oscillatory.yaml", pivot_offset_m=0.17)
        if skewed
        else (config_dir / "oscillatory.yaml")
    )
    expected = offline_beat(config_path)
    if skewed:  # the premise: this geometry is far outside the monitor's default tolerance
        assert abs(expected.positive_time_share - 0.5) > 0.02
    else:
        assert abs(expected.positive_time_share - 0.5) < 1e-4

    start_node("driver", params={"publish_rate_hz": PUBLISH_RATE_HZ})
    start_node("kinematics", params_file=config_path)
    start_node("monitor")
    reports = ros.record(
        SymmetryReport,
        "tail/symmetry",
        QoSProfile(depth=50, reliability=ReliabilityPolicy.RELIABLE),
    )
    diagnostics = ros.record_diagnostics()
    ros.wait_for_publishers("tail/symmetry")
    ros.wait_for_subscribers("tail/state")
    ros.wait_for_subscribers("motor/cmd_speed", 2)  # driver and monitor
    ros.command_speed(SPEED_RAD_S)

    def steady():
        # A beat with a gap in tail/state (a process starved of CPU) is not judged: it says
        # nothing about the geometry under test.
        return [
            r
            for r in reports.messages
            if abs(r.period - PERIOD_S) < 0.005 * PERIOD_S and r.verdict != NOT_JUDGED
        ]

    ros.spin_until(
        lambda: len(steady()) >= STEADY_BEATS,
        25.0,
        f"{STEADY_BEATS} beats at steady speed (period {PERIOD_S:.4f} s)",
    )
    for report in steady():
        summary = (
            f"beat {report.beat_index}: verdict {report.verdict}, +side share "
            f"{report.positive_time_share:.5f}, '{report.message}'"
        )
        assert abs(report.positive_time_share - expected.positive_time_share) < (
            TIME_SHARE_TOLERANCE
        ), f"{summary}; engine predicts {expected.positive_time_share:.5f}"
        assert math.isclose(report.amplitude, expected.amplitude_rad, abs_tol=1e-3), summary
        if skewed:
            assert report.verdict in (WARN, ERROR), summary
            assert f"{report.positive_time_share:.4f} of the beat on +side" in report.message
        else:
            assert report.verdict == OK, summary
            assert report.message.startswith("symmetric"), summary

    # /diagnostics carries the latest verdict (published once a second): the first status sent
    # after the first steady beat must give the verdict and quote the measured bias.
    after_ns = ros.stamp_ns(steady()[0]) + 50_000_000  # + delivery to the monitor

    def later_statuses():
        return [
            (level, status)
            for received, level, status in ros.statuses(diagnostics, "monitor")
            if received > after_ns and status.name.endswith("tail swing symmetry")
        ]

    ros.spin_until(later_statuses, 10.0, "a monitor status after the steady beats")
    level, status = later_statuses()[0]
    assert level in ((WARN, ERROR) if skewed else (OK,)), f"level {level}: {status.message}"
    assert status.message.startswith("asymmetric swing" if skewed else "symmetric"), status.message
    match = re.search(r"(\d\.\d{4}) of the beat on \+side", status.message)
    assert match, status.message
    share = float(match.group(1))
    assert abs(share - expected.positive_time_share) < TIME_SHARE_TOLERANCE, status.message
    values = ros.values(status)
    assert float(values["positive_time_share"]) == pytest.approx(share, abs=1e-4)
