"""A recorded run for ``fishtail-swim animate --bag``: what each frame shows, read from a bag.

What is read (topics found as :func:`fishtail_common.bag_reading.pick_topic` finds them, so a suite
recorded under a namespace is read too):

* ``fish/odom``: the pose (X, Y of the centre of mass, yaw psi) in ``world`` and the speed
  |(u, v)| from the twist; required;
* the carrier angle and speed: ``motor_angle``/``motor_velocity`` of ``tail/state``, or the carrier
  joint of ``motor/joint_state`` when the bag has no tail/state;
* the pivot shift: the pivot joint of ``pivot/joint_state``, else ``pivot_shift`` of ``tail/state``,
  else none (the tail as designed);
* ``goal_pose``: the goals, each kept once (the console sends its goal again every second).

Time: every sample sits at its header stamp; t = 0 at the first ``fish/odom`` stamp. A goal
stamped 0 sits at its receive time. Frame k is at t_k = start + k / fps, up to the end of the
window or the last fish/odom sample, whichever comes first.

Interpolation by time (:func:`frame_values`): a frame's value is linear between the last sample
at or before t_k and the first after it, angles along the shorter way round. Where those two are
more than ``gap_s`` apart (a gap in the recording), the frame has no value (NaN): the fish, or the
linkage, is not drawn, and the path is broken there. A frame beyond a topic's first or last sample
takes that sample if it is within half a frame interval, else it has none.

Memory is bounded by the frame count, not the bag's length: messages are deserialised one at a
time (:class:`~fishtail_common.bag_reading.BagFile`) and each topic keeps, for every frame, only
the sample before and the sample after it (:class:`Brackets`, 2 × 5 numbers a frame for the pose);
the path keeps at most :data:`PATH_POINTS_PER_FRAME` points a frame interval (plus one break a gap);
goals at most :data:`MAX_GOALS`. A window (``--start``/``--duration``) is read from a few seconds
before to a few after it (by receive time), not the whole bag; goal_pose alone is read through the
whole bag (the goal current at the window's start may have been sent long before).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from fishtail_common.bag_reading import BagError, BagFile, pick_topic, stamp_ns, yaw_of_quaternion
from fishtail_common.interface import (
    CARRIER_JOINT,
    FISH_ODOM,
    GOAL_POSE,
    MECHANISM_CODES,
    MOTOR_JOINT_STATE,
    PIVOT_JOINT,
    PIVOT_JOINT_STATE,
    TAIL_STATE,
)
from fishtail_plant.fish.fish import FloatArray

#: Consecutive fish/odom samples further apart than this are a gap (50 samples at the simulator's
#: 200 Hz, 5 frames at 20 fps).
DEFAULT_GAP_S = 0.25
#: The path keeps at most this many samples per frame interval (C moves well under a pixel
#: between them).
PATH_POINTS_PER_FRAME = 4
#: Distinct goals kept; later ones are ignored with a note.
MAX_GOALS = 1000
#: How far beyond the window (by receive time) messages are read: the topics' latencies differ.
READ_MARGIN_S = 5.0
#: Goals closer than this to the previous one are the same goal sent again.
SAME_GOAL_M = 1e-6

MECHANISM_OF_CODE = {code: name for name, code in MECHANISM_CODES.items()}
_ODOM_COLUMNS = ("x", "y", "psi", "u", "v")


class Brackets:
    """For each frame time, the last sample at or before it and the first after it.

    Samples are added in time order (:meth:`add`); one at or before the previous is dropped and
    counted in :attr:`dropped` (a repeated stamp, or one out of order). Arrays of NaN where a frame
    has no such sample.
    """

    def __init__(self, frame_time_s: FloatArray, width: int) -> None:
        """Brackets of samples of ``width`` values at ``frame_time_s`` (increasing)."""
        frames = frame_time_s.size
        self.frame_time_s = frame_time_s
        self.before_t = np.full(frames, np.nan)
        self.before = np.full((frames, width), np.nan)
        self.after_t = np.full(frames, np.nan)
        self.after = np.full((frames, width), np.nan)
        self.count = 0
        self.dropped = 0
        self.first_t = math.nan
        self.last_t = -math.inf
        self._last = np.full(width, np.nan)
        self._next = 0  # the first frame whose "after" is not set yet

    def add(self, time_s: float, values: Sequence[float]) -> None:
        """One sample: ``values`` at ``time_s``."""
        if not time_s > self.last_t:
            self.dropped += 1
            return
        k = self._next
        times = self.frame_time_s
        while k < times.size and times[k] < time_s:
            if self.count:
                self.before_t[k] = self.last_t
                self.before[k] = self._last
            self.after_t[k] = time_s
            self.after[k] = values
            k += 1
        self._next = k
        if not self.count:
            self.first_t = time_s
        self.count += 1
        self.last_t = time_s
        self._last = np.asarray(values, dtype=np.float64)

    def finish(self) -> None:
        """After the last sample: the frames at or after it have it as their "before"."""
        if self.count:
            rest = slice(self._next, None)
            self.before_t[rest] = self.last_t
            self.before[rest] = self._last
        self._next = self.frame_time_s.size


def frame_values(
    brackets: Brackets, gap_s: float, edge_s: float, angle_columns: Sequence[int] = ()
) -> FloatArray:
    """The value of every frame, ``(F, width)``: linear in time between its bracketing samples.

    NaN where the samples are more than ``gap_s`` apart, or where one is missing and the other is
    more than ``edge_s`` from the frame. ``angle_columns`` are interpolated the shorter way round.
    """
    t = brackets.frame_time_s
    before, after = brackets.before, brackets.after
    span = brackets.after_t - brackets.before_t
    with np.errstate(invalid="ignore", divide="ignore"):
        fraction = np.where(span > 0.0, (t - brackets.before_t) / span, 0.0)
    step = after - before
    for column in angle_columns:
        step[:, column] = np.angle(np.exp(1j * step[:, column]))
    values = before + fraction[:, None] * step
    values[~(span <= gap_s)] = np.nan
    # The ends of a topic: the sample itself, if it is close enough.
    only_before = np.isnan(brackets.after_t) & (t - brackets.before_t <= edge_s)
    only_after = np.isnan(brackets.before_t) & (brackets.after_t - t <= edge_s)
    values[only_before] = before[only_before]
    values[only_after] = after[only_after]
    return values


def interpolate_samples(
    sample_time_s: FloatArray,
    samples: FloatArray,
    frame_time_s: FloatArray,
    gap_s: float = DEFAULT_GAP_S,
    edge_s: float = 0.0,
    angle_columns: Sequence[int] = (),
) -> FloatArray:
    """:func:`frame_values` of samples given as arrays, ``(K,)`` times and ``(K, width)`` values."""
    brackets = Brackets(np.asarray(frame_time_s, dtype=np.float64), samples.shape[1])
    for time_s, values in zip(sample_time_s.tolist(), samples, strict=True):
        brackets.add(time_s, values)
    brackets.finish()
    return frame_values(brackets, gap_s, edge_s, angle_columns)


class _Path:
    """C's path in the window, decimated in time, with a NaN row after the last sample of a gap."""

    def __init__(self, start_s: float, end_s: float, step_s: float, gap_s: float) -> None:
        self.start_s, self.end_s, self.step_s, self.gap_s = start_s, end_s, step_s, gap_s
        self.time_s: list[float] = []
        self.points: list[tuple[float, float]] = []
        self.gaps = 0
        self._last: tuple[float, float, float] | None = None  # the previous sample (t, x, y)

    def _keep(self, time_s: float, x: float, y: float) -> None:
        if not self.time_s or time_s > self.time_s[-1] or math.isnan(self.points[-1][0]):
            self.time_s.append(time_s)
            self.points.append((x, y))

    def add(self, time_s: float, x: float, y: float) -> None:
        """The next fish/odom sample (after the previous one)."""
        last = self._last
        self._last = (time_s, x, y)
        if time_s < self.start_s:
            return
        if time_s > self.end_s:
            if last is not None and self.start_s <= last[0] <= self.end_s:
                self._keep(*last)
            return
        if last is not None and time_s - last[0] > self.gap_s:
            if last[0] >= self.start_s:
                self._keep(*last)
                self.time_s.append(last[0])
                self.points.append((math.nan, math.nan))
            self.gaps += 1
            self._keep(time_s, x, y)
        elif not self.time_s or time_s - self.time_s[-1] >= self.step_s:
            self._keep(time_s, x, y)

    def finish(self) -> tuple[FloatArray, FloatArray]:
        """The kept times ``(K,)`` and points ``(K, 2)``, the window's last sample included."""
        if self._last is not None and self.start_s <= self._last[0] <= self.end_s:
            self._keep(*self._last)
        return np.asarray(self.time_s, dtype=np.float64), np.asarray(
            self.points, dtype=np.float64
        ).reshape(-1, 2)


@dataclasses.dataclass
class RecordedRun:
    """What the frames of a recorded run show; frame arrays ``(F,)``, NaN where not recorded."""

    source: Path
    time_s: FloatArray  # frame times, s since the first fish/odom stamp
    x_m: FloatArray
    y_m: FloatArray
    psi_rad: FloatArray
    speed_m_s: FloatArray
    carrier_angle_rad: FloatArray  # NaN: no linkage drawn
    carrier_velocity_rad_s: FloatArray
    pivot_shift_m: FloatArray  # 0 where none was recorded
    path_time_s: FloatArray  # (K,) decimated, a NaN row after each gap's last sample
    path: FloatArray  # (K, 2)
    goal_time_s: FloatArray  # (G,) when each goal was first sent
    goals: FloatArray  # (G, 2)
    carrier_source: str
    pivot_source: str
    mechanism: str | None  # tail/state's, if recorded
    odometry_samples: int  # fish/odom samples in the window
    gaps: int  # gaps of fish/odom in the window
    end_s: float  # the last fish/odom stamp
    notes: list[str] = dataclasses.field(default_factory=list)


def _joint_index(names: Sequence[str], joint: str) -> int | None:
    names = list(names)
    if joint in names:
        return names.index(joint)
    return 0 if len(names) == 1 else None


def _joint_sample(message: Any, joint: str) -> tuple[float, float] | None:
    index = _joint_index(message.name, joint)
    if index is None or index >= len(message.position):
        return None
    velocity = float(message.velocity[index]) if index < len(message.velocity) else 0.0
    return float(message.position[index]), velocity if math.isfinite(velocity) else 0.0


def _count(connections: Sequence[Any], topic: str | None) -> int:
    return sum(int(c.msgcount) for c in connections if c.topic == topic)


def frame_count(start_s: float, end_s: float, fps: float) -> int:
    """Frames at start + k / fps up to ``end_s`` (included when it falls on a frame)."""
    return math.floor((end_s - start_s) * fps * (1.0 + 1e-12) + 1e-9) + 1


def read_recorded_run(
    path: str | Path,
    fps: float,
    start_s: float = 0.0,
    duration_s: float | None = None,
    gap_s: float = DEFAULT_GAP_S,
    namespace: str | None = None,
    max_frames: int | None = None,
) -> RecordedRun:
    """Read a bag into the frames of an animation at ``fps``; :class:`BagError` if it cannot.

    The window starts ``start_s`` after the first fish/odom sample and lasts ``duration_s`` (None:
    to the last fish/odom sample). ``max_frames``: refuse (BagError) a window of more frames,
    before reading it when the bag's length tells.
    """
    path = Path(path)
    with BagFile(path) as bag:
        connections = bag.connections
        odom_topic = pick_topic(connections, FISH_ODOM.type, FISH_ODOM.name, namespace)
        # t = 0: the first fish/odom sample; its receive time maps stamps to the bag's clock.
        odom_connections = bag.connections_of(odom_topic)
        peek = bag.messages(odom_connections)
        try:
            _, first_receive_ns, first = next(peek)
        except StopIteration:
            where = f" in namespace {namespace!r}" if namespace is not None else ""
            raise BagError(
                f"{path}: no fish/odom messages{where}, which the animation draws the fish from "
                f"(topics: {bag.listing()})"
            ) from None
        finally:
            peek.close()
        state_topic = pick_topic(connections, TAIL_STATE.type, TAIL_STATE.name, namespace)
        joint_topic = pick_topic(
            connections, MOTOR_JOINT_STATE.type, MOTOR_JOINT_STATE.name, namespace, any_name=False
        )
        pivot_topic = pick_topic(
            connections, PIVOT_JOINT_STATE.type, PIVOT_JOINT_STATE.name, namespace, any_name=False
        )
        goal_topic = pick_topic(connections, GOAL_POSE.type, GOAL_POSE.name, namespace)
        if not _count(connections, state_topic):
            state_topic = None
        if state_topic is not None or not _count(connections, joint_topic):
            joint_topic = None
        if not _count(connections, pivot_topic):
            pivot_topic = None

        origin_ns = stamp_ns(first)
        receive_offset_ns = first_receive_ns - origin_ns
        bag_end_s = (int(bag.reader.end_time) - first_receive_ns) * 1e-9
        end_s = bag_end_s if duration_s is None else start_s + duration_s
        if max_frames is not None and start_s <= bag_end_s:
            # Said before reading: the window as far as the bag's length tells.
            span_s = min(end_s, bag_end_s) - start_s
            estimate = frame_count(start_s, start_s + span_s, fps)
            if estimate > max_frames:
                raise BagError(
                    f"{path}: {span_s:.1f} s of recording from --start {start_s:g} s at --fps "
                    f"{fps:g} is {estimate} frames, but a GIF takes 2 to {max_frames}: choose a "
                    "shorter window (--start, --duration) or lower --fps"
                )
        # Frames up to the bag's end (and a little beyond: stamps lag receive times); those after
        # the last fish/odom sample are dropped once it is known.
        frames = frame_count(start_s, max(start_s, min(end_s, bag_end_s + 1.0)), fps)
        frame_time_s = start_s + np.arange(frames, dtype=np.float64) / fps

        odometry = Brackets(frame_time_s, len(_ODOM_COLUMNS))
        carrier = Brackets(frame_time_s, 2)
        pivot = Brackets(frame_time_s, 1)
        pivot_from_state = pivot_topic is None
        path_points = _Path(start_s, end_s, 1.0 / (PATH_POINTS_PER_FRAME * fps), gap_s)
        mechanisms: dict[int, int] = {}
        no_carrier_joint = 0

        def seconds(stamp: int) -> float:
            return (stamp - origin_ns) * 1e-9

        read = bag.connections_of(odom_topic, state_topic, joint_topic, pivot_topic)
        window_start = first_receive_ns + round((start_s - READ_MARGIN_S) * 1e9)
        window_stop = first_receive_ns + round((end_s + READ_MARGIN_S) * 1e9)
        for connection, _, message in bag.messages(
            read, start_ns=max(window_start, 0) if start_s > READ_MARGIN_S else None,
            stop_ns=window_stop if duration_s is not None else None,
        ):  # fmt: skip
            topic = connection.topic
            t = seconds(stamp_ns(message))
            if topic == odom_topic:
                pose = message.pose.pose
                q = pose.orientation
                twist = message.twist.twist.linear
                x, y = float(pose.position.x), float(pose.position.y)
                psi = yaw_of_quaternion(float(q.x), float(q.y), float(q.z), float(q.w))
                if t > odometry.last_t:
                    path_points.add(t, x, y)
                odometry.add(t, (x, y, psi, float(twist.x), float(twist.y)))
            elif topic == state_topic:
                carrier.add(t, (float(message.motor_angle), float(message.motor_velocity)))
                code = int(message.mechanism)
                mechanisms[code] = mechanisms.get(code, 0) + 1
                if pivot_from_state and hasattr(message, "pivot_shift"):
                    pivot.add(t, (float(message.pivot_shift),))
            elif topic == joint_topic:
                sample = _joint_sample(message, CARRIER_JOINT)
                if sample is None:
                    no_carrier_joint += 1
                else:
                    carrier.add(t, sample)
            elif topic == pivot_topic:
                sample = _joint_sample(message, PIVOT_JOINT)
                if sample is not None:
                    pivot.add(t, sample[:1])
        for brackets in (odometry, carrier, pivot):
            brackets.finish()
        goal_times, goals, goal_notes = _read_goals(bag, goal_topic, origin_ns, receive_offset_ns)

    notes = list(goal_notes)
    last_odom_s = odometry.last_t
    if odometry.count == 0 or last_odom_s < start_s:
        raise BagError(
            f"{path}: --start {start_s:g} s is past the end of fish/odom "
            f"({max(last_odom_s, 0.0):.2f} s after its first sample)"
        )
    count = min(frames, frame_count(start_s, min(end_s, last_odom_s), fps))
    if duration_s is not None and last_odom_s < end_s - 0.5 / fps:
        notes.append(
            f"fish/odom ends {last_odom_s:.2f} s after its first sample: the animation ends there"
        )
    if count < 2:
        raise BagError(
            f"{path}: from --start {start_s:g} s, fish/odom lasts {last_odom_s - start_s:.3f} s, "
            f"not enough for 2 frames at --fps {fps:g}"
        )
    if max_frames is not None and count > max_frames:
        raise BagError(
            f"{path}: the window is {count} frames at --fps {fps:g}, but a GIF takes 2 to "
            f"{max_frames}: choose a shorter window (--start, --duration) or lower --fps"
        )
    edge_s = 0.5 / fps
    pose = frame_values(odometry, gap_s, edge_s, angle_columns=(2,))[:count]
    if not np.any(np.isfinite(pose[:, 0])):
        raise BagError(
            f"{path}: no fish/odom sample within --gap {gap_s:g} s of any frame of the window"
        )
    carrier_values = frame_values(carrier, gap_s, edge_s, angle_columns=(0,))[:count]
    if pivot.count:
        shift = frame_values(pivot, gap_s, edge_s)[:count, 0]
        # Between pivot samples too far apart, the pivot held where it was last seen.
        held = frame_values(pivot, math.inf, math.inf)[:count, 0]
        shift = np.where(np.isnan(shift), held, shift)
        shift = np.where(np.isnan(shift), 0.0, shift)
    else:
        shift = np.zeros(count)

    if state_topic is not None:
        carrier_source = f"motor_angle of {state_topic}"
    elif joint_topic is not None:
        carrier_source = f"{CARRIER_JOINT} of {joint_topic}"
    else:
        carrier_source = "none (no tail/state or motor/joint_state): the linkage is not drawn"
    if pivot_topic is not None:
        pivot_source = f"{PIVOT_JOINT} of {pivot_topic}"
    elif pivot.count:
        pivot_source = f"pivot_shift of {state_topic}"
    else:
        pivot_source = "none (the tail as designed)"
    mechanism = None
    if mechanisms:
        code = max(mechanisms, key=lambda c: mechanisms[c])
        mechanism = MECHANISM_OF_CODE.get(code)
    if no_carrier_joint:
        notes.append(f"{no_carrier_joint} {joint_topic} messages without {CARRIER_JOINT} ignored")
    for name, brackets in (("fish/odom", odometry), ("carrier", carrier), ("pivot", pivot)):
        if brackets.dropped:
            notes.append(f"{brackets.dropped} {name} samples repeated or out of order ignored")
    path_time, path_xy = path_points.finish()
    return RecordedRun(
        source=path,
        time_s=frame_time_s[:count],
        x_m=pose[:, 0],
        y_m=pose[:, 1],
        psi_rad=pose[:, 2],
        speed_m_s=np.hypot(pose[:, 3], pose[:, 4]),
        carrier_angle_rad=carrier_values[:, 0],
        carrier_velocity_rad_s=carrier_values[:, 1],
        pivot_shift_m=shift,
        path_time_s=path_time,
        path=path_xy,
        goal_time_s=goal_times,
        goals=goals,
        carrier_source=carrier_source,
        pivot_source=pivot_source,
        mechanism=mechanism,
        odometry_samples=odometry.count,
        gaps=path_points.gaps,
        end_s=last_odom_s,
        notes=notes,
    )


def _read_goals(
    bag: BagFile, topic: str | None, origin_ns: int, receive_offset_ns: int
) -> tuple[FloatArray, FloatArray, list[str]]:
    """Each distinct goal (a goal sent again is one) and when it was first sent, whole bag."""
    times: list[float] = []
    goals: list[tuple[float, float]] = []
    notes: list[str] = []
    ignored = 0
    if topic is not None:
        for _, receive_ns, message in bag.messages(bag.connections_of(topic)):
            stamp = stamp_ns(message)
            stamp = stamp if stamp else receive_ns - receive_offset_ns
            position = message.pose.position
            goal = (float(position.x), float(position.y))
            if not all(math.isfinite(v) for v in goal):
                continue
            if goals and math.dist(goal, goals[-1]) <= SAME_GOAL_M:
                continue
            if len(goals) >= MAX_GOALS:
                ignored += 1
                continue
            times.append((stamp - origin_ns) * 1e-9)
            goals.append(goal)
    if ignored:
        notes.append(f"more than {MAX_GOALS} goals: {ignored} later ones not drawn")
    order = np.argsort(np.asarray(times), kind="stable")
    return (
        np.asarray(times, dtype=np.float64)[order],
        np.asarray(goals, dtype=np.float64).reshape(-1, 2)[order],
        notes,
    )
