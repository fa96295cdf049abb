"""What the live view draws, as plain primitives made from the suite's messages (no rclpy here).

The view node (:mod:`fishtail_bringup.view`) and the bag replay
(:mod:`fishtail_bringup.view_replay`) hand messages to the functions here and log what comes back
through :mod:`fishtail_bringup.view_rerun`; each primitive is one Rerun archetype. Messages are
read by their fields only, so rclpy's and rosbags' both work. Archetypes, entities and sizes:
docs/visualisation.md ("The node").

>>> from types import SimpleNamespace as Msg
>>> point = lambda x, y: Msg(x=x, y=y, z=0.0)
>>> marker = Msg(
...     header=Msg(stamp=Msg(sec=3, nanosec=500_000_000)), ns="links", id=0, type=LINE_LIST,
...     action=ADD, scale=Msg(x=0.004), color=Msg(r=0.25, g=0.55, b=0.95, a=1.0),
...     pose=Msg(position=point(0.0, 0.0), orientation=Msg(x=0.0, y=0.0, z=0.0, w=1.0)),
...     points=[point(0.0, 0.1), point(0.2, 0.0), point(0.2, 0.0), point(0.3, 0.0)])
>>> stamp_s, [links] = marker_primitives(Msg(markers=[marker]), TAIL_ROOT)
>>> stamp_s, links.entity, len(links.strips), links.width_m
(3.5, 'tail/links', 2, 0.004)
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from fishtail_bringup.console import VERDICT_NAMES, verdict_text
from fishtail_bringup.view_pacing import RateLimit

FloatArray = npt.NDArray[np.float64]
Colour = tuple[float, float, float, float]  # RGBA, 0..1 as in std_msgs/ColorRGBA

#: Entity roots: the tail's drawing (its frame), the fish's (``world``), the plots, the verdicts.
TAIL_ROOT = "tail"
FISH_ROOT = "fish"
#: The tail's plot: theta3, theta5 (mechanism 2) and the carrier speed as series of one entity,
#: one message per batch (a software-rendered page takes in few a second; docs/visualisation.md).
TAIL_PLOT = "plots/tail"
#: Its series, in the order of its columns.
TAIL_SERIES = ("θ3 [deg]", "θ5 [deg]", "carrier speed [rad/s]")
SYMMETRY_LOG = "symmetry"
GOAL_ENTITY = f"{FISH_ROOT}/goal"

# visualization_msgs/Marker's type and action values (from its definition; a test compares).
ARROW, CUBE, SPHERE, CYLINDER = 0, 1, 2, 3
LINE_STRIP, LINE_LIST, CUBE_LIST, SPHERE_LIST, POINTS = 4, 5, 6, 7, 8
ADD, DELETE, DELETEALL = 0, 2, 3
_SINGLE_SHAPES = frozenset({CUBE, SPHERE, CYLINDER})
_POINT_LISTS = frozenset({CUBE_LIST, SPHERE_LIST, POINTS})

#: The goal as drawn: a disc and a heading stroke.
GOAL_COLOUR: Colour = (0.85, 0.2, 0.85, 1.0)
GOAL_DIAMETER_M = 0.06
GOAL_HEADING_M = 0.15
#: Log levels of the symmetry verdicts (Rerun's TextLog levels). NOT_JUDGED (a beat with a gap in
#: tail/state) is a WARN, as on /diagnostics: the monitor's input status warns about the gap, and
#: beats not judged before any judged one are a WARN there; DEBUG would hide it in the view.
VERDICT_LEVELS = {"OK": "INFO", "WARN": "WARN", "ERROR": "ERROR", "NOT_JUDGED": "WARN"}


@dataclasses.dataclass(frozen=True)
class Lines:
    """Polylines of one entity: each strip ``(n, 2)`` is drawn joined in order."""

    entity: str
    strips: tuple[FloatArray, ...]
    colour: Colour
    width_m: float


@dataclasses.dataclass(frozen=True)
class Points:
    """Discs of one entity at ``positions`` ``(n, 2)``."""

    entity: str
    positions: FloatArray
    colour: Colour
    diameter_m: float


@dataclasses.dataclass(frozen=True)
class Shapes:
    """The lines and discs of one drawing (a marker array), drawn as one entity.

    Every strip and every disc keeps its colour and size; a browser's viewer takes data in per
    entity and batch, so one array costs it one message instead of one per marker
    (docs/visualisation.md, "Keeping up").
    """

    entity: str
    lines: tuple[Lines, ...]
    points: tuple[Points, ...]


@dataclasses.dataclass(frozen=True)
class Series:
    """Samples of plotted quantities: values ``(n,)`` or ``(n, k)`` (k series) at times (s)."""

    entity: str
    times_s: FloatArray
    values: FloatArray
    #: The series' names, one per column (empty: the entity's names stay as they are).
    names: tuple[str, ...] = ()


@dataclasses.dataclass(frozen=True)
class Text:
    """One line of a text log, with a level (INFO, WARN, ERROR, DEBUG)."""

    entity: str
    text: str
    level: str


@dataclasses.dataclass(frozen=True)
class Clear:
    """Remove ``entity`` and everything under it from the picture."""

    entity: str


Primitive = Lines | Points | Shapes | Series | Text | Clear


def merged(primitives: Iterable[Primitive], root: str) -> list[Primitive]:
    """The Lines and Points of one drawing as one :class:`Shapes` at ``root/drawing``, last.

    Clears of single markers are left out: the drawing is replaced as a whole each time.

    >>> dot = Points("tail/joints", np.zeros((2, 2)), (1.0, 1.0, 1.0, 1.0), 0.01)
    >>> [type(p).__name__ for p in merged([Clear("tail"), dot, Clear("tail/joints")], "tail")]
    ['Clear', 'Shapes']
    """
    primitives = list(primitives)
    lines = tuple(p for p in primitives if isinstance(p, Lines))
    points = tuple(p for p in primitives if isinstance(p, Points))
    rest: list[Primitive] = [p for p in primitives if isinstance(p, Series | Text)
            or (isinstance(p, Clear) and p.entity == root)]  # fmt: skip
    return rest + ([Shapes(f"{root}/drawing", lines, points)] if lines or points else [])


def stamp_seconds(header: Any) -> float:
    """A std_msgs/Header's stamp in seconds."""
    return int(header.stamp.sec) + int(header.stamp.nanosec) * 1e-9


def entity_name(root: str, namespace: str, marker_id: int) -> str:
    """The entity of one marker: ``root/namespace`` (``/id`` unless 0), as RViz keys them.

    >>> entity_name("tail", "tip trail", 0), entity_name("fish", "", 3)
    ('tail/tip_trail', 'fish/marker/3')
    """
    part = re.sub(r"[^A-Za-z0-9_-]", "_", namespace) or "marker"
    return f"{root}/{part}" if marker_id == 0 else f"{root}/{part}/{marker_id}"


def _colour(message: Any) -> Colour:
    return (float(message.r), float(message.g), float(message.b), float(message.a))


def _pose_transform(pose: Any) -> tuple[float, float, float]:
    """(x, y, yaw) of a marker's pose in the plane (a turn about z; tilts are not drawn)."""
    q = pose.orientation
    yaw = math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))
    return float(pose.position.x), float(pose.position.y), yaw


def _placed(points: FloatArray, pose: Any) -> FloatArray:
    x, y, yaw = _pose_transform(pose)
    if x == 0.0 and y == 0.0 and yaw == 0.0:
        return points
    c, s = math.cos(yaw), math.sin(yaw)
    turned = points @ np.array([[c, s], [-s, c]])
    return turned + np.array([x, y])


def marker_primitives(array: Any, root: str) -> tuple[float | None, list[Primitive]]:
    """The primitives of a visualization_msgs/MarkerArray, and its stamp (None if it has none).

    Line strips, line lists, point and sphere lists, and single spheres, cubes and cylinders (as
    discs at their pose) are drawn in the plane; other kinds (arrows, text, meshes) are skipped.
    DELETEALL clears ``root``, DELETE the marker's entity.
    """
    primitives: list[Primitive] = []
    stamp: float | None = None
    for marker in array.markers:
        if stamp is None and (marker.header.stamp.sec or marker.header.stamp.nanosec):
            stamp = stamp_seconds(marker.header)
        entity = entity_name(root, marker.ns, int(marker.id))
        action = int(marker.action)
        if action == DELETEALL:
            primitives.append(Clear(root))
            continue
        if action == DELETE:
            primitives.append(Clear(entity))
            continue
        kind = int(marker.type)
        colour = _colour(marker.color)
        size = float(marker.scale.x)
        if kind in _SINGLE_SHAPES:
            centre = _placed(np.zeros((1, 2)), marker.pose)
            primitives.append(Points(entity, centre, colour, size))
            continue
        if kind not in (LINE_STRIP, LINE_LIST) and kind not in _POINT_LISTS:
            continue
        points = np.array([(p.x, p.y) for p in marker.points], dtype=np.float64).reshape(-1, 2)
        points = _placed(points, marker.pose)
        if kind == LINE_STRIP:
            primitives.append(Lines(entity, (points,), colour, size))
        elif kind == LINE_LIST:
            pairs = points[: len(points) // 2 * 2].reshape(-1, 2, 2)
            primitives.append(Lines(entity, tuple(pairs), colour, size))
        else:
            primitives.append(Points(entity, points, colour, size))
    return stamp, primitives


class TailPlots:
    """tail/state samples gathered for the plots: theta3 (theta5) in degrees, carrier speed.

    :meth:`add` keeps three floats per message, at most ``rate_hz`` messages a second by their
    stamps (0: all; :class:`~fishtail_bringup.view_pacing.RateLimit`); :meth:`flush` hands them
    over as one :class:`Series` (one send, not one per sample): theta3, theta5 and the carrier
    speed, without theta5 where it is not a number (mechanism 1).
    """

    def __init__(self, rate_hz: float = 0.0) -> None:
        """Start empty."""
        self.limit = RateLimit(rate_hz)
        #: The stamp of the newest sample handed over by :meth:`flush` (None before any).
        self.newest_s: float | None = None
        self._times: list[float] = []
        self._theta3: list[float] = []
        self._theta5: list[float] = []
        self._speed: list[float] = []

    def add(self, state: Any) -> bool:
        """Keep one fishtail_msgs/TailState's plotted values, unless the rate is reached."""
        stamp = stamp_seconds(state.header)
        if not self.limit.admit(stamp):
            return False
        self._times.append(stamp)
        self._theta3.append(math.degrees(state.theta3))
        self._theta5.append(math.degrees(state.theta5))  # NaN for mechanism 1
        self._speed.append(float(state.motor_velocity))
        return True

    def __len__(self) -> int:
        """Samples waiting for :meth:`flush`."""
        return len(self._times)

    def flush(self) -> list[Primitive]:
        """The gathered samples as series; then empty."""
        if not self._times:
            return []
        times = np.array(self._times)
        self.newest_s = float(times.max())
        columns = [self._theta3, self._theta5, self._speed]
        names: tuple[str, ...] = TAIL_SERIES
        if not np.isfinite(self._theta5).all():
            columns, names = [self._theta3, self._speed], (TAIL_SERIES[0], TAIL_SERIES[2])
        series = Series(TAIL_PLOT, times, np.array(columns).T, names)
        for values in (self._times, self._theta3, self._theta5, self._speed):
            values.clear()
        return [series]


def symmetry_primitives(report: Any) -> tuple[float, list[Primitive]]:
    """A fishtail_msgs/SymmetryReport as one line of the verdict log, as the console words it."""
    name = VERDICT_NAMES.get(int(report.verdict), str(report.verdict))
    text = verdict_text(int(report.beat_index), int(report.verdict), report.message)
    return stamp_seconds(report.header), [
        Text(SYMMETRY_LOG, text, VERDICT_LEVELS.get(name, "INFO"))
    ]


def goal_primitives(pose_stamped: Any) -> tuple[float, list[Primitive]]:
    """A geometry_msgs/PoseStamped goal: a disc at its position and a stroke along its heading.

    Drawn in the fish's picture (``world``) whatever its frame_id says.
    """
    x, y, yaw = _pose_transform(pose_stamped.pose)
    tip = (x + GOAL_HEADING_M * math.cos(yaw), y + GOAL_HEADING_M * math.sin(yaw))
    return stamp_seconds(pose_stamped.header), [
        Points(GOAL_ENTITY, np.array([[x, y]]), GOAL_COLOUR, GOAL_DIAMETER_M),
        Lines(f"{GOAL_ENTITY}/heading", (np.array([[x, y], tip]),), GOAL_COLOUR, 0.01),
    ]


def spec_primitives(specs: Iterable[Any], root: str) -> list[Primitive]:
    """The engine's marker specs (:class:`~fishtail_kinematics.engine.markers.MarkerSpec`).

    The same primitives as the kinematics node's ``tail/markers`` give, without the messages.
    """
    primitives: list[Primitive] = []
    for spec in specs:
        entity = entity_name(root, spec.namespace, spec.marker_id)
        points = np.asarray(spec.points, dtype=np.float64).reshape(-1, 2)
        if spec.kind == "line_strip":
            primitives.append(Lines(entity, (points,), spec.colour, float(spec.size_m)))
        elif spec.kind == "line_list":
            pairs = points[: len(points) // 2 * 2].reshape(-1, 2, 2)
            primitives.append(Lines(entity, tuple(pairs), spec.colour, float(spec.size_m)))
        else:
            primitives.append(Points(entity, points, spec.colour, float(spec.size_m)))
    return primitives


def polyline(entity: str, points: Sequence[tuple[float, float]] | FloatArray, colour: Colour,
             width_m: float) -> Lines:  # fmt: skip
    """One strip through ``points``."""
    return Lines(entity, (np.asarray(points, dtype=np.float64).reshape(-1, 2),), colour, width_m)
