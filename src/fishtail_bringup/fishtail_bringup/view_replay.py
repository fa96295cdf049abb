"""A recorded bag as the live view's primitives, in the order and at the pace it was recorded.

``fishtail-record`` records the suite's state, not the RViz markers, so the linkage and the fish
are redrawn from ``tail/state`` and ``fish/odom`` as the nodes draw them (or from the markers, if
the bag holds them). No rclpy here: :class:`~fishtail_common.bag_reading.BagFile` reads the bag.
What is drawn from what: docs/visualisation.md ("A bag").
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from fishtail_bringup.view_scene import (
    FISH_ROOT,
    TAIL_ROOT,
    Colour,
    Primitive,
    TailPlots,
    goal_primitives,
    marker_primitives,
    merged,
    polyline,
    spec_primitives,
    stamp_seconds,
    symmetry_primitives,
)
from fishtail_common.bag_reading import BagFile, topic_under, yaw_of_quaternion
from fishtail_common.interface import (
    FISH_MARKERS,
    FISH_ODOM,
    GOAL_POSE,
    MECHANISM_CODES,
    TAIL_MARKERS,
    TAIL_STATE,
    TAIL_SYMMETRY,
)
from fishtail_common.parameter_files import load_parameter_file
from fishtail_kinematics.engine.markers import build_markers
from fishtail_kinematics.engine.mechanisms import Tail, make_tail
from fishtail_kinematics.engine.parameters import geometry_from_parameters, geometry_parameters_in
from fishtail_plant.fish.outline import body_outline, body_to_world, tail_to_body
from fishtail_plant.values import read_fish_values

#: The kinematics node's default marker rate and trail (markers_rate_hz, markers_trail_length).
TAIL_FRAME_RATE_HZ = 30.0
TAIL_TRAIL_LENGTH = 90
#: The simulator's default marker rate and path (markers_rate_hz, markers_path_length).
FISH_FRAME_RATE_HZ = 10.0
FISH_PATH_LENGTH = 3000
#: How often the gathered plot samples are handed over, in bag time.
PLOT_PERIOD_S = 0.1
#: The simulator's fish/markers colours and line width.
BODY_COLOUR: Colour = (0.2, 0.5, 0.9, 1.0)
PATH_COLOUR: Colour = (0.9, 0.9, 0.2, 0.8)
FISH_TAIL_COLOUR: Colour = (0.9, 0.3, 0.2, 1.0)
FISH_LINE_M = 0.01

MECHANISM_OF_CODE = {code: name for name, code in MECHANISM_CODES.items()}
#: What a replay draws from.
REPLAYED_TOPICS = (TAIL_STATE, TAIL_SYMMETRY, FISH_ODOM, TAIL_MARKERS, FISH_MARKERS, GOAL_POSE)


class ReplayError(Exception):
    """The bag or a parameter file cannot be replayed; the message is one line for the user."""


class TailFromState:
    """The kinematics node's markers redrawn from tail/state with a geometry of our own."""

    def __init__(self, tail: Tail, trail_length: int = TAIL_TRAIL_LENGTH) -> None:
        """Draw ``tail``, keeping ``trail_length`` tip positions (one per drawn frame)."""
        self.tail = tail
        self.trail: deque[tuple[float, float]] = deque(maxlen=trail_length)

    def primitives(self, state_message: Any) -> list[Primitive]:
        """The linkage at the message's carrier angle, with the trail up to it."""
        state = self.tail.solve(
            float(state_message.motor_angle), float(state_message.motor_velocity)
        )
        self.trail.append((float(state.tip_x), float(state.tip_y)))
        return spec_primitives(build_markers(self.tail, state, list(self.trail)), TAIL_ROOT)


class FishFromOdometry:
    """The simulator's fish/markers redrawn from fish/odom and the fish's parameters."""

    def __init__(
        self,
        body_length_m: float,
        body_diameter_m: float,
        tail_origin_offset_m: float,
        path_length: int = FISH_PATH_LENGTH,
    ) -> None:
        """The hull of that length and diameter, its tail's ring-gear centre behind C."""
        self.outline = body_outline(body_length_m, body_diameter_m)
        self.tail_origin_offset_m = tail_origin_offset_m
        self.path: deque[tuple[float, float]] = deque(maxlen=path_length)

    def primitives(self, odometry: Any, tip: tuple[float, float] | None) -> list[Primitive]:
        """Hull, path (extended by this pose) and tail (O to ``tip``, tail frame) in ``world``."""
        pose = odometry.pose.pose
        x, y = float(pose.position.x), float(pose.position.y)
        q = pose.orientation
        psi = yaw_of_quaternion(float(q.x), float(q.y), float(q.z), float(q.w))
        self.path.append((x, y))
        drawn: list[Primitive] = [
            polyline(f"{FISH_ROOT}/body", body_to_world(self.outline, x, y, psi), BODY_COLOUR,
                     FISH_LINE_M),
            polyline(f"{FISH_ROOT}/path", np.array(self.path), PATH_COLOUR, FISH_LINE_M),
        ]  # fmt: skip
        if tip is not None:
            tail = tail_to_body(np.array([[0.0, 0.0], tip]), self.tail_origin_offset_m)
            drawn.append(
                polyline(f"{FISH_ROOT}/tail", body_to_world(tail, x, y, psi), FISH_TAIL_COLOUR,
                         FISH_LINE_M)
            )  # fmt: skip
        return drawn


def tail_from_parameter_file(path: Path) -> Tail:
    """The engine's tail for the geometry of a parameter file.

    Raises:
        ReplayError: a file that cannot be read or holds no geometry that assembles.
    """
    try:
        values = load_parameter_file(path)
        return make_tail(geometry_from_parameters(geometry_parameters_in(values)))
    except Exception as error:  # noqa: BLE001 - ParameterError, ValueError: one line for the user
        raise ReplayError(f"{path}: {error}") from None


def fish_from_parameter_file(path: Path) -> FishFromOdometry:
    """The fish's drawing from a fish parameter file (config/fish.yaml).

    Raises:
        ReplayError: a file that cannot be read or lacks the hull's parameters.
    """
    try:
        values = read_fish_values(path)
        return FishFromOdometry(
            values["body_length_m"], values["body_diameter_m"], values["tail_origin_offset_m"]
        )
    except Exception as error:  # noqa: BLE001 - OSError, KeyError, ValueError: one line
        raise ReplayError(f"{path}: {error}") from None


class BagReplay:
    """The messages of a bag, turned into timed primitives (:meth:`events`)."""

    def __init__(
        self,
        path: Path,
        tail_config: Path | None,
        fish: FishFromOdometry,
        default_config: Any,
        namespace: str = "",
    ) -> None:
        """Open nothing yet; ``default_config(mechanism)`` names a mechanism's parameter file.

        ``tail_config`` (or, without it, the default file of the mechanism that tail/state
        records) gives the geometry the linkage is drawn with; the topics are those under
        ``namespace``.
        """
        self.path = path
        self.tail_config = tail_config
        self.default_config = default_config
        self.fish = fish
        self.namespace = namespace
        self.tail: TailFromState | None = None
        self.notes: list[str] = []

    def _tail_for(self, state_message: Any) -> TailFromState:
        if self.tail is None:
            mechanism = MECHANISM_OF_CODE.get(int(state_message.mechanism))
            config = self.tail_config
            if config is None:
                if mechanism is None:
                    raise ReplayError(f"tail/state has an unknown mechanism code "
                                      f"{state_message.mechanism}: give --config")  # fmt: skip
                config = Path(self.default_config(mechanism))
            self.tail = TailFromState(tail_from_parameter_file(config))
            self.notes.append(f"linkage drawn with the geometry of {config}")
        return self.tail

    def events(self) -> Iterator[tuple[float, float | None, list[Primitive]]]:
        """(bag time s, stamp s or None, primitives), in the bag's order.

        The bag time is the receive time rosbag2 stores, from which the replay takes its pace;
        the stamp places the primitives on the view's time line.

        Raises:
            ReplayError: an unreadable bag, one with nothing to show, or a tail/state whose
                mechanism has no parameter file to draw it with.
        """
        with BagFile(self.path, error=ReplayError) as bag:
            names: dict[str, str] = {}  # the bag's topic -> the suite's name for it
            for topic in REPLAYED_TOPICS:
                picked = bag.pick(topic, self.namespace)
                if picked is not None:
                    names[picked] = topic.name
            if not names:
                wanted = sorted(topic_under(self.namespace, t.name) for t in REPLAYED_TOPICS)
                raise ReplayError(
                    f"{self.path}: nothing to show (topics: {bag.listing()}; wanted "
                    f"{', '.join(wanted)})"
                )
            yield from self._events(bag.messages(bag.connections_of(*names)), names)

    def _events(
        self, messages: Iterable[tuple[Any, int, Any]], names: dict[str, str]
    ) -> Iterator[tuple[float, float | None, list[Primitive]]]:
        """The primitives of ``messages`` (connection, receive ns, message) of the topics named."""
        draw_tail = TAIL_MARKERS.name not in names.values()
        draw_fish = FISH_MARKERS.name not in names.values()
        plots = TailPlots()
        next_plot = next_tail = next_fish = -math.inf
        tip: tuple[float, float] | None = None
        bag_s = 0.0
        for connection, timestamp_ns, message in messages:
            bag_s = timestamp_ns * 1e-9
            name = names[connection.topic]
            if name == TAIL_STATE.name:
                plots.add(message)
                tip = (float(message.tip.x), float(message.tip.y))
                if draw_tail and bag_s >= next_tail:
                    next_tail = bag_s + 1.0 / TAIL_FRAME_RATE_HZ
                    primitives = self._tail_for(message).primitives(message)
                    yield bag_s, stamp_seconds(message.header), merged(primitives, TAIL_ROOT)
                if bag_s >= next_plot:
                    next_plot = bag_s + PLOT_PERIOD_S
                    yield bag_s, None, plots.flush()
            elif name == FISH_ODOM.name:
                if draw_fish and bag_s >= next_fish:
                    next_fish = bag_s + 1.0 / FISH_FRAME_RATE_HZ
                    fish = self.fish.primitives(message, tip)
                    yield bag_s, stamp_seconds(message.header), merged(fish, FISH_ROOT)
            elif name == TAIL_SYMMETRY.name:
                yield (bag_s, *symmetry_primitives(message))
            elif name == GOAL_POSE.name:
                yield (bag_s, *goal_primitives(message))
            else:
                root = TAIL_ROOT if name == TAIL_MARKERS.name else FISH_ROOT
                stamp, primitives = marker_primitives(message, root)
                yield bag_s, stamp, merged(primitives, root)
        yield bag_s, None, plots.flush()
