"""Top view of a swimming fish as an animated GIF: the hull, the tail's linkage in it, C's path.

The frames of ``fishtail-swim animate``: of a simulated run (:func:`fish_frames`), its pose
interpolated between the RK4 samples and the linkage the engine's, or of a recorded one
(:func:`recorded_frames`, ``--bag``, from :class:`~fishtail_swim.offline.recorded_run.RecordedRun`),
placed as the simulator's RViz markers are (:mod:`fishtail_plant.fish.outline`). They are drawn
and written by :mod:`fishtail_swim.offline.gif_drawing` (:func:`write_gif`, re-exported here). What
a frame shows and what it costs: docs/swimming-dynamics.md ("Command line", ``animate``).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
import numpy.typing as npt

from fishtail_kinematics.engine.linkage_points import LinkagePoints
from fishtail_kinematics.engine.mechanisms import Tail
from fishtail_kinematics.offline.animation import MAX_FPS, MAX_FRAMES
from fishtail_plant.fish.fish import FishParameters, FloatArray
from fishtail_plant.fish.model import PSI, SURGE, SWAY, X, Y
from fishtail_plant.fish.outline import body_outline, body_to_world, tail_to_body
from fishtail_swim.offline.gif_drawing import FIGURE_SIZE_PX, follows_fish, write_gif

if TYPE_CHECKING:
    from fishtail_swim.offline.recorded_run import RecordedRun

__all__ = [
    "FIGURE_SIZE_PX",
    "MAX_FPS",
    "MAX_FRAMES",
    "FishFrames",
    "fish_frames",
    "follows_fish",
    "frame_count",
    "frame_times",
    "recorded_frames",
    "write_gif",
]

_CIRCLE = np.linspace(0.0, 2.0 * math.pi, 73)
#: A recorded run's pivot shifts are drawn rounded to this (far below a pixel): one tail each.
PIVOT_SHIFT_STEP_M = 1e-4
_NO_TIMES = np.zeros(0)
_NO_POINTS = np.zeros((0, 2))


class FishFrames(NamedTuple):
    """What each frame draws, in the world frame; F frames, points as ``(F, k, 2)`` arrays."""

    time_s: FloatArray  # (F,) frame times
    x_m: FloatArray  # (F,) position of C
    y_m: FloatArray
    psi_rad: FloatArray  # (F,) heading, counter-clockwise from world x
    speed_m_s: FloatArray  # (F,) speed of C, |(u, v)|
    outline: FloatArray  # (F, P, 2) hull
    ring: FloatArray  # (F, Q, 2) ring gear
    planet: FloatArray  # (F, Q, 2) planet gear
    crank: FloatArray  # (F, 2, 2) carrier crank, O to the planet's centre
    drive_links: list[FloatArray]  # each (F, k, 2), the links up to the tail link
    tail_link: FloatArray  # (F, 2, 2)
    joints: FloatArray  # (F, k, 2) the joints that move
    tip: FloatArray  # (F, 2) tail tip T
    path_time_s: FloatArray  # (K,) the run's sample times
    path: FloatArray  # (K, 2) C at the run's samples; a NaN row breaks it (a gap)
    reach_m: float  # farthest drawn point from C over all frames
    goal_time_s: FloatArray = _NO_TIMES  # (G,) when each goal was sent, increasing
    goals: FloatArray = _NO_POINTS  # (G, 2)

    def path_until(self, frame: int) -> FloatArray:
        """C's path from the start to frame ``frame``, ``(k, 2)``, ending at the frame's C."""
        count = int(np.searchsorted(self.path_time_s, self.time_s[frame], side="left"))
        here = np.array([[self.x_m[frame], self.y_m[frame]]])
        return np.concatenate((self.path[:count], here))

    def goals_until(self, frame: int) -> int:
        """How many goals were sent at or before frame ``frame``; the last is the current one."""
        return int(np.searchsorted(self.goal_time_s, self.time_s[frame], side="right"))


def frame_count(duration_s: float, fps: float) -> float:
    """How many frames :func:`frame_times` gives, without allocating them (inf when huge)."""
    frames = duration_s * fps * (1.0 + 1e-12) + 1e-9
    return math.floor(frames) + 1.0 if math.isfinite(frames) else math.inf


def frame_times(duration_s: float, fps: float) -> FloatArray:
    """t_k = k / fps from 0 up to ``duration_s`` (included when it falls on a frame)."""
    count = math.floor(duration_s * fps * (1.0 + 1e-12) + 1e-9) + 1
    return np.arange(count, dtype=np.float64) / fps


def _one(value: float | FloatArray) -> float:
    # A fish parameter of the command line's single fish (a float, or an array of one).
    return float(np.mean(value))


def fish_frames(
    time_s: FloatArray,
    state: FloatArray,
    tail: Tail,
    fish: FishParameters,
    carrier_speed_rad_s: float,
    frame_time_s: FloatArray,
) -> FishFrames:
    """The frames at ``frame_time_s`` of one fish's run: ``time_s`` (K,) and ``state`` (K, 6).

    Raises:
        ValueError: frame times outside the run.
    """
    times = np.asarray(frame_time_s, dtype=np.float64)
    if times.size and (times[0] < time_s[0] or times[-1] > time_s[-1] * (1.0 + 1e-12)):
        raise ValueError(
            f"frame times {times[0]:g} to {times[-1]:g} s leave the run "
            f"({time_s[0]:g} to {time_s[-1]:g} s)"
        )

    def at_frames(column: int) -> FloatArray:
        return np.interp(times, time_s, state[:, column])

    angle = carrier_speed_rad_s * times
    points = tail.link_points(tail.solve(angle, np.full_like(angle, carrier_speed_rad_s)))
    return _frames(
        times, at_frames(X), at_frames(Y), at_frames(PSI),
        np.hypot(at_frames(SURGE), at_frames(SWAY)), points, tail, fish,
        np.asarray(time_s, dtype=np.float64), np.column_stack((state[:, X], state[:, Y])),
    )  # fmt: skip


def shifted_link_points(
    tail: Tail,
    carrier_angle_rad: FloatArray,
    carrier_velocity_rad_s: FloatArray,
    pivot_shift_m: FloatArray,
) -> LinkagePoints:
    """The linkage of each frame, ``tail`` with that frame's pivot shift (from the design).

    Shifts are rounded to :data:`PIVOT_SHIFT_STEP_M` and each distinct one solved once; a frame
    whose carrier angle is NaN gets NaN points (not drawn).
    """
    angle = np.asarray(carrier_angle_rad, dtype=np.float64)
    velocity = np.nan_to_num(np.asarray(carrier_velocity_rad_s, dtype=np.float64))
    drawn = np.isfinite(angle)
    steps = np.round(
        np.nan_to_num(np.asarray(pivot_shift_m, dtype=np.float64)) / PIVOT_SHIFT_STEP_M
    )
    template = tail.link_points(tail.solve(np.zeros(angle.size)))
    points = type(template)(*(np.full_like(field, np.nan) for field in template))
    for step in np.unique(steps[drawn]):
        frames = drawn & (steps == step)
        shifted = tail.with_pivot_shift(float(step) * PIVOT_SHIFT_STEP_M)
        solved = shifted.link_points(shifted.solve(angle[frames], velocity[frames]))
        for whole, part in zip(points, solved, strict=True):
            whole[frames] = part
    return points


def recorded_frames(run: RecordedRun, tail: Tail, fish: FishParameters) -> FishFrames:
    """The frames of a recorded run: its poses, its linkage drawn with ``tail``, its goals."""
    points = shifted_link_points(
        tail, run.carrier_angle_rad, run.carrier_velocity_rad_s, run.pivot_shift_m
    )
    return _frames(
        run.time_s, run.x_m, run.y_m, run.psi_rad, run.speed_m_s, points, tail, fish,
        run.path_time_s, run.path, run.goal_time_s, run.goals,
    )  # fmt: skip


def _frames(
    times: FloatArray,
    x: FloatArray,
    y: FloatArray,
    psi: FloatArray,
    speed: FloatArray,
    points: LinkagePoints,
    tail: Tail,
    fish: FishParameters,
    path_time_s: FloatArray,
    path: FloatArray,
    goal_time_s: FloatArray = _NO_TIMES,
    goals: FloatArray = _NO_POINTS,
) -> FishFrames:
    """The frames for these poses (NaN: not drawn) and linkage points (one state per frame)."""
    offset = _one(fish.tail_origin_offset_m)
    ring_radius = tail.geometry.ring_radius_m
    circle = np.column_stack((np.cos(_CIRCLE), np.sin(_CIRCLE)))

    def body(tail_points: npt.ArrayLike) -> FloatArray:
        return tail_to_body(tail_points, offset)

    # Everything in the body frame first, shaped (F, k, 2) so that each frame has its own pose.
    frames = times.size
    outline = body_outline(_one(fish.body_length_m), _one(fish.body_diameter_m))
    hull = np.broadcast_to(outline, (frames, *outline.shape))
    ring = np.broadcast_to(body(ring_radius * circle), (frames, *circle.shape))
    planet = body(points.planet_centre[:, None, :] + 0.5 * ring_radius * circle)
    crank = body(np.stack((points.origin, points.planet_centre), axis=-2))
    drive = [body(link) for link in points.drive_links()]
    tail_link = body(points.tail_link())
    joints = body(points.moving_joints())
    tip = body(points.tip[:, None, :])
    drawn = [hull, ring, planet, crank, *drive, tail_link, joints]
    reach = (
        max(float(np.nanmax(np.hypot(p[..., 0], p[..., 1]), initial=0.0)) for p in drawn)
        if frames
        else 0.0
    )

    def world(body_points: FloatArray) -> FloatArray:
        return body_to_world(body_points, x, y, psi)

    return FishFrames(
        time_s=times,
        x_m=x,
        y_m=y,
        psi_rad=psi,
        speed_m_s=speed,
        outline=world(hull),
        ring=world(ring),
        planet=world(planet),
        crank=world(crank),
        drive_links=[world(link) for link in drive],
        tail_link=world(tail_link),
        joints=world(joints),
        tip=world(tip)[:, 0, :],
        path_time_s=path_time_s,
        path=path,
        reach_m=reach,
        goal_time_s=goal_time_s,
        goals=goals,
    )
