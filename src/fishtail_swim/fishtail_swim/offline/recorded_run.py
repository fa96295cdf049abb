"""A recorded run for ``fishtail-swim animate --bag``: what each frame shows, read from a bag.

Reads the pose from ``fish/odom``, the carrier from ``tail/state`` (or ``motor/joint_state``), the
pivot shift and the goals, through :class:`~fishtail_common.bag_reading.BagFile` (the reader
``fishtail-view --bag`` uses too), only the window asked for and in memory bounded by its frame
count (:mod:`~fishtail_swim.offline.frame_sampling`; each topic's messages:
:mod:`~fishtail_swim.offline.recorded_samples`). Topics, time, interpolation, gaps and limits:
docs/swimming-dynamics.md ("Command line", ``animate --bag``).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from fishtail_common.bag_reading import BagError, BagFile, stamp_ns
from fishtail_common.interface import (
    CARRIER_JOINT,
    FISH_ODOM,
    GOAL_POSE,
    MOTOR_JOINT_STATE,
    PIVOT_JOINT,
    PIVOT_JOINT_STATE,
    TAIL_STATE,
)
from fishtail_plant.fish.fish import FloatArray
from fishtail_swim.offline.frame_sampling import (
    DEFAULT_GAP_S,
    Brackets,
    DecimatedPath,
    frame_count,
    frame_values,
    interpolate_samples,
)
from fishtail_swim.offline.recorded_samples import RunClock, TopicSamples, read_goals

__all__ = [
    "DEFAULT_GAP_S",
    "PATH_POINTS_PER_FRAME",
    "READ_MARGIN_S",
    "RecordedRun",
    "frame_count",
    "interpolate_samples",
    "read_recorded_run",
]

#: The path keeps at most this many samples per frame interval (C moves well under a pixel
#: between them).
PATH_POINTS_PER_FRAME = 4
#: How far beyond the window (by receive time) messages are read: the topics' latencies differ.
READ_MARGIN_S = 5.0


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


@dataclasses.dataclass(frozen=True)
class _Topics:
    """The bag's topics a run is read from; None where not recorded (or without messages)."""

    odom: str | None
    state: str | None
    joint: str | None  # only without tail/state, which carries the carrier angle too
    pivot: str | None
    goal: str | None


@dataclasses.dataclass(frozen=True)
class _Window:
    """The frames asked for and the receive times read for them (None: from the start, the end)."""

    start_s: float
    end_s: float  # start + duration, or the bag's end
    frame_time_s: FloatArray  # up to a little beyond the bag's end; cut once fish/odom's is known
    read_start_ns: int | None
    read_stop_ns: int | None


def read_recorded_run(
    path: str | Path,
    fps: float,
    start_s: float = 0.0,
    duration_s: float | None = None,
    gap_s: float = DEFAULT_GAP_S,
    namespace: str | None = None,
    max_frames: int | None = None,
) -> RecordedRun:
    """Read a bag into the frames of an animation at ``fps``.

    The window starts ``start_s`` after the first fish/odom sample and lasts ``duration_s`` (None:
    to the last fish/odom sample).

    Raises:
        BagError: a missing, unreadable or foreign bag, no fish/odom, a window past its end, or
            a window of more than ``max_frames`` frames (said before reading it when the bag's
            length tells).
    """
    path = Path(path)
    with BagFile(path) as bag:
        odom_topic = bag.pick(FISH_ODOM, namespace)
        clock = _first_odometry(bag, odom_topic, namespace)
        topics = _pick_topics(bag, odom_topic, namespace)
        window = _window(bag, clock, fps, start_s, duration_s, max_frames)
        samples = _read_samples(bag, topics, clock, window, fps, gap_s)
        goal_times, goals, notes = read_goals(bag, topics.goal, clock)
    count = _frames_recorded(path, samples.odometry, window, fps, duration_s, max_frames, notes)
    edge_s = 0.5 / fps
    pose = _frame_poses(path, samples.odometry, gap_s, edge_s, count)
    carrier = frame_values(samples.carrier, gap_s, edge_s, angle_columns=(0,))[:count]
    notes += samples.notes(topics.joint)
    path_time, path_xy = samples.path.finish()
    return RecordedRun(
        source=path,
        time_s=window.frame_time_s[:count],
        x_m=pose[:, 0],
        y_m=pose[:, 1],
        psi_rad=pose[:, 2],
        speed_m_s=np.hypot(pose[:, 3], pose[:, 4]),
        carrier_angle_rad=carrier[:, 0],
        carrier_velocity_rad_s=carrier[:, 1],
        pivot_shift_m=_pivot_shift(samples.pivot, gap_s, edge_s, count),
        path_time_s=path_time,
        path=path_xy,
        goal_time_s=goal_times,
        goals=goals,
        carrier_source=_carrier_source(topics),
        pivot_source=_pivot_source(topics, samples.pivot),
        mechanism=samples.mechanism(),
        odometry_samples=samples.odometry.count,
        gaps=samples.path.gaps,
        end_s=samples.odometry.last_t,
        notes=notes,
    )


def _first_odometry(bag: BagFile, odom_topic: str | None, namespace: str | None) -> RunClock:
    """The run's clock, from the first fish/odom message; BagError if there is none."""
    peek = bag.messages(bag.connections_of(odom_topic))
    try:
        _, first_receive_ns, first = next(peek)
    except StopIteration:
        where = f" in namespace {namespace!r}" if namespace is not None else ""
        raise BagError(
            f"{bag.path}: no fish/odom messages{where}, which the animation draws the fish from "
            f"(topics: {bag.listing()})"
        ) from None
    finally:
        peek.close()
    return RunClock(origin_ns=stamp_ns(first), first_receive_ns=first_receive_ns)


def _pick_topics(bag: BagFile, odom_topic: str | None, namespace: str | None) -> _Topics:
    """The topics to read; one without messages counts as not recorded.

    The carrier comes from tail/state, else from motor/joint_state; the pivot from
    pivot/joint_state, else from tail/state.
    """
    state_topic = bag.pick(TAIL_STATE, namespace)
    joint_topic = bag.pick(MOTOR_JOINT_STATE, namespace, any_name=False)
    pivot_topic = bag.pick(PIVOT_JOINT_STATE, namespace, any_name=False)
    goal_topic = bag.pick(GOAL_POSE, namespace)
    if not bag.count(state_topic):
        state_topic = None
    if state_topic is not None or not bag.count(joint_topic):
        joint_topic = None
    if not bag.count(pivot_topic):
        pivot_topic = None
    return _Topics(odom_topic, state_topic, joint_topic, pivot_topic, goal_topic)


def _window(
    bag: BagFile,
    clock: RunClock,
    fps: float,
    start_s: float,
    duration_s: float | None,
    max_frames: int | None,
) -> _Window:
    """The frame times and what to read for them; BagError if the bag's length shows too many."""
    bag_end_s = (bag.end_ns - clock.first_receive_ns) * 1e-9
    end_s = bag_end_s if duration_s is None else start_s + duration_s
    if max_frames is not None and start_s <= bag_end_s:
        # Said before reading: the window as far as the bag's length tells.
        span_s = min(end_s, bag_end_s) - start_s
        estimate = frame_count(start_s, start_s + span_s, fps)
        if estimate > max_frames:
            raise BagError(
                f"{bag.path}: {span_s:.1f} s of recording from --start {start_s:g} s at --fps "
                f"{fps:g} is {estimate} frames, but a GIF takes 2 to {max_frames}: choose a "
                "shorter window (--start, --duration) or lower --fps"
            )
    # Frames up to the bag's end (and a little beyond: stamps lag receive times); those after
    # the last fish/odom sample are dropped once it is known.
    frames = frame_count(start_s, max(start_s, min(end_s, bag_end_s + 1.0)), fps)
    read_start_ns = clock.first_receive_ns + round((start_s - READ_MARGIN_S) * 1e9)
    read_stop_ns = clock.first_receive_ns + round((end_s + READ_MARGIN_S) * 1e9)
    return _Window(
        start_s=start_s,
        end_s=end_s,
        frame_time_s=start_s + np.arange(frames, dtype=np.float64) / fps,
        read_start_ns=max(read_start_ns, 0) if start_s > READ_MARGIN_S else None,
        read_stop_ns=read_stop_ns if duration_s is not None else None,
    )


def _read_samples(
    bag: BagFile, topics: _Topics, clock: RunClock, window: _Window, fps: float, gap_s: float
) -> TopicSamples:
    """The window's fish/odom, carrier and pivot samples, at their stamps."""
    path = DecimatedPath(window.start_s, window.end_s, 1.0 / (PATH_POINTS_PER_FRAME * fps), gap_s)
    samples = TopicSamples(window.frame_time_s, path, pivot_from_state=topics.pivot is None)
    add = {
        topic: handler
        for topic, handler in (
            (topics.odom, samples.add_odometry), (topics.state, samples.add_state),
            (topics.joint, samples.add_joint), (topics.pivot, samples.add_pivot),
        )
        if topic is not None
    }  # fmt: skip
    for connection, _, message in bag.messages(
        bag.connections_of(*add), start_ns=window.read_start_ns, stop_ns=window.read_stop_ns
    ):
        add[connection.topic](clock.seconds(stamp_ns(message)), message)
    samples.finish()
    return samples


def _frames_recorded(
    path: Path,
    odometry: Brackets,
    window: _Window,
    fps: float,
    duration_s: float | None,
    max_frames: int | None,
    notes: list[str],
) -> int:
    """How many of the window's frames fish/odom covers; BagError unless 2 to ``max_frames``.

    A window that fish/odom ends before adds a note to ``notes``.
    """
    start_s, end_s = window.start_s, window.end_s
    last_odom_s = odometry.last_t
    if odometry.count == 0 or last_odom_s < start_s:
        raise BagError(
            f"{path}: --start {start_s:g} s is past the end of fish/odom "
            f"({max(last_odom_s, 0.0):.2f} s after its first sample)"
        )
    count = min(window.frame_time_s.size, frame_count(start_s, min(end_s, last_odom_s), fps))
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
    return count


def _frame_poses(
    path: Path, odometry: Brackets, gap_s: float, edge_s: float, count: int
) -> FloatArray:
    """The first ``count`` frames' (x, y, psi, u, v); BagError if no frame has a pose."""
    pose = frame_values(odometry, gap_s, edge_s, angle_columns=(2,))[:count]
    if not np.any(np.isfinite(pose[:, 0])):
        raise BagError(
            f"{path}: no fish/odom sample within --gap {gap_s:g} s of any frame of the window"
        )
    return pose


def _pivot_shift(pivot: Brackets, gap_s: float, edge_s: float, count: int) -> FloatArray:
    """The pivot shift of the first ``count`` frames; 0 where none was recorded."""
    if not pivot.count:
        return np.zeros(count)
    shift = frame_values(pivot, gap_s, edge_s)[:count, 0]
    # Between pivot samples too far apart, the pivot held where it was last seen.
    held = frame_values(pivot, math.inf, math.inf)[:count, 0]
    shift = np.where(np.isnan(shift), held, shift)
    return np.where(np.isnan(shift), 0.0, shift)


def _carrier_source(topics: _Topics) -> str:
    """Where the carrier angle comes from, for the user."""
    if topics.state is not None:
        return f"motor_angle of {topics.state}"
    if topics.joint is not None:
        return f"{CARRIER_JOINT} of {topics.joint}"
    return "none (no tail/state or motor/joint_state): the linkage is not drawn"


def _pivot_source(topics: _Topics, pivot: Brackets) -> str:
    """Where the pivot shift comes from, for the user."""
    if topics.pivot is not None:
        return f"{PIVOT_JOINT} of {topics.pivot}"
    if pivot.count:
        return f"pivot_shift of {topics.state}"
    return "none (the tail as designed)"
