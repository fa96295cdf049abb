"""One carrier revolution of either mechanism as an animated GIF (the report's animated plot).

``fishtail-kinematics animate``. The joints are the engine's own
:meth:`~fishtail_kinematics.engine.mechanisms.Tail.link_points`, so the picture is exactly what
the engine computes; the still parts are drawn once and the moving ones blitted onto them. What a
frame shows and what it costs: docs/visualisation.md ("Animated cycle (GIF)").
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from fishtail_kinematics.engine.mechanisms import Tail

#: GIF frame delays are whole centiseconds and viewers slow anything under 2 cs down.
MAX_FPS = 50.0
MAX_FRAMES = 2000

_CIRCLE = np.linspace(0.0, 2.0 * math.pi, 97)


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def animate_cycle(
    tail: Tail,
    path: Path,
    frames: int = 72,
    fps: float = 24.0,
    title: str = "",
    dpi: int = 90,
) -> Path:
    """Write one carrier revolution of ``tail`` as a GIF of ``frames`` frames at ``fps``.

    Raises:
        ValueError: ``frames`` outside [2, MAX_FRAMES] or ``fps`` outside (0, MAX_FPS].
        OSError: the GIF cannot be written.
    """
    if not 2 <= frames <= MAX_FRAMES:
        raise ValueError(f"frames must be between 2 and {MAX_FRAMES}, got {frames}")
    if not (math.isfinite(fps) and 0.0 < fps <= MAX_FPS):
        raise ValueError(f"fps must be in (0, {MAX_FPS:g}], got {fps!r}")
    from PIL import Image

    plt = _pyplot()
    angles = np.arange(frames) * (2.0 * math.pi / frames)
    points = tail.link_points(tail.solve(angles, 0.0))
    # The full tip path, finely sampled, for the faint outline and the axis limits.
    fine = tail.link_points(tail.solve(np.linspace(0.0, 2.0 * math.pi, 721), 0.0))
    drive = points.drive_links()
    tail_link = points.tail_link()
    joints = points.moving_joints()
    ring = tail.geometry.ring_radius_m

    figure, axes = plt.subplots(figsize=(8.6, 4.6))
    every = np.concatenate([np.asarray(p).reshape(-1, 2) for p in fine] + [[[-ring, -ring]]])
    low, high = every.min(axis=0), every.max(axis=0)
    margin = 0.08 * float(np.max(high - low))
    axes.set_xlim(low[0] - margin, high[0] + margin)
    axes.set_ylim(min(low[1], -ring) - margin, max(high[1], ring) + margin)
    axes.set_aspect("equal")
    axes.grid(True, linewidth=0.4, alpha=0.6)
    axes.set_xlabel("x [m] (body axis, towards the tail)")
    axes.set_ylabel("y [m] (left)")

    axes.plot(ring * np.cos(_CIRCLE), ring * np.sin(_CIRCLE), color="0.45", linewidth=2.0,
              label="ring gear")  # fmt: skip
    axes.plot([0.0, 0.0], [-ring, ring], color="0.6", linewidth=0.8, linestyle="--")
    axes.plot([-ring, ring], [0.0, 0.0], color="0.6", linewidth=0.8, linestyle="--")
    axes.plot(fine.tip[:, 0], fine.tip[:, 1], color="tab:cyan", linewidth=0.8, linestyle=":",
              label="tip path")  # fmt: skip
    fixed = np.array([points.origin[0], points.pivot_s[0]])
    axes.plot(fixed[:, 0], fixed[:, 1], linestyle="none", marker="s", color="black",
              markersize=6, label="fixed pivots O, S")  # fmt: skip

    moving = dict(animated=True)
    (planet,) = axes.plot([], [], color="tab:orange", linewidth=1.5, label="planet", **moving)
    (carrier,) = axes.plot([], [], color="tab:orange", linewidth=1.0, **moving)
    (diameter,) = axes.plot([], [], color="darkorange", linewidth=1.0, linestyle="-.", **moving)
    drive_lines = [
        axes.plot([], [], color="tab:blue", linewidth=2.2, label="links" if i == 0 else None,
                  **moving)[0]
        for i in range(len(drive))
    ]  # fmt: skip
    (tail_line,) = axes.plot([], [], color="tab:green", linewidth=3.0, label="tail link",
                             **moving)  # fmt: skip
    (trail,) = axes.plot([], [], color="tab:cyan", linewidth=1.8, label="tip trail", **moving)
    (joint_marks,) = axes.plot([], [], linestyle="none", marker="o", markersize=5,
                               markerfacecolor="white", markeredgecolor="black",
                               label="joints", **moving)  # fmt: skip
    (cardan,) = axes.plot([], [], linestyle="none", marker="o", markersize=7, color="tab:red",
                          label="Cardan point P", **moving)  # fmt: skip
    axes.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7, framealpha=0.8)
    heading = f"{title}: " if title else ""
    caption = axes.set_title(" ", fontsize=10, animated=True)
    artists = [planet, carrier, diameter, *drive_lines, tail_line, trail, cardan, joint_marks,
               caption]  # fmt: skip

    def draw(k: int):
        centre = points.planet_centre[k]
        planet.set_data(centre[0] + 0.5 * ring * np.cos(_CIRCLE),
                        centre[1] + 0.5 * ring * np.sin(_CIRCLE))  # fmt: skip
        carrier.set_data([0.0, centre[0]], [0.0, centre[1]])
        ends = np.array([points.cardan[k], points.planet_opposite[k]])
        diameter.set_data(ends[:, 0], ends[:, 1])
        for line, polyline in zip(drive_lines, drive, strict=True):
            line.set_data(polyline[k, :, 0], polyline[k, :, 1])
        tail_line.set_data(tail_link[k, :, 0], tail_link[k, :, 1])
        trail.set_data(points.tip[: k + 1, 0], points.tip[: k + 1, 1])
        joint_marks.set_data(joints[k, :, 0], joints[k, :, 1])
        cardan.set_data([points.cardan[k, 0]], [points.cardan[k, 1]])
        caption.set_text(
            f"{heading}carrier angle φ = {math.degrees(angles[k]):5.1f}°, frame {k + 1}/{frames}"
        )

    try:
        figure.set_dpi(dpi)
        figure.tight_layout()
        canvas = figure.canvas
        canvas.draw()  # everything but the animated artists
        background = canvas.copy_from_bbox(figure.bbox)
        images = []
        for k in range(frames):
            canvas.restore_region(background)
            draw(k)
            for artist in artists:
                figure.draw_artist(artist)
            width, height = canvas.get_width_height()
            images.append(Image.frombuffer("RGBA", (width, height), canvas.buffer_rgba()).copy())
    finally:
        plt.close(figure)
    # As matplotlib's PillowWriter.finish: one looping GIF, a frame every 1/fps s.
    images[0].save(
        path, format="GIF", save_all=True, append_images=images[1:],
        duration=int(1000 / fps), loop=0,
    )  # fmt: skip
    return path
