import dataclasses
import math

import numpy as np
import pytest

from fishtail_common.parameter_files import default_parameter_file
from fishtail_design.evaluation import FIGURES, score_designs
from fishtail_design.problem import read_problem
from fishtail_design.variables import symmetric_rocker_link
from fishtail_kinematics.engine.geometry import OscillatoryGeometry
from fishtail_kinematics.engine.mechanisms import OscillatoryTail

PROBLEM = read_problem(default_parameter_file("design/report-fish"))


def _designs(rows: list[dict[str, float]]) -> dict[str, np.ndarray]:
    names = (*PROBLEM.space.linkage_names, "gear_ratio", "gearbox_efficiency",
             "carrier_speed_rad_s")  # fmt: skip
    defaults = {"gear_ratio": 30.0, "gearbox_efficiency": 0.76, "carrier_speed_rad_s": math.nan}
    return {name: np.array([row.get(name, defaults.get(name, math.nan)) for row in rows])
            for name in names}  # fmt: skip


def _margins(rows: list[dict[str, float]], problem=PROBLEM) -> dict[str, np.ndarray]:
    _, table = score_designs(problem, _designs(rows))
    return {constraint.name: value for constraint, value in table.items()}


REPORT = {"ring_radius_m": 0.1, "crank_link_m": 0.1, "tail_link_m": 0.15, "pivot_offset_m": 0.2,
          "rocker_link_m": float(symmetric_rocker_link(0.1, 0.1, 0.2))}  # fmt: skip
COMPACT = {"ring_radius_m": 0.04, "crank_link_m": 0.04, "tail_link_m": 0.15, "pivot_offset_m": 0.15,
           "rocker_link_m": float(symmetric_rocker_link(0.04, 0.04, 0.15))}  # fmt: skip


def test_a_linkage_that_does_not_close_fails_the_condition_it_breaks_by_its_length():
    short = REPORT | {"rocker_link_m": 0.05}
    margins = _margins([short])
    # RS + PR = 0.15 m cannot reach sqrt(OS^2 + R^2) = 0.2236 m; |RS - PR| = 0.05 < OS holds.
    assert margins["assembly_outer"][0] == pytest.approx(0.15 - math.hypot(0.2, 0.1))
    assert margins["assembly_inner"][0] == pytest.approx(0.2 - 0.05)
    # Nothing else can be judged of it: every figure-based margin is unmet, none is NaN.
    assert margins["swims"][0] == -math.inf
    assert not any(np.isnan(value[0]) for value in margins.values())


def test_the_report_s_linkage_binds_at_the_hull_by_the_reach_of_its_joint_r():
    margins = _margins([REPORT, COMPACT])
    tail = OscillatoryTail(OscillatoryGeometry(**REPORT))
    points = tail.link_points(tail.solve(np.linspace(0.0, 2.0 * math.pi, 4001), 1.0))
    reach = np.abs(points.joint_r[:, 1]).max()  # R swings 0.18 m to one side of the axis
    half_width = 0.5 * PROBLEM.limits.hull_width_at_o_m
    assert margins["hull_width"][0] == pytest.approx(half_width - reach, abs=1e-4)
    assert margins["hull_width"][0] < -0.08
    assert margins["hull_width"][1] > 0.0
    # S sits at the hull's end: the length behind O is used exactly.
    assert margins["hull_length"][0] == pytest.approx(0.0, abs=1e-12)


def test_a_motor_that_cannot_sustain_the_speed_fails_on_it_and_the_driver_on_current():
    scores, _ = score_designs(PROBLEM, _designs([COMPACT]))
    sustained = scores.figures[0, FIGURES.index("sustained_speed_rad_s")]
    speeds = (0.5 * sustained, 1.2 * sustained)
    rows = [COMPACT | {"carrier_speed_rad_s": speed} for speed in speeds]
    margins = _margins(rows)
    assert margins["motor_speed"][0] == pytest.approx(0.5 * sustained, rel=1e-6)
    assert margins["motor_speed"][1] == pytest.approx(-0.2 * sustained, rel=1e-6)
    # As fast as the motor sustains: the margin is zero, and counts as met.
    assert _margins([COMPACT])["motor_speed"][0] == pytest.approx(0.0, abs=1e-6)
    assert _margins([COMPACT])["motor_speed"][0] >= 0.0
    weak_driver = dataclasses.replace(
        PROBLEM, limits=dataclasses.replace(PROBLEM.limits, driver_continuous_current_a=0.05)
    )
    margins = _margins([COMPACT], weak_driver)
    rms = scores.figures[0, FIGURES.index("rms_current_a")]
    assert margins["rms_current"][0] == pytest.approx(0.05 - rms)
    assert margins["rms_current"][0] < 0.0


def test_the_transmission_angle_is_the_smallest_angle_at_r_between_its_links():
    margins = _margins([REPORT])
    tail = OscillatoryTail(OscillatoryGeometry(**REPORT))
    points = tail.link_points(tail.solve(np.linspace(0.0, 2.0 * math.pi, 20001), 1.0))
    to_p = points.cardan - points.joint_r
    to_s = points.pivot_s - points.joint_r
    lengths = np.linalg.norm(to_p, axis=1) * np.linalg.norm(to_s, axis=1)
    cosine = np.sum(to_p * to_s, axis=1) / lengths
    angle = np.degrees(np.arccos(cosine))
    smallest = np.minimum(angle, 180.0 - angle).min()
    expected = smallest - PROBLEM.limits.min_transmission_angle_deg
    assert margins["transmission_angle"][0] == pytest.approx(expected, abs=0.05)


def test_an_asymmetric_rocker_fails_the_monitor_s_symmetry_by_its_own_statistics():
    skewed = REPORT | {"rocker_link_m": REPORT["rocker_link_m"] * 1.05}
    margins = _margins([REPORT, skewed])
    assert margins["symmetry_mean_angle"][0] > 0.0
    assert margins["symmetry_time_share"][1] < 0.0 or margins["symmetry_mean_angle"][1] < 0.0
