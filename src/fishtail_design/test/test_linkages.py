import math

import numpy as np
import pytest

from fishtail_common.parameter_files import default_parameter_file
from fishtail_design.constraints import binding
from fishtail_design.evaluation import constraint_list, score_designs
from fishtail_design.linkages import OscillatoryLinkages, UndulatoryLinkages
from fishtail_design.problem import read_problem
from fishtail_design.variables import LINKAGE_VARIABLES
from fishtail_design.verification import verify_designs
from fishtail_kinematics.engine.geometry import UndulatoryGeometry
from fishtail_kinematics.engine.undulatory_tail import UndulatoryTail
from fishtail_plant.fish.tail_drive import EngineTailDrive, constant_carrier_speed

PROBLEM = read_problem(default_parameter_file("design/report-fish-undulatory"))
NAMES = LINKAGE_VARIABLES["undulatory"]
REPORT = UndulatoryGeometry()
GEOMETRIES = [
    REPORT,
    UndulatoryGeometry(pin_offset_m=0.05),
    UndulatoryGeometry(ring_radius_m=0.05, crank_link_m=0.06, rocker_link_m=0.16,
                       pivot_offset_m=0.15, swing_arm_m=0.12, slotted_link_m=0.2,
                       fin_link_m=0.25, fin_joint_offset_m=0.05, pin_offset_m=0.04),
]  # fmt: skip
#: A small drive, so that the second loop's joints, not the drive's R, reach furthest from the axis.
COMPACT = UndulatoryGeometry(ring_radius_m=0.04, crank_link_m=0.04, rocker_link_m=0.1,
                             pivot_offset_m=0.1, swing_arm_m=0.24, slotted_link_m=0.3,
                             pin_offset_m=0.1)  # fmt: skip
FINE = np.linspace(0.0, 2.0 * math.pi, 20001)
#: The engine's state fields of a TailSample's, in order.
ENGINE_FIELDS = ("tip_x", "tip_y", "tip_x_dot", "tip_y_dot", "theta5", "theta5_dot")


def _designs(geometries: list[UndulatoryGeometry]) -> dict[str, np.ndarray]:
    return {name: np.array([getattr(g, name) for g in geometries]) for name in NAMES}


def _problem_designs(geometries: list[UndulatoryGeometry]) -> dict[str, np.ndarray]:
    count = len(geometries)
    return _designs(geometries) | {
        "gear_ratio": np.full(count, 30.0), "gearbox_efficiency": np.full(count, 0.76),
        "carrier_speed_rad_s": np.full(count, 6.0),
    }  # fmt: skip


def _angle(first: np.ndarray, second: np.ndarray) -> np.ndarray:
    """The angle between two lines (rows of 2-vectors), folded into [0, pi/2]."""
    cross = first[:, 0] * second[:, 1] - first[:, 1] * second[:, 0]
    dot = np.sum(first * second, axis=1)
    angle = np.abs(np.arctan2(cross, dot))
    return np.minimum(angle, math.pi - angle)


def test_each_design_s_drive_is_the_engine_s_tail_solved_alone():
    # Both close the loop to the engine's tolerance (1e-13 m), from different seeds.
    speeds = np.array([4.0, 7.0, 11.0])
    linkages = UndulatoryLinkages(_designs(GEOMETRIES))
    drive = linkages.drive(constant_carrier_speed(speeds))
    times = (np.arange(64)[:, None] / 64) * (2.0 * math.pi / speeds)
    sample, acceleration = drive.sample(times), drive.acceleration(times)
    for index, geometry in enumerate(GEOMETRIES):
        tail = UndulatoryTail(geometry)
        alone = tail.solve(speeds[index] * times[:, index], speeds[index])
        for field, engine_field in zip(sample._fields, ENGINE_FIELDS, strict=True):
            got, want = getattr(sample, field)[:, index], getattr(alone, engine_field)
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-11)
        single = EngineTailDrive(tail, constant_carrier_speed(speeds[index]))
        expected = single.acceleration(times[:, index])
        # A central difference over 2e-4 rad: the poses' 1e-13 become some 1e-9.
        for got, want in zip(acceleration, expected, strict=True):
            np.testing.assert_allclose(got[:, index], want, rtol=1e-7, atol=1e-6)
    # The same times again come from memory, read-only.
    assert drive.sample(times) is sample
    assert not sample.tip_y.flags.writeable


def test_a_design_the_engine_refuses_has_nan_figures_and_margins_that_say_why():
    pin_past_w = UndulatoryGeometry(pin_offset_m=0.12)  # SU > SW - VW = 0.1 m
    short_rocker = UndulatoryGeometry(rocker_link_m=0.05)  # RS + PR cannot reach sqrt(OS² + R²)
    folded = UndulatoryGeometry(pin_offset_m=0.0111)  # the loop folds inside the swing
    geometries = [REPORT, pin_past_w, short_rocker, folded]
    linkages = UndulatoryLinkages(_designs(geometries))
    assert linkages.assembles.tolist() == [True, False, False, False]
    assert linkages.refusals[1].startswith("PinOffsetError")
    assert linkages.refusals[2].startswith("AssemblyError")
    stroke = linkages.stroke(128, PROBLEM.limits.length_behind_o_m)
    for field in ("transmission_angle_rad", "half_width_m", "time_share_imbalance",
                  "tip_excursion_m"):  # fmt: skip
        values = getattr(stroke, field)
        assert np.isfinite(values[0]) and np.isnan(values[1:]).all()
    sample = linkages.drive(constant_carrier_speed(np.full(4, 5.0))).sample(
        np.linspace(0.0, 1.0, 32)[:, None]
    )
    assert np.isfinite(sample.tip_y[:, 0]).all() and np.isnan(sample.tip_y[:, 1:]).all()

    _, table = score_designs(PROBLEM, _problem_designs(geometries))
    margins = {constraint.name: value for constraint, value in table.items()}
    # The pin: its own condition, by its length; the loop then has nothing else to say.
    assert margins["second_loop"][1] == pytest.approx(0.16 - 0.06 - 0.12)
    assert binding(table, 1) == "second_loop"
    # The drive: its condition, by its length; the loop is not judged without a swing.
    assert margins["assembly_outer"][2] == pytest.approx(0.05 + 0.1 - math.hypot(0.2, 0.1))
    assert margins["second_loop"][2] == -math.inf
    assert binding(table, 2) == "assembly_outer"
    # The fold: the engine says only that it fails, so the margin is unmet without a distance.
    assert margins["assembly_inner"][3] > 0.0 and margins["assembly_outer"][3] > 0.0
    assert margins["second_loop"][3] == -math.inf
    assert binding(table, 3) == "second_loop"
    assert not any(np.isnan(value).any() for value in margins.values())


def test_the_second_loop_margin_is_its_nearest_condition():
    geometries = [REPORT, COMPACT, UndulatoryGeometry(slotted_link_m=0.15)]
    stroke = UndulatoryLinkages(_designs(geometries)).stroke(128)
    angles = np.arange(128) * (2.0 * math.pi / 128)
    for index, g in enumerate(geometries):
        state = UndulatoryTail(g).solve(angles, 1.0)
        expected = min(
            g.swing_arm_m - g.fin_joint_offset_m - g.pin_offset_m,
            g.fin_link_m - g.fin_joint_offset_m,
            g.slotted_link_m + g.fin_joint_offset_m - g.swing_arm_m,
            state.pin_u_distance.min(), (g.slotted_link_m - state.pin_u_distance).min(),
            state.slider_a_distance.min(),
        )  # fmt: skip
        assert stroke.second_loop_m[index] == pytest.approx(expected, rel=1e-12)
    # The report's pin sits 0.02 m short of SW - VW (which is AV - AU in the straight pose): its
    # nearest condition; with AV = 0.15 m the slider comes within AV + VW - SW = 0.05 m of S.
    assert stroke.second_loop_m[0] == pytest.approx(0.16 - 0.06 - 0.08)
    assert stroke.second_loop_m[2] == pytest.approx(0.02)


def test_the_transmission_angle_is_the_smaller_of_the_drive_s_at_r_and_the_loop_s_at_v():
    stroke = UndulatoryLinkages(_designs([REPORT])).stroke(4096)
    tail = UndulatoryTail(REPORT)
    points = tail.link_points(tail.solve(FINE, 1.0))
    at_r = _angle(points.cardan - points.joint_r, points.pivot_s - points.joint_r)
    # The slotted link, SW held: A slides along the axis and AV slides and turns on the pin U,
    # so AV's instant centre I is where the vertical through A meets the normal to AV at U. V
    # moves across IV, and AV pushes the fin link at V along IV: the transmission angle is the
    # angle between IV's normal and VW, i.e. between VW and IV, folded.
    a, u, v, w = points.slider_a, points.pin_u, points.joint_v, points.joint_w
    slot = (u - a) / np.linalg.norm(u - a, axis=1)[:, None]
    normal = np.stack((-slot[:, 1], slot[:, 0]), axis=1)
    # Along the axis (the straight pose) I is at infinity: that pose is left out, the angle is
    # continuous there.
    finite = np.abs(normal[:, 0]) > 1e-9
    reach = (a[finite, 0] - u[finite, 0]) / normal[finite, 0]
    centre = u[finite] + reach[:, None] * normal[finite]
    at_v = _angle(w[finite] - v[finite], v[finite] - centre)
    expected = min(at_r.min(), at_v.min())
    assert stroke.transmission_angle_rad[0] == pytest.approx(expected, abs=1e-5)
    # For the report's geometry the drive binds (58.1°), the loop keeps some 68°.
    assert math.degrees(at_r.min()) == pytest.approx(58.10, abs=0.01)
    assert at_v.min() > at_r.min() + math.radians(5.0)


def test_the_loop_s_transmission_angle_vanishes_where_the_engine_finds_the_fold():
    # With the pin near S the loop folds inside the swing: at SU = 0.0111 m the engine refuses
    # the design, and just above it the loop's angle falls towards zero like a square root.
    pins = [0.0111, 0.01112, 0.0112, 0.0122]
    geometries = [UndulatoryGeometry(pin_offset_m=pin) for pin in pins]
    stroke = UndulatoryLinkages(_designs(geometries)).stroke(20000)
    angles = np.degrees(stroke.transmission_angle_rad)
    assert np.isnan(angles[0])
    assert 0.0 < angles[1] < 1.5 < angles[2] < 4.0 < angles[3] < 12.0


def test_the_hull_counts_the_ring_r_and_s_and_the_loop_s_joints_while_inside_the_hull():
    tail = UndulatoryTail(COMPACT)
    points = tail.link_points(tail.solve(np.arange(4096) * (2.0 * math.pi / 4096), 1.0))
    linkages = UndulatoryLinkages(_designs([COMPACT]))
    loop_joints = (points.pin_u, points.slider_a, points.joint_v, points.joint_w)
    drive_reach = max(0.04, np.abs(points.joint_r[:, 1]).max())
    for hull_length in (math.inf, 0.33, 0.3, 0.1):
        stroke = linkages.stroke(4096, hull_length)
        inside = [np.abs(joint[joint[:, 0] <= hull_length, 1]) for joint in loop_joints]
        expected = max(drive_reach, *(reach.max(initial=0.0) for reach in inside))
        assert stroke.half_width_m[0] == pytest.approx(expected, rel=1e-12)
        assert stroke.length_behind_o_m[0] == pytest.approx(
            max(0.1, points.joint_r[:, 0].max()), rel=1e-12
        )
    # The whole loop counts when the hull is long (W's swing reaches furthest); a hull ending
    # between V and W leaves the drive's R furthest out; with S at the hull's end only A (on the
    # axis) is inside.
    assert linkages.stroke(4096).half_width_m[0] > drive_reach + 0.02
    assert linkages.stroke(4096, 0.3).half_width_m[0] == pytest.approx(drive_reach)
    assert linkages.stroke(4096, 0.1).half_width_m[0] == pytest.approx(drive_reach)


def test_symmetry_is_judged_on_the_drive_s_theta3_and_the_excursion_on_the_tip():
    designs = _designs(GEOMETRIES)
    undulatory = UndulatoryLinkages(designs).stroke(128)
    drive = OscillatoryLinkages(designs | {"tail_link_m": designs["swing_arm_m"]}).stroke(128)
    np.testing.assert_allclose(undulatory.time_share_imbalance, drive.time_share_imbalance,
                               atol=1e-15)  # fmt: skip
    np.testing.assert_allclose(undulatory.mean_angle_rad, drive.mean_angle_rad, rtol=1e-12)
    for index, geometry in enumerate(GEOMETRIES):
        tip_y = UndulatoryTail(geometry).solve(np.arange(128) * (2.0 * math.pi / 128), 1.0).tip_y
        assert undulatory.tip_excursion_m[index] == pytest.approx(np.ptp(tip_y), abs=1e-12)


def test_only_the_undulatory_problem_has_the_second_loop_constraint():
    names = [constraint.name for constraint in constraint_list(PROBLEM)]
    assert names[:3] == ["assembly_inner", "assembly_outer", "second_loop"]
    oscillatory = read_problem(default_parameter_file("design/report-fish"))
    assert "second_loop" not in [constraint.name for constraint in constraint_list(oscillatory)]


@pytest.mark.slow
def test_the_verified_tier_runs_mechanism_2_designs():
    designs = _problem_designs([REPORT, UndulatoryGeometry(pin_offset_m=0.12)])
    verified = verify_designs(PROBLEM, designs, np.array([6.0, 6.0]))
    assert verified.sustained[0] == 1.0
    assert verified.speed_m_s[0] > 0.3
    assert math.isnan(verified.speed_m_s[1])


def test_a_design_s_stroke_is_the_same_bits_whatever_else_is_in_its_batch():
    folded = UndulatoryGeometry(pin_offset_m=0.0111)
    pair = UndulatoryLinkages(_designs([REPORT, GEOMETRIES[2]])).stroke(128, 0.2)
    batch = UndulatoryLinkages(_designs([folded, GEOMETRIES[2], REPORT, COMPACT])).stroke(128, 0.2)
    for field in pair._fields:
        assert np.array_equal(getattr(pair, field), getattr(batch, field)[[2, 1]])
