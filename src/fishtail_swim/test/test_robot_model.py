"""The fish's robot model (URDF): what yourdfpy reads from it, and where its joints put the tail.

The forward kinematics of the model, at the joint positions the kinematics node publishes for a
carrier angle (the engine's state, named as ``Tail.joint_names``), must put the tip, the hinge W
and the rocker's joint R where the engine puts them: the check that the joints' conventions
(theta3 from the swing's mid-line, theta5 from the tail frame's x axis) are honoured.
"""

import io
import math
from pathlib import Path

import numpy as np
import pytest
import yaml
import yourdfpy

from fishtail_common.interface import BODY_FRAME, TAIL_FRAME
from fishtail_common.parameter_files import load_parameter_file
from fishtail_kinematics.engine.design import pivot_shift_effect
from fishtail_kinematics.engine.mechanisms import make_tail
from fishtail_kinematics.engine.parameters import geometry_from_parameters, geometry_parameters_in
from fishtail_plant.errors import FishParameterError
from fishtail_plant.fish.fish import FishParameters
from fishtail_plant.values import load_fish_parameters
from fishtail_swim.frames import tail_in_body
from fishtail_swim.robot_model import (
    FIN_HINGE,
    FIN_HINGE_COUNTER_TURN,
    PASSIVE_JOINT_EFFORT,
    SWING_JOINT,
    TAIL_FIN,
    TAIL_MOUNT_JOINT,
    robot_description,
)

CONFIG = Path(__file__).resolve().parents[3] / "config"
MECHANISMS = ("oscillatory", "undulatory")
#: Carrier angles: the stroke's ends (0, pi), between them, and beyond a revolution.
CARRIER_ANGLES = (0.0, 0.7, 1.9, math.pi, 4.4, 5.8, 12.0)
TOP_CARRIER_SPEED_RAD_S = 20.0


def _tail(mechanism):
    values = load_parameter_file(CONFIG / f"{mechanism}.yaml")
    return make_tail(geometry_from_parameters(geometry_parameters_in(values)))


FISH = load_fish_parameters(CONFIG / "fish.yaml")
TAILS = {mechanism: _tail(mechanism) for mechanism in MECHANISMS}


def _load(text):
    return yourdfpy.URDF.load(
        io.StringIO(text), load_meshes=False, build_collision_scene_graph=False,
        load_collision_meshes=False,
    )  # fmt: skip


@pytest.fixture(scope="module", params=[(m, s) for m in MECHANISMS for s in (0.0, 0.03)],
                ids=lambda p: f"{p[0]}-shift{p[1]:g}")  # fmt: skip
def model(request):
    """(tail, URDF text, yourdfpy model) of a config's tail, unshifted and with S shifted 30 mm."""
    mechanism, shift = request.param
    tail = TAILS[mechanism].with_pivot_shift(shift)
    text = robot_description(tail, FISH, TOP_CARRIER_SPEED_RAD_S)
    return tail, text, _load(text)


def _frame_matrix(transform):
    """The 4x4 matrix of a frames.FrameTransform, built from where it sends points."""
    origin = np.array(transform.apply((0.0, 0.0, 0.0)))
    matrix = np.eye(4)
    for axis in range(3):
        unit = [0.0, 0.0, 0.0]
        unit[axis] = 1.0
        matrix[:3, axis] = np.array(transform.apply(tuple(unit))) - origin
    matrix[:3, 3] = origin
    return matrix


def _pose(urdf, tail, carrier_angle):
    """Set the model's joints as the kinematics node publishes them for ``carrier_angle``."""
    state = tail.solve(carrier_angle, 0.0)
    published = {name: getattr(state, name) for name in tail.joint_names}
    urdf.update_cfg({name: published[name] for name in urdf.actuated_joint_names})
    return state


def _point(matrix, xyz):
    return (matrix @ np.array([*xyz, 1.0]))[:3]


def test_the_root_is_base_link_and_the_model_validates(model):
    _, _, urdf = model
    assert urdf.base_link == BODY_FRAME
    assert urdf.validate()


def test_the_tail_frame_is_mounted_as_frames_places_it(model):
    _, _, urdf = model
    mount = urdf.joint_map[TAIL_MOUNT_JOINT]
    assert (mount.type, mount.parent, mount.child) == ("fixed", BODY_FRAME, TAIL_FRAME)
    expected = _frame_matrix(tail_in_body(FISH.tail_origin_offset_m))
    np.testing.assert_allclose(urdf.get_transform(TAIL_FRAME, BODY_FRAME), expected, atol=1e-15)


def test_the_driven_joints_are_named_as_on_tail_joint_states(model):
    tail, _, urdf = model
    # The kinematics node publishes tail.joint_names (its _configure_messages).
    driven = [SWING_JOINT] if tail.fin_joint is None else [SWING_JOINT, tail.fin_joint]
    assert urdf.actuated_joint_names == driven
    assert set(driven) <= set(tail.joint_names)
    for name in driven:
        assert urdf.joint_map[name].type == "revolute"
        np.testing.assert_array_equal(urdf.joint_map[name].axis, [0.0, 0.0, 1.0])
    mimics = {j.name: j.mimic for j in urdf.robot.joints if j.mimic is not None}
    if tail.fin_joint is None:
        assert mimics == {}
    else:
        assert list(mimics) == [FIN_HINGE_COUNTER_TURN]
        mimic = mimics[FIN_HINGE_COUNTER_TURN]
        assert (mimic.joint, mimic.multiplier, mimic.offset) == (SWING_JOINT, -1.0, 0.0)


def test_the_limits_are_the_engines_range(model):
    tail, _, urdf = model
    drive = tail.drive
    swing = urdf.joint_map[SWING_JOINT].limit
    assert swing.lower == drive.theta2_min - drive.theta2_mid
    assert swing.upper == drive.theta2_max - drive.theta2_mid
    assert swing.upper - swing.lower == pytest.approx(drive.swing_range_rad, abs=1e-15)
    # A finer revolution at the top speed: the velocity limits are the highest rates there.
    fine = tail.solve(np.linspace(0.0, 2.0 * math.pi, 36_001), TOP_CARRIER_SPEED_RAD_S)
    for name in urdf.actuated_joint_names:
        limit = urdf.joint_map[name].limit
        fastest = np.abs(getattr(fine, f"{name}_dot")).max()
        assert limit.velocity == pytest.approx(fastest, rel=1e-4)
        assert limit.effort == PASSIVE_JOINT_EFFORT
        assert limit.lower < 0.0 < limit.upper
    if tail.fin_joint is not None:
        # theta5's range is the fin's over a revolution (fishtail-kinematics pivot's figures).
        fin = urdf.joint_map[tail.fin_joint].limit
        effect = pivot_shift_effect(tail, tail.pivot_shift_m)
        assert (fin.lower, fin.upper) == pytest.approx((effect.fin_min_rad, effect.fin_max_rad))
        counter = urdf.joint_map[FIN_HINGE_COUNTER_TURN].limit
        assert (counter.lower, counter.upper) == (-swing.upper, -swing.lower)


@pytest.mark.parametrize("carrier_angle", CARRIER_ANGLES)
def test_the_tip_is_where_the_engine_puts_it(model, carrier_angle):
    tail, _, urdf = model
    state = _pose(urdf, tail, carrier_angle)
    tip_in_body = tail_in_body(FISH.tail_origin_offset_m).apply((state.tip_x, state.tip_y, 0.0))
    fin = urdf.get_transform(TAIL_FIN, BODY_FRAME)
    np.testing.assert_allclose(fin[:3, 3], tip_in_body, atol=1e-12)
    # The fin's x axis, in the tail frame, lies along the last link at the engine's fin angle.
    fin_in_tail = urdf.get_transform(TAIL_FIN, TAIL_FRAME)
    direction = fin_in_tail[:3, 0]
    expected = [math.cos(state.fin_angle), math.sin(state.fin_angle), 0.0]
    np.testing.assert_allclose(direction, expected, atol=1e-12)


@pytest.mark.parametrize("carrier_angle", CARRIER_ANGLES)
def test_the_drawn_joints_are_where_the_engine_puts_them(model, carrier_angle):
    tail, _, urdf = model
    state = _pose(urdf, tail, carrier_angle)
    points = tail.link_points(state)
    swing_link = urdf.joint_map[SWING_JOINT].child
    arm = urdf.get_transform(swing_link, TAIL_FRAME)
    np.testing.assert_allclose(_point(arm, (0.0, 0.0, 0.0))[:2], points.pivot_s, atol=1e-12)
    # The rocker RS is drawn rigid with the tail link: its far end is the joint R.
    (rocker,) = [v for v in urdf.link_map[swing_link].visuals if v.name == "rocker_link"]
    far_end = 2.0 * rocker.origin[:3, 3]
    np.testing.assert_allclose(_point(arm, far_end)[:2], points.joint_r, atol=1e-12)
    if tail.fin_joint is not None:
        hinge = urdf.get_transform(FIN_HINGE, TAIL_FRAME)
        np.testing.assert_allclose(hinge[:3, 3][:2], points.joint_w, atol=1e-12)


def test_the_description_survives_a_ros_parameter_on_the_command_line():
    """``-p robot_description:="$(cat fish.urdf)"``: the value is read as YAML, a plain scalar."""
    text = robot_description(TAILS["undulatory"], FISH)
    value = yaml.safe_load(text)
    assert isinstance(value, str)
    read, original = _load(value), _load(text)
    assert read.actuated_joint_names == original.actuated_joint_names
    assert [j.name for j in read.robot.joints] == [j.name for j in original.robot.joints]


def test_the_hull_is_the_fishs_size():
    fish = FishParameters(body_length_m=0.8, body_diameter_m=0.3, fin_span_m=0.15)
    urdf = _load(robot_description(TAILS["oscillatory"], fish))
    hull = urdf.link_map[BODY_FRAME].visuals
    ends = [v.origin[0, 3] + sign * 0.5 * v.geometry.cylinder.length
            for v in hull for sign in (-1.0, 1.0)]  # fmt: skip
    assert min(ends) == pytest.approx(-0.4) and max(ends) == pytest.approx(0.4)
    assert 2.0 * max(v.geometry.cylinder.radius for v in hull) == pytest.approx(0.3, rel=0.01)
    (fin,) = urdf.link_map[TAIL_FIN].visuals
    assert fin.geometry.box.size[2] == pytest.approx(0.15)


def test_a_batch_of_fish_is_refused():
    fish = FishParameters(body_length_m=np.array([0.5, 0.6]))
    with pytest.raises(FishParameterError, match="one fish"):
        robot_description(TAILS["oscillatory"], fish)
