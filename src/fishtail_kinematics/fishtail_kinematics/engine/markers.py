"""What the RViz markers of the tail show: point lists, kinds, colours and sizes (no ROS here).

:func:`build_markers` turns one solved state into a list of :class:`MarkerSpec`, each one
``visualization_msgs/Marker`` to be, from the tail's own points (``Tail.link_points``), so that
RViz draws exactly what the engine solved; the kinematics node converts them
(:mod:`fishtail_kinematics.nodes.marker_publisher`). Points are (x, y) in metres in the frame at
O. The namespaces: docs/visualisation.md ("RViz").

>>> from fishtail_kinematics.engine.geometry import OscillatoryGeometry
>>> from fishtail_kinematics.engine.mechanisms import OscillatoryTail
>>> tail = OscillatoryTail(OscillatoryGeometry())
>>> specs = build_markers(tail, tail.solve(0.0), [(0.3, 0.0), (0.3, 0.01)])
>>> [spec.namespace for spec in specs]  # doctest: +NORMALIZE_WHITESPACE
['ring', 'guides', 'planet', 'carrier', 'cardan_point', 'links', 'tail_link', 'joints',
 'pivots', 'tip_trail']
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from fishtail_kinematics.engine.geometry import FloatArray, Geometry, LinkageState
from fishtail_kinematics.engine.mechanisms import Tail

LINE_STRIP = "line_strip"
LINE_LIST = "line_list"
SPHERE_LIST = "sphere_list"

#: Segments of the drawn ring; the planet (redrawn every tick) gets fewer.
CIRCLE_SEGMENTS = 72
PLANET_SEGMENTS = 48
#: Namespaces whose markers depend on the geometry only, not on the state.
STATIC_NAMESPACES = frozenset({"ring", "guides", "pivots"})

# RGBA, 0..1.
RING_COLOUR = (0.62, 0.62, 0.66, 1.0)
GUIDE_COLOUR = (0.45, 0.45, 0.5, 0.6)
PLANET_COLOUR = (0.95, 0.7, 0.2, 1.0)
CARRIER_COLOUR = (0.95, 0.55, 0.1, 1.0)
CARDAN_COLOUR = (0.9, 0.15, 0.15, 1.0)
LINK_COLOUR = (0.25, 0.55, 0.95, 1.0)
TAIL_COLOUR = (0.2, 0.8, 0.4, 1.0)
JOINT_COLOUR = (1.0, 1.0, 1.0, 1.0)
PIVOT_COLOUR = (0.1, 0.1, 0.1, 1.0)
TRAIL_COLOUR = (0.3, 0.9, 0.9, 0.8)


class MarkerSpec(NamedTuple):
    """One marker: namespace and id (its identity in RViz), kind, points, colour, size.

    ``kind`` is one of LINE_STRIP (points joined in order), LINE_LIST (pairs of points, one
    segment each) or SPHERE_LIST (one sphere per point). ``size_m`` is the line width or the
    sphere diameter.
    """

    namespace: str
    marker_id: int
    kind: str
    points: FloatArray  # (n, 2)
    colour: tuple[float, float, float, float]
    size_m: float


def _unit_circle(segments: int = CIRCLE_SEGMENTS) -> FloatArray:
    angles = np.linspace(0.0, 2.0 * math.pi, segments + 1)
    return np.stack((np.cos(angles), np.sin(angles)), axis=-1)


_UNIT_CIRCLE = _unit_circle()
_PLANET_CIRCLE = _unit_circle(PLANET_SEGMENTS)


def drawing_scale_m(geometry: Geometry) -> float:
    """Overall size of the linkage: O to the tip of the straight tail, plus the ring."""
    return geometry.pivot_offset_m + geometry.tail_extent_m + geometry.ring_radius_m


def _segments(*pairs: tuple[FloatArray, FloatArray]) -> FloatArray:
    return np.array([point for pair in pairs for point in pair], float).reshape(-1, 2)


def _polyline_segments(polyline: FloatArray) -> FloatArray:
    """A polyline ``(k, 2)`` as LINE_LIST pairs: its points 0-1, 1-2, ..."""
    return np.stack((polyline[:-1], polyline[1:]), axis=1).reshape(-1, 2)


def build_markers(
    tail: Tail,
    state: LinkageState,
    trail: Sequence[tuple[float, float]] | FloatArray = (),
) -> list[MarkerSpec]:
    """The markers of one state of ``tail`` (floats, as the node's scalar path gives them).

    ``trail`` holds the last tip positions, oldest first; it is drawn when it has two or more.
    """
    p = tail.link_points(state)
    ring = tail.geometry.ring_radius_m
    scale = drawing_scale_m(tail.geometry)
    line = scale / 120.0
    joint = scale / 35.0
    ring_diameters = np.array([[0.0, -ring], [0.0, ring], [-ring, 0.0], [ring, 0.0]])
    carrier = _segments((p.origin, p.planet_centre), (p.cardan, p.planet_opposite))
    links = np.concatenate([_polyline_segments(polyline) for polyline in p.drive_links()])
    tail_link = p.tail_link()
    joints = p.moving_joints()
    planet = p.planet_centre + 0.5 * ring * _PLANET_CIRCLE
    # (namespace, kind, points, colour, size); the guides are the two diameters of the ring on
    # which P and the opposite rim point D slide.
    table: list[tuple[str, str, FloatArray, tuple[float, float, float, float], float]] = [
        ("ring", LINE_STRIP, ring * _UNIT_CIRCLE, RING_COLOUR, line),
        ("guides", LINE_LIST, ring_diameters, GUIDE_COLOUR, 0.5 * line),
        ("planet", LINE_STRIP, planet, PLANET_COLOUR, line),
        ("carrier", LINE_LIST, carrier, CARRIER_COLOUR, line),
        ("cardan_point", SPHERE_LIST, p.cardan.reshape(1, 2), CARDAN_COLOUR, 1.4 * joint),
        ("links", LINE_LIST, links, LINK_COLOUR, 1.5 * line),
        ("tail_link", LINE_LIST, tail_link, TAIL_COLOUR, 2.0 * line),
        ("joints", SPHERE_LIST, joints, JOINT_COLOUR, joint),
        ("pivots", SPHERE_LIST, np.array([p.origin, p.pivot_s]), PIVOT_COLOUR, 1.2 * joint),
    ]
    trail_points = np.asarray(trail, float).reshape(-1, 2)
    if len(trail_points) >= 2:
        table.append(("tip_trail", LINE_STRIP, trail_points, TRAIL_COLOUR, line))
    return [
        MarkerSpec(namespace, 0, kind, points, colour, size)
        for namespace, kind, points, colour, size in table
    ]
