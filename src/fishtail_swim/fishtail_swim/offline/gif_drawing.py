"""The frames of a swimming fish (:class:`~fishtail_swim.offline.animate.FishFrames`) as a GIF.

The view holds the whole path while it spans at most :data:`FIT_SPAN` fish widths, else follows C
with an inset of the whole path. The still parts are drawn once and each frame on a copy of them,
and Pillow takes the frames as they are drawn, as 256-colour images, to bound time and memory.
The views, the drawing and their costs: docs/swimming-dynamics.md ("Command line", ``animate``).
"""

from __future__ import annotations

import math
from collections.abc import Generator
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from fishtail_kinematics.offline.animation import MAX_FPS, MAX_FRAMES
from fishtail_plant.fish.fish import FloatArray
from fishtail_swim.offline.progress import Progress

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from PIL.Image import Image

    from fishtail_swim.offline.animate import FishFrames

_DPI = 80
#: Width and height of every frame in pixels.
FIGURE_SIZE_PX = (640, 480)
#: The view stays fixed on the whole path while it spans at most this many fish widths (twice
#: the reach of the fish's farthest drawn point from C); beyond, it follows the fish.
FIT_SPAN = 3.0
# Half the following view's height, in reaches: the fish turned across fills most of it.
_FOLLOW_HALF_HEIGHT = 1.3
# The figure's layout in figure fractions: the view on the left, a column on the right with the
# legend and, for a following view, the whole path. Fixed, so that no frame moves the view's box.
_VIEW_BOX = (0.11, 0.09, 0.61, 0.79)
_LEGEND_CORNER = (0.75, 0.88)
_INSET_BOX = (0.76, 0.1, 0.22, 0.33)


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


def _posed(frames: FishFrames, k: int) -> bool:
    """Whether frame ``k`` has a pose (a frame in a gap of the recording has none)."""
    return bool(
        math.isfinite(frames.x_m[k])
        and math.isfinite(frames.y_m[k])
        and math.isfinite(frames.psi_rad[k])
    )


class _FishArtists:
    """The view's artists that change from frame to frame: the fish, its path, goals, the title."""

    def __init__(self, figure: Figure, axes: Axes, frames: FishFrames) -> None:
        """Add them to ``axes`` (empty until :meth:`show`), and the figure's legend."""
        from matplotlib.patches import Polygon

        (self.trail,) = axes.plot([], [], color="0.25", linewidth=1.2, label="path of C")
        self.hull = Polygon(frames.outline[0], closed=True, facecolor="lightsteelblue", alpha=0.6,
                            edgecolor="navy", linewidth=1.2, label="hull")  # fmt: skip
        axes.add_patch(self.hull)
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
        (self.tip,) = axes.plot([], [], linestyle="none", marker="o", markersize=6,
                                color="tab:red", label="tip T")  # fmt: skip
        (self.centre,) = axes.plot([], [], linestyle="none", marker="+", markersize=9,
                                   color="black", label="centre of mass C")  # fmt: skip
        self.goals: list[Line2D] = []  # the line to the current goal, those sent, the current one
        if frames.goals.size:
            (to_goal,) = axes.plot([], [], linestyle=":", linewidth=1.0, color="tab:purple")
            (sent,) = axes.plot([], [], linestyle="none", marker="o", markersize=7,
                                markerfacecolor="none", markeredgecolor="tab:purple",
                                label="goals sent")  # fmt: skip
            (now,) = axes.plot([], [], linestyle="none", marker="*", markersize=15,
                               color="tab:purple", label="current goal")  # fmt: skip
            self.goals = [to_goal, sent, now]
        figure.legend(loc="upper left", bbox_to_anchor=_LEGEND_CORNER, fontsize=8, framealpha=0.9)
        self.polylines = [
            (ring, frames.ring), (planet, frames.planet), (crank, frames.crank),
            (tail_line, frames.tail_link), (joints, frames.joints),
            *zip(drive, frames.drive_links, strict=True),
        ]  # fmt: skip
        self.status = axes.set_title(" ", fontsize=10)
        self.fish = [self.hull, *(line for line, _ in self.polylines), self.tip, self.centre]
        #: In the order they are drawn over the still view.
        self.moving = [self.trail, *self.goals, *self.fish, self.status]

    def show(self, frames: FishFrames, k: int, path: FloatArray, title: str) -> None:
        """Frame ``k``: the path so far (``path``), the fish unless in a gap, the title, goals."""
        seen = _posed(frames, k)
        self.trail.set_data(path[:, 0], path[:, 1])
        for artist in self.fish:
            artist.set_visible(seen)
        if seen:
            self.hull.set_xy(frames.outline[k])
            for line, points in self.polylines:
                line.set_data(points[k, :, 0], points[k, :, 1])
            self.tip.set_data(frames.tip[k, :1], frames.tip[k, 1:])
            self.centre.set_data([float(frames.x_m[k])], [float(frames.y_m[k])])
            self.status.set_text(
                f"{title}\nt = {frames.time_s[k]:.2f} s   U = {frames.speed_m_s[k]:.3f} m/s   "
                f"heading ψ = {math.degrees(frames.psi_rad[k]):+.1f}°"
            )
        else:
            self.status.set_text(f"{title}\nt = {frames.time_s[k]:.2f} s   no pose: a gap in the "
                                 "recording")  # fmt: skip
        if self.goals:
            self._show_goals(frames, k, seen)

    def _show_goals(self, frames: FishFrames, k: int, seen: bool) -> None:
        """The goals sent by frame ``k``, the current one, and the line from C to it."""
        to_goal, sent_line, now_line = self.goals
        sent = frames.goals_until(k)
        sent_line.set_data(frames.goals[:sent, 0], frames.goals[:sent, 1])
        current = frames.goals[sent - 1 : sent]
        now_line.set_data(current[:, 0], current[:, 1])
        to_goal.set_visible(seen and sent > 0)
        if seen and sent:
            x, y = float(frames.x_m[k]), float(frames.y_m[k])
            to_goal.set_data([x, current[0, 0]], [y, current[0, 1]])


class _Following:
    """A view that follows C, with an inset of the whole path and where the fish is on it."""

    def __init__(self, figure: Figure, axes: Axes, frames: FishFrames, aspect: float) -> None:
        """Add the inset; the view starts on the first pose recorded (a gap's frames have none)."""
        self.axes = axes
        self.aspect = aspect
        self.half_window = np.array([aspect, 1.0]) * _FOLLOW_HALF_HEIGHT * frames.reach_m
        posed = np.flatnonzero(np.isfinite(frames.x_m) & np.isfinite(frames.y_m))
        self.here = (
            np.array([frames.x_m[posed[0]], frames.y_m[posed[0]]]) if posed.size else np.zeros(2)
        )
        inset = figure.add_axes(_INSET_BOX)
        inset.set_xticks([])
        inset.set_yticks([])
        inset.set_title("whole path", fontsize=8)
        whole = frames.path_until(-1)
        inset.plot(whole[:, 0], whole[:, 1], color="0.75", linewidth=1.0)
        if frames.goals.size:
            inset.plot(frames.goals[:, 0], frames.goals[:, 1], linestyle="none", marker="*",
                       markersize=6, color="tab:purple")  # fmt: skip
        (self.trail,) = inset.plot([], [], color="0.25", linewidth=1.2, animated=True)
        (self.fish,) = inset.plot([], [], linestyle="none", marker="o", markersize=5,
                                  color="tab:red", animated=True)  # fmt: skip
        every = np.concatenate((whole, frames.goals))
        path_low, path_high = np.nanmin(every, axis=0), np.nanmax(every, axis=0)
        margin = max(0.05 * float(np.max(path_high - path_low)), frames.reach_m)
        _set_window(inset, path_low - margin, path_high + margin, _box_aspect(_INSET_BOX))
        #: The view's limits, ticks and grid move: the whole view is drawn every frame.
        self.moving = [axes, self.trail, self.fish]

    def show(self, frames: FishFrames, k: int, path: FloatArray) -> None:
        """Frame ``k``: the view round C (where it was last seen, in a gap), the inset's path."""
        x, y = float(frames.x_m[k]), float(frames.y_m[k])
        if _posed(frames, k):
            self.here = np.array([x, y])
        _set_window(self.axes, self.here - self.half_window, self.here + self.half_window,
                    self.aspect)  # fmt: skip
        self.trail.set_data(path[:, 0], path[:, 1])
        self.fish.set_data([x], [y])


def _view(figure: Figure) -> Axes:
    """The view's axes, gridded and labelled."""
    axes = figure.add_axes(_VIEW_BOX)
    axes.grid(True, linewidth=0.4, alpha=0.6)
    axes.set_xlabel("X [m]")
    axes.set_ylabel("Y [m]")
    return axes


def _fit_whole_path(axes: Axes, frames: FishFrames, aspect: float) -> None:
    """Fix the view on everything the frames draw, with a margin."""
    low, high = _extent(frames)
    margin = 0.05 * float(np.max(high - low)) + 0.1 * frames.reach_m
    _set_window(axes, low - margin, high + margin, aspect)


def _still_background(canvas: FigureCanvasAgg, axes: Axes, follow: bool) -> Any:
    """The still parts drawn once: the figure without its moving artists (or the following view)."""
    axes.set_visible(not follow)
    canvas.draw()
    background = canvas.copy_from_bbox(canvas.figure.bbox)
    axes.set_visible(True)
    return background


def _palette_image(canvas: FigureCanvasAgg) -> Image:
    """The canvas as a GIF frame: 256 colours."""
    from PIL import Image as PilImage

    rgb = PilImage.frombuffer(
        "RGBA", canvas.get_width_height(), canvas.buffer_rgba(), "raw", "RGBA", 0, 1
    ).convert("RGB")
    # The GIF's 256 colours of a frame (of about 1000, anti-aliasing included) by maximum
    # coverage: the white ground stays white and the faint grid stays, where the median cut
    # of Pillow's own conversion on saving loses grid lines at half again the cost.
    return rgb.quantize(256, method=PilImage.Quantize.MAXCOVERAGE)


def _drawn_frames(
    frames: FishFrames, title: str, progress: Progress | None
) -> Generator[Image, None, None]:
    """Each frame as a palette image, drawn when asked for."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    width, height = FIGURE_SIZE_PX
    figure = Figure(figsize=(width / _DPI, height / _DPI), dpi=_DPI)
    canvas = FigureCanvasAgg(figure)
    axes = _view(figure)
    artists = _FishArtists(figure, axes, frames)
    # Both views keep equal scales by their limits (a window of the box's aspect), so that the
    # box itself never moves between frames.
    aspect = _box_aspect(_VIEW_BOX)
    following = _Following(figure, axes, frames, aspect) if follows_fish(frames) else None
    if following is None:
        _fit_whole_path(axes, frames, aspect)
        moving = artists.moving
        for artist in moving:
            artist.set_animated(True)
    else:
        moving = following.moving
    # Each frame restores the still parts and draws the moving ones on top (in the whole-path
    # view, a full draw would cost about 3 times as much, most of it text).
    background = _still_background(canvas, axes, following is not None)
    for k in range(frames.time_s.size):
        path = frames.path_until(k)
        artists.show(frames, k, path, title)
        if following is not None:
            following.show(frames, k, path)
        canvas.restore_region(background)
        for artist in moving:
            figure.draw_artist(artist)
        image = _palette_image(canvas)
        if progress is not None:
            progress.update(k + 1)
        yield image


def write_gif(
    frames: FishFrames, path: Path, fps: float, title: str = "", progress: Progress | None = None
) -> Path:
    """Draw ``frames`` and write them to ``path`` as a looping GIF playing at ``fps``.

    Raises:
        ValueError: no frames or more than MAX_FRAMES, or ``fps`` outside (0, MAX_FPS].
        OSError: the GIF cannot be written (no half-written file is left).
    """
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
