"""Top view of a swimming fish as an animated GIF: the hull, the tail's linkage in it, C's path.

Frame k shows the fish at t_k = k / fps. Its pose (X, Y, psi) and velocity are the run's,
interpolated linearly between the RK4 samples (16-48 a beat: far below a pixel here); the
linkage is the engine's at the carrier angle speed * t_k (the carrier turns at constant speed
from phi = 0, as in the run), carried from the tail frame through the body into the world by
:mod:`fishtail_plant.fish.outline`, the geometry the simulator's RViz markers use.

The view is fixed on the whole path while the path, fish included, spans at most
:data:`FIT_SPAN` fish widths; a longer path would make the fish a speck, so the view then follows
C (the fish fills most of its height) and an inset shows the whole path and where the fish is.

A recorded run (:func:`recorded_frames`, ``fishtail-swim animate --bag``) is drawn the same way
from :class:`~fishtail_swim.offline.recorded_run.RecordedRun`: the pose, carrier angle and pivot
shift of each frame interpolated from the bag, the linkage solved by a tail with that pivot shift
(shifts rounded to :data:`PIVOT_SHIFT_STEP_M`, one solve per distinct shift), the goals sent so far
as markers, the current one highlighted. Where the recording has a gap the frame's pose is NaN:
the fish is not drawn and its path is broken.

matplotlib draws on an Agg canvas (no pyplot, no display). As in ``fishtail_kinematics``' cycle
animation, the still parts are drawn once and each frame on a copy of them: in the whole-path view
all but the fish, its path and the title; a following view moves its limits, ticks and grid, so
there only the legend and the inset's frame are still and the view is drawn anew each frame.
Pillow writes the GIF with the call matplotlib's ``PillowWriter`` makes, but takes the frames one
at a time as they are drawn, each cut to its 256 colours at once: ``PillowWriter`` would hold every
frame as RGB until the end (1.8 GB at :data:`MAX_FRAMES` frames of this size), Pillow holds the
palette frames, a third of that.
"""

from __future__ import annotations

import math
from collections.abc import Generator
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
import numpy.typing as npt

from fishtail_kinematics.engine.linkage_points import LinkagePoints
from fishtail_kinematics.engine.mechanisms import Tail
from fishtail_kinematics.offline.animation import MAX_FPS, MAX_FRAMES
from fishtail_plant.fish.fish import FishParameters, FloatArray
from fishtail_plant.fish.model import PSI, SURGE, SWAY, X, Y
from fishtail_plant.fish.outline import body_outline, body_to_world, tail_to_body
from fishtail_swim.offline.progress import Progress

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from PIL.Image import Image

    from fishtail_swim.offline.recorded_run import RecordedRun

__all__ = [
    "FIGURE_SIZE_PX",
    "MAX_FPS",
    "MAX_FRAMES",
    "FishFrames",
    "fish_frames",
    "follows_fish",
    "frame_times",
    "recorded_frames",
    "write_gif",
]

_DPI = 80
#: Width and height of every frame in pixels.
FIGURE_SIZE_PX = (640, 480)
#: The view stays fixed on the whole path while it spans at most this many fish widths (twice
#: the reach of the fish's farthest drawn point from C); beyond, it follows the fish.
FIT_SPAN = 3.0
# Half the following view's height, in reaches: the fish turned across fills most of it.
_FOLLOW_HALF_HEIGHT = 1.3
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
    """The frames at ``frame_time_s`` of one fish's run: ``time_s`` (K,) and ``state`` (K, 6)."""
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


def _extent(frames: FishFrames) -> tuple[FloatArray, FloatArray]:
    """The lowest and highest world (x, y) of everything drawn, C's whole path and the goals."""
    drawn = [frames.outline, frames.ring, frames.tail_link, frames.joints, *frames.drive_links]
    every = np.concatenate(
        [p.reshape(-1, 2) for p in drawn] + [frames.path_until(-1), frames.goals]
    )
    return np.nanmin(every, axis=0), np.nanmax(every, axis=0)


def follows_fish(frames: FishFrames) -> bool:
    """Whether the view follows C: the whole path spans more than FIT_SPAN fish widths."""
    low, high = _extent(frames)
    return float(np.max(high - low)) > FIT_SPAN * 2.0 * frames.reach_m


# The figure's layout in figure fractions: the view on the left, a column on the right with the
# legend and, for a following view, the whole path. Fixed, so that no frame moves the view's box.
_VIEW_BOX = (0.11, 0.09, 0.61, 0.79)
_LEGEND_CORNER = (0.75, 0.88)
_INSET_BOX = (0.76, 0.1, 0.22, 0.33)


def _box_aspect(box: tuple[float, float, float, float]) -> float:
    """Width over height of a box of the figure, in pixels."""
    return (box[2] * FIGURE_SIZE_PX[0]) / (box[3] * FIGURE_SIZE_PX[1])


def _set_window(axes: Axes, low: FloatArray, high: FloatArray, aspect: float) -> None:
    """Limits round ``low``-``high`` widened to the box's aspect: equal scales, a fixed box."""
    centre = 0.5 * (low + high)
    half_height = max(0.5 * float(high[1] - low[1]), 0.5 * float(high[0] - low[0]) / aspect)
    half_width = aspect * half_height
    axes.set_xlim(centre[0] - half_width, centre[0] + half_width)
    axes.set_ylim(centre[1] - half_height, centre[1] + half_height)


def _drawn_frames(
    frames: FishFrames, title: str, progress: Progress | None
) -> Generator[Image, None, None]:
    """Each frame as a palette image, drawn when asked for."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.patches import Polygon
    from PIL import Image as PilImage

    width, height = FIGURE_SIZE_PX
    figure = Figure(figsize=(width / _DPI, height / _DPI), dpi=_DPI)
    canvas = FigureCanvasAgg(figure)
    axes = figure.add_axes(_VIEW_BOX)
    axes.grid(True, linewidth=0.4, alpha=0.6)
    axes.set_xlabel("X [m]")
    axes.set_ylabel("Y [m]")

    (trail,) = axes.plot([], [], color="0.25", linewidth=1.2, label="path of C")
    hull = Polygon(frames.outline[0], closed=True, facecolor="lightsteelblue", alpha=0.6,
                   edgecolor="navy", linewidth=1.2, label="hull")  # fmt: skip
    axes.add_patch(hull)
    (ring,) = axes.plot([], [], color="0.4", linewidth=1.5, label="ring gear")
    (planet,) = axes.plot([], [], color="tab:orange", linewidth=1.2, label="planet, carrier")
    (crank,) = axes.plot([], [], color="tab:orange", linewidth=1.0)
    drive = [
        axes.plot([], [], color="tab:blue", linewidth=2.0, label=None if i else "links")[0]
        for i in range(len(frames.drive_links))
    ]
    (tail_line,) = axes.plot([], [], color="tab:green", linewidth=3.0, label="tail link")
    (joints,) = axes.plot([], [], linestyle="none", marker="o", markersize=4,
                          markerfacecolor="white", markeredgecolor="black")  # fmt: skip
    (tip,) = axes.plot([], [], linestyle="none", marker="o", markersize=6, color="tab:red",
                       label="tip T")  # fmt: skip
    (centre,) = axes.plot([], [], linestyle="none", marker="+", markersize=9, color="black",
                          label="centre of mass C")  # fmt: skip
    goal_artists = []
    if frames.goals.size:
        (to_goal,) = axes.plot([], [], linestyle=":", linewidth=1.0, color="tab:purple")
        (goals_sent,) = axes.plot([], [], linestyle="none", marker="o", markersize=7,
                                  markerfacecolor="none", markeredgecolor="tab:purple",
                                  label="goals sent")  # fmt: skip
        (goal_now,) = axes.plot([], [], linestyle="none", marker="*", markersize=15,
                                color="tab:purple", label="current goal")  # fmt: skip
        goal_artists = [to_goal, goals_sent, goal_now]
    figure.legend(loc="upper left", bbox_to_anchor=_LEGEND_CORNER, fontsize=8, framealpha=0.9)
    polylines = [
        (ring, frames.ring), (planet, frames.planet), (crank, frames.crank),
        (tail_line, frames.tail_link), (joints, frames.joints),
        *zip(drive, frames.drive_links, strict=True),
    ]  # fmt: skip

    status = axes.set_title(" ", fontsize=10)
    fish_artists = [hull, *(line for line, _ in polylines), tip, centre]
    moving_in_view = [trail, *goal_artists, *fish_artists, status]

    follow = follows_fish(frames)
    # Both views keep equal scales by their limits (a window of the box's aspect), so that the
    # box itself never moves between frames.
    aspect = _box_aspect(_VIEW_BOX)
    window = np.array([aspect, 1.0]) * _FOLLOW_HALF_HEIGHT * frames.reach_m
    if follow:
        inset = figure.add_axes(_INSET_BOX)
        inset.set_xticks([])
        inset.set_yticks([])
        inset.set_title("whole path", fontsize=8)
        whole = frames.path_until(-1)
        inset.plot(whole[:, 0], whole[:, 1], color="0.75", linewidth=1.0)
        if frames.goals.size:
            inset.plot(frames.goals[:, 0], frames.goals[:, 1], linestyle="none", marker="*",
                       markersize=6, color="tab:purple")  # fmt: skip
        (inset_trail,) = inset.plot([], [], color="0.25", linewidth=1.2, animated=True)
        (inset_fish,) = inset.plot([], [], linestyle="none", marker="o", markersize=5,
                                   color="tab:red", animated=True)  # fmt: skip
        every = np.concatenate((whole, frames.goals))
        path_low, path_high = np.nanmin(every, axis=0), np.nanmax(every, axis=0)
        margin = max(0.05 * float(np.max(path_high - path_low)), frames.reach_m)
        _set_window(inset, path_low - margin, path_high + margin, _box_aspect(_INSET_BOX))
        # The view's limits, ticks and grid move: the whole view is drawn every frame.
        moving = [axes, inset_trail, inset_fish]
    else:
        low, high = _extent(frames)
        margin = 0.05 * float(np.max(high - low)) + 0.1 * frames.reach_m
        _set_window(axes, low - margin, high + margin, aspect)
        moving = moving_in_view
        for artist in moving:
            artist.set_animated(True)

    # The still parts are drawn once; each frame restores them and draws the moving ones on top
    # (in the whole-path view, a full draw would cost about 3 times as much, most of it text).
    axes.set_visible(not follow)
    canvas.draw()
    background = canvas.copy_from_bbox(figure.bbox)
    axes.set_visible(True)
    # A following view starts on the first pose recorded (frames in a gap have none).
    posed = np.flatnonzero(np.isfinite(frames.x_m) & np.isfinite(frames.y_m))
    here = np.array([frames.x_m[posed[0]], frames.y_m[posed[0]]]) if posed.size else np.zeros(2)
    for k in range(frames.time_s.size):
        x, y = float(frames.x_m[k]), float(frames.y_m[k])
        seen = math.isfinite(x) and math.isfinite(y) and math.isfinite(frames.psi_rad[k])
        path = frames.path_until(k)
        trail.set_data(path[:, 0], path[:, 1])
        for artist in fish_artists:
            artist.set_visible(seen)
        if seen:
            hull.set_xy(frames.outline[k])
            for line, points in polylines:
                line.set_data(points[k, :, 0], points[k, :, 1])
            tip.set_data(frames.tip[k, :1], frames.tip[k, 1:])
            centre.set_data([x], [y])
            status.set_text(
                f"{title}\nt = {frames.time_s[k]:.2f} s   U = {frames.speed_m_s[k]:.3f} m/s   "
                f"heading ψ = {math.degrees(frames.psi_rad[k]):+.1f}°"
            )
        else:
            status.set_text(f"{title}\nt = {frames.time_s[k]:.2f} s   no pose: a gap in the "
                            "recording")  # fmt: skip
        if goal_artists:
            sent = frames.goals_until(k)
            goals_sent.set_data(frames.goals[:sent, 0], frames.goals[:sent, 1])
            current = frames.goals[sent - 1 : sent]
            goal_now.set_data(current[:, 0], current[:, 1])
            to_goal.set_visible(seen and sent > 0)
            if seen and sent:
                to_goal.set_data([x, current[0, 0]], [y, current[0, 1]])
        if follow:
            if seen:
                here = np.array([x, y])
            _set_window(axes, here - window, here + window, aspect)
            inset_trail.set_data(path[:, 0], path[:, 1])
            inset_fish.set_data([x], [y])
        canvas.restore_region(background)
        for artist in moving:
            figure.draw_artist(artist)
        rgb = PilImage.frombuffer(
            "RGBA", canvas.get_width_height(), canvas.buffer_rgba(), "raw", "RGBA", 0, 1
        ).convert("RGB")
        # The GIF's 256 colours of a frame (of about 1000, anti-aliasing included) by maximum
        # coverage: the white ground stays white and the faint grid stays, where the median cut
        # of Pillow's own conversion on saving loses grid lines at half again the cost.
        image = rgb.quantize(256, method=PilImage.Quantize.MAXCOVERAGE)
        if progress is not None:
            progress.update(k + 1)
        yield image


def write_gif(
    frames: FishFrames, path: Path, fps: float, title: str = "", progress: Progress | None = None
) -> Path:
    """Draw ``frames`` and write them to ``path`` as a looping GIF playing at ``fps``."""
    if not 1 <= frames.time_s.size <= MAX_FRAMES:
        raise ValueError(f"a GIF of 1 to {MAX_FRAMES} frames, got {frames.time_s.size}")
    if not (math.isfinite(fps) and 0.0 < fps <= MAX_FPS):
        raise ValueError(f"fps must be in (0, {MAX_FPS:g}], got {fps!r}")
    images = _drawn_frames(frames, title, progress)
    first = next(images)
    try:
        # As matplotlib's PillowWriter.finish; Pillow draws the later frames from the iterator.
        first.save(
            path, format="GIF", save_all=True, append_images=images,
            duration=int(1000 / fps), loop=0,
        )  # fmt: skip
    except BaseException:
        # A half-written GIF is no GIF.
        path.unlink(missing_ok=True)
        raise
    finally:
        images.close()
    if progress is not None:
        progress.finish()
    return path
