"""The fish as a robot model (URDF), for robot_state_publisher and RViz's RobotModel display.

The tree, every link named as a frame or as one of the engine's ``Tail.links``::

    base_link            the hull, origin at the centre of mass C (the simulator's odometry)
      | fixed            frames.tail_in_body: O at x = -l_O, a half turn about y
    tail_mechanism       the tail frame (x back, y left, z down), the ring gear drawn at O
      | theta3           revolute about z at S, from the swing's mid-line
    tail_link            mechanism 1: ST, with the rocker RS rigid to it
    swing_arm            mechanism 2: SW, with RS and the pin U
      | fin_hinge_counter_turn   mechanism 2: at W, mimics theta3 times -1
    fin_hinge            mechanism 2: W, axes parallel to the tail frame's
      | theta5           mechanism 2: revolute about z, the fin link from the tail frame's x axis
    fin_link             mechanism 2: VT
      | fixed
    tail_fin             the fin, origin at the tip T (the trailing edge)

The revolute joints are driven by the kinematics node's ``tail/joint_states``, whose names are the
engine's ``Tail.joint_names``; the others there (theta1, theta2, theta4) move parts the model
leaves out and robot_state_publisher ignores them. Each published angle is in the tail frame
(docs/kinematics.md): theta3 is the tail link's angle about S, so it drives the joint at S as it
is, but theta5 is the fin link's own angle to the tail frame's x axis, not its angle to SW, on which
its hinge W sits. The hinge is therefore two coincident joints: one turns back by theta3 (a mimic
joint, which robot_state_publisher computes from theta3), the other turns by theta5; together they
turn the fin link by theta5 - theta3 relative to SW, as the linkage does. The model is visual only
(no inertial or collision elements). docs/visualisation.md ("Robot model (URDF)").

>>> from fishtail_kinematics.engine.geometry import OscillatoryGeometry
>>> from fishtail_kinematics.engine.mechanisms import make_tail
>>> limits = joint_limits(make_tail(OscillatoryGeometry()))
>>> round(math.degrees(limits["theta3"].upper_rad), 3), round(limits["theta3"].velocity_rad_s, 2)
(26.565, 10.01)
"""

from __future__ import annotations

import dataclasses
import math
import xml.etree.ElementTree as ElementTree
from collections.abc import Sequence

import numpy as np

from fishtail_common.interface import BODY_FRAME, TAIL_FRAME
from fishtail_kinematics.engine.carrier_profile import DEFAULT_TOP_SPEED_RAD_S
from fishtail_kinematics.engine.geometry import OscillatoryGeometry, UndulatoryGeometry
from fishtail_kinematics.engine.mechanisms import Tail
from fishtail_plant.errors import FishParameterError
from fishtail_plant.fish.fish import FishParameters
from fishtail_swim.frames import Quaternion, Vector, tail_in_body

#: The engine's joint (in ``Tail.joint_names``, published on tail/joint_states) that turns the
#: tail link (ST, or SW of mechanism 2) about S.
SWING_JOINT = "theta3"
#: The fixed joint from the hull to the tail frame.
TAIL_MOUNT_JOINT = f"{BODY_FRAME}_to_{TAIL_FRAME}"
#: Mechanism 2's hinge W: the joint that turns back by theta3, and the link after it.
FIN_HINGE_COUNTER_TURN = "fin_hinge_counter_turn"
FIN_HINGE = "fin_hinge"
#: The link that carries the fin (mechanism 2), the tail link itself for mechanism 1.
FIN_LINK = "fin_link"
#: The fin, its origin at the tip T, and the fixed joint that places it there.
TAIL_FIN = "tail_fin"
TAIL_FIN_JOINT = f"{TAIL_FIN}_mount"
#: The links that turn about S (``Tail.links``): ST with RS, or SW with RS.
TAIL_LINK = "tail_link"
SWING_ARM = "swing_arm"

#: Carrier angles over one revolution at which the joints' rates (and theta5's extremes) are
#: taken; the stroke's ends are among them.
CYCLE_SAMPLES = 3600
#: The output joints are turned by the linkage, not by an actuator of their own, so no effort
#: limit exists; URDF requires the attribute, and robot_state_publisher and RViz ignore it.
PASSIVE_JOINT_EFFORT = 0.0
#: The hull is a prolate spheroid; URDF has no ellipsoid, so it is drawn as coaxial cylinders.
HULL_SLICES = 12
#: Cross-section of the links' bars and the radius of the joints' discs [m] (drawing only).
BAR_WIDTH_M = 0.01
BAR_HEIGHT_M = 0.006
JOINT_RADIUS_M = 0.008
#: The ring gear's disc is this thick [m].
RING_THICKNESS_M = 0.002
#: The fin's chord as drawn when the fish's fin_chord_m is 0 (config/fish.yaml: 0 means "no
#: recoil term" in the dynamics, not a fin without depth) [m], and its thickness.
DRAWN_FIN_CHORD_M = 0.04
FIN_THICKNESS_M = 0.003
#: Colours (r, g, b, a) of the parts.
MATERIALS: dict[str, tuple[float, float, float, float]] = {
    "hull": (0.55, 0.65, 0.75, 0.35),
    "ring_gear": (0.6, 0.6, 0.6, 0.5),
    "linkage": (0.85, 0.45, 0.1, 1.0),
    "fin": (0.2, 0.4, 0.8, 0.8),
}

_HALF_TURN = math.pi
_ALONG_X = (0.0, 0.5 * math.pi, 0.0)  # rpy that turns a cylinder's axis (z) onto x


@dataclasses.dataclass(frozen=True)
class JointLimits:
    """A revolute joint's limits: its range and top rate at the top carrier speed, its effort."""

    lower_rad: float
    upper_rad: float
    velocity_rad_s: float
    effort: float = PASSIVE_JOINT_EFFORT


def joint_limits(
    tail: Tail, top_carrier_speed_rad_s: float = DEFAULT_TOP_SPEED_RAD_S
) -> dict[str, JointLimits]:
    """The limits of the model's driven joints (theta3, and theta5 for mechanism 2).

    theta3's range is the engine's swing, exact: the drive's extremes of theta2 about its
    mid-line. theta5's is its smallest and largest value over :data:`CYCLE_SAMPLES` carrier
    angles of a revolution solved by the engine (exact where the extremes lie at the stroke's
    ends, as for a monotone drive). A joint's velocity limit is its highest rate over that
    revolution with the carrier at ``top_carrier_speed_rad_s`` (the driver's top speed by default).
    """
    drive = tail.drive
    names = [SWING_JOINT] if tail.fin_joint is None else [SWING_JOINT, tail.fin_joint]
    # OP = R cos(phi + psi): shifted by the phase, the samples include the stroke's ends.
    carrier = np.linspace(0.0, 2.0 * math.pi, CYCLE_SAMPLES, endpoint=False)
    state = tail.solve(carrier - tail.geometry.phase_rad, 1.0)
    limits = {}
    for name in names:
        if name == SWING_JOINT:
            lower = drive.theta2_min - drive.theta2_mid
            upper = drive.theta2_max - drive.theta2_mid
        else:
            angles = np.asarray(getattr(state, name))
            lower, upper = float(angles.min()), float(angles.max())
        rate_per_carrier_speed = float(np.abs(np.asarray(getattr(state, f"{name}_dot"))).max())
        limits[name] = JointLimits(lower, upper, rate_per_carrier_speed * top_carrier_speed_rad_s)
    return limits


def _text(values: Sequence[float]) -> str:
    # repr: the shortest text that reads back as the same float.
    return " ".join(repr(float(value)) for value in values)


def _quaternion_rpy(rotation: Quaternion) -> Vector:
    """The roll, pitch, yaw (URDF's fixed-axis x-y-z angles) of a unit quaternion (x, y, z, w)."""
    x, y, z, w = rotation
    sin_pitch = max(-1.0, min(1.0, 2.0 * (w * y - z * x)))
    return (
        math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y)),
        math.asin(sin_pitch),
        math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z)),
    )


class _RobotWriter:
    """Builds the URDF's elements: links with visuals, joints with origins and limits."""

    def __init__(self, name: str) -> None:
        self.robot = ElementTree.Element("robot", name=name)
        for material, rgba in MATERIALS.items():
            element = ElementTree.SubElement(self.robot, "material", name=material)
            ElementTree.SubElement(element, "color", rgba=_text(rgba))

    def comment(self, text: str) -> None:
        self.robot.append(ElementTree.Comment(f" {text} "))

    def link(self, name: str) -> ElementTree.Element:
        return ElementTree.SubElement(self.robot, "link", name=name)

    def visual(
        self,
        link: ElementTree.Element,
        name: str,
        shape: str,
        size: dict[str, str],
        material: str,
        xyz: Vector = (0.0, 0.0, 0.0),
        rpy: Vector = (0.0, 0.0, 0.0),
    ) -> None:
        visual = ElementTree.SubElement(link, "visual", name=name)
        ElementTree.SubElement(visual, "origin", xyz=_text(xyz), rpy=_text(rpy))
        geometry = ElementTree.SubElement(visual, "geometry")
        ElementTree.SubElement(geometry, shape, size)
        ElementTree.SubElement(visual, "material", name=material)

    def bar(
        self, link: ElementTree.Element, name: str, length: float, angle: float = 0.0,
        start: float = 0.0,
    ) -> None:  # fmt: skip
        """A bar of ``length`` from ``start`` along the direction ``angle`` (about z)."""
        middle = start + 0.5 * length
        self.visual(
            link, name, "box", {"size": _text((length, BAR_WIDTH_M, BAR_HEIGHT_M))}, "linkage",
            (middle * math.cos(angle), middle * math.sin(angle), 0.0), (0.0, 0.0, angle),
        )  # fmt: skip

    def pin(self, link: ElementTree.Element, name: str, x: float) -> None:
        """A joint's disc at (x, 0, 0), its axis z."""
        self.visual(
            link, name, "cylinder",
            {"radius": repr(JOINT_RADIUS_M), "length": repr(2.0 * BAR_HEIGHT_M)}, "linkage",
            (x, 0.0, 0.0),
        )  # fmt: skip

    def joint(
        self,
        name: str,
        kind: str,
        parent: str,
        child: str,
        xyz: Vector,
        rpy: Vector = (0.0, 0.0, 0.0),
        limits: JointLimits | None = None,
    ) -> ElementTree.Element:
        joint = ElementTree.SubElement(self.robot, "joint", name=name, type=kind)
        ElementTree.SubElement(joint, "parent", link=parent)
        ElementTree.SubElement(joint, "child", link=child)
        ElementTree.SubElement(joint, "origin", xyz=_text(xyz), rpy=_text(rpy))
        if limits is not None:
            ElementTree.SubElement(joint, "axis", xyz="0 0 1")
            ElementTree.SubElement(
                joint, "limit", lower=repr(limits.lower_rad), upper=repr(limits.upper_rad),
                velocity=repr(limits.velocity_rad_s), effort=repr(limits.effort),
            )  # fmt: skip
        return joint

    def text(self) -> str:
        ElementTree.indent(self.robot, space="  ")
        return '<?xml version="1.0"?>\n' + ElementTree.tostring(self.robot, "unicode") + "\n"


def _one_fish(fish: FishParameters, name: str) -> float:
    """A fish parameter as a float.

    Raises:
        FishParameterError: the parameters hold more than one fish.
    """
    value = np.asarray(getattr(fish, name))
    if value.size != 1:
        raise FishParameterError(
            f"{name} holds {value.size} values: the robot model is of one fish"
        )
    return float(value.ravel()[0])


def _hull(writer: _RobotWriter, length_m: float, diameter_m: float) -> None:
    """The prolate spheroid L x D round C, as :data:`HULL_SLICES` coaxial cylinders along x."""
    body = writer.link(BODY_FRAME)
    half_length, radius = 0.5 * length_m, 0.5 * diameter_m
    width = length_m / HULL_SLICES
    for index in range(HULL_SLICES):
        middle = -half_length + (index + 0.5) * width
        slice_radius = radius * math.sqrt(1.0 - (middle / half_length) ** 2)
        writer.visual(
            body, f"hull_{index}", "cylinder",
            {"radius": repr(slice_radius), "length": repr(width)}, "hull", (middle, 0.0, 0.0),
            _ALONG_X,
        )  # fmt: skip


def _fin(
    writer: _RobotWriter, parent: str, tip_x_m: float, fin_span_m: float, fin_chord_m: float
) -> None:
    """The fin, its origin at the tip T = (``tip_x_m``, 0, 0) of ``parent``, its span along z."""
    writer.joint(TAIL_FIN_JOINT, "fixed", parent, TAIL_FIN, (tip_x_m, 0.0, 0.0))
    chord = fin_chord_m if fin_chord_m > 0.0 else DRAWN_FIN_CHORD_M
    writer.visual(
        writer.link(TAIL_FIN), "fin", "box", {"size": _text((chord, FIN_THICKNESS_M, fin_span_m))},
        "fin", (-0.5 * chord, 0.0, 0.0),
    )  # fmt: skip


def robot_description(
    tail: Tail, fish: FishParameters, top_carrier_speed_rad_s: float = DEFAULT_TOP_SPEED_RAD_S
) -> str:
    """The URDF of ``fish`` with ``tail`` (its geometry and pivot shift), as text.

    A tail with a pivot shift gives the model with S where the shift puts it and theta3's joint
    turned by the swing bias (theta3 is measured from the shifted swing's mid-line); the design's
    tail gives the model of the design. ``top_carrier_speed_rad_s`` sets the velocity limits
    (:func:`joint_limits`).

    Raises:
        FishParameterError: ``fish`` holds more than one fish.
    """
    body_length = _one_fish(fish, "body_length_m")
    body_diameter = _one_fish(fish, "body_diameter_m")
    tail_offset = _one_fish(fish, "tail_origin_offset_m")
    fin_span = _one_fish(fish, "fin_span_m")
    fin_chord = _one_fish(fish, "fin_chord_m")
    limits = joint_limits(tail, top_carrier_speed_rad_s)
    geometry = tail.shifted_geometry
    bias = tail.swing_bias_rad
    rocker_angle = tail.drive.tail_mounting_rad  # RS's direction in the frame of ST or SW

    writer = _RobotWriter(f"fishtail_{tail.name}")
    writer.comment(
        f"The robotic fish with the {tail.name} tail, made by fishtail-swim urdf. Drive it with "
        "the kinematics node's tail/joint_states (docs/visualisation.md)."
    )
    _hull(writer, body_length, body_diameter)
    mount = tail_in_body(tail_offset)
    writer.joint(
        TAIL_MOUNT_JOINT, "fixed", mount.parent, mount.child, mount.translation,
        _quaternion_rpy(mount.rotation),
    )  # fmt: skip
    ring = writer.link(TAIL_FRAME)
    writer.visual(
        ring, "ring_gear", "cylinder",
        {"radius": repr(geometry.ring_radius_m), "length": repr(RING_THICKNESS_M)}, "ring_gear",
    )  # fmt: skip
    swing_link = TAIL_LINK if tail.fin_joint is None else SWING_ARM
    writer.joint(
        SWING_JOINT, "revolute", TAIL_FRAME, swing_link, (geometry.pivot_offset_m, 0.0, 0.0),
        (0.0, 0.0, bias), limits[SWING_JOINT],
    )  # fmt: skip
    arm = writer.link(swing_link)
    writer.pin(arm, "pivot_s", 0.0)
    writer.bar(arm, "rocker_link", geometry.rocker_link_m, rocker_angle)
    if isinstance(geometry, OscillatoryGeometry):
        writer.bar(arm, TAIL_LINK, geometry.tail_link_m)
        _fin(writer, TAIL_LINK, geometry.tail_link_m, fin_span, fin_chord)
        return writer.text()
    assert isinstance(geometry, UndulatoryGeometry) and tail.fin_joint is not None
    writer.bar(arm, SWING_ARM, geometry.swing_arm_m)
    writer.pin(arm, "pin_u", geometry.pin_offset_m)
    writer.comment(
        f"The hinge W. {tail.fin_joint} is the fin link's angle to the tail frame's x axis, not "
        f"to SW, so W is two joints. The first turns back by {SWING_JOINT} (mimic, multiplier "
        f"-1), the second by {tail.fin_joint}."
    )
    swing = limits[SWING_JOINT]
    counter_turn = writer.joint(
        FIN_HINGE_COUNTER_TURN, "revolute", SWING_ARM, FIN_HINGE,
        (geometry.swing_arm_m, 0.0, 0.0), limits=JointLimits(
            -swing.upper_rad, -swing.lower_rad, swing.velocity_rad_s, swing.effort
        ),
    )  # fmt: skip
    ElementTree.SubElement(counter_turn, "mimic", joint=SWING_JOINT, multiplier="-1.0")
    writer.link(FIN_HINGE)
    # The counter-turn leaves the swing bias; the fin's joint turns it back to the tail frame.
    writer.joint(
        tail.fin_joint, "revolute", FIN_HINGE, FIN_LINK, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0 - bias),
        limits[tail.fin_joint],
    )  # fmt: skip
    fin_link = writer.link(FIN_LINK)
    tip_x = geometry.fin_link_m - geometry.fin_joint_offset_m  # WT
    writer.pin(fin_link, "hinge_w", 0.0)
    writer.bar(fin_link, FIN_LINK, geometry.fin_link_m, start=-geometry.fin_joint_offset_m)
    _fin(writer, FIN_LINK, tip_x, fin_span, fin_chord)
    return writer.text()
