"""Where the fish is drawn: its hull and tail points in the body frame, and the body in the world.

The one placement every picture of the swimming fish uses (the simulator's RViz markers, the
command line's animation), so that they all draw the same fish the same way: the hull an ellipse
L x D round C, tail points moved from the tail frame to the body, the body turned by psi and moved
to (X, Y). Points are ``(..., 2)`` arrays of (x, y) in metres. Frames: docs/swimming-dynamics.md
("Frames and signs").

>>> import math
>>> body_to_world(np.array([1.0, 0.0]), 2.0, 3.0, math.pi / 2).round(12).tolist()
[2.0, 4.0]
>>> tail_to_body(np.array([0.2, 0.1]), 0.05).round(12).tolist()
[-0.25, 0.1]
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from fishtail_plant.fish.fish import FloatArray

#: Points of the hull's outline (the first and last coincide, closing it).
OUTLINE_POINTS = 37


def body_outline(
    body_length_m: float, body_diameter_m: float, points: int = OUTLINE_POINTS
) -> FloatArray:
    """The hull's outline in the body frame, ``(points, 2)``, from the nose round by the left."""
    angles = np.linspace(0.0, 2.0 * math.pi, points)
    return np.column_stack(
        (0.5 * body_length_m * np.cos(angles), 0.5 * body_diameter_m * np.sin(angles))
    )


def tail_to_body(points: npt.ArrayLike, tail_origin_offset_m: float) -> FloatArray:
    """Tail-frame points (x back, y left, origin O) in the body frame: (-l_O - x_t, y_t)."""
    tail = np.asarray(points, dtype=np.float64)
    body = np.empty_like(tail)
    body[..., 0] = -tail_origin_offset_m - tail[..., 0]
    body[..., 1] = tail[..., 1]
    return body


def body_to_world(
    points: npt.ArrayLike, x_m: npt.ArrayLike, y_m: npt.ArrayLike, psi_rad: npt.ArrayLike
) -> FloatArray:
    """Body-frame points in the world for the pose (X, Y, psi).

    The pose may be floats, or arrays of a shape ``S`` (one pose per frame, say); the points are
    then ``(..., 2)`` broadcastable to ``S + (P, 2)``, e.g. one outline ``(P, 2)`` for every pose,
    or ``S + (P, 2)`` points that differ per pose. The result has the broadcast shape.
    """
    body = np.asarray(points, dtype=np.float64)
    # A trailing axis on the pose lines it up with the points' (P,) axis.
    x = np.asarray(x_m, dtype=np.float64)[..., None]
    y = np.asarray(y_m, dtype=np.float64)[..., None]
    psi = np.asarray(psi_rad, dtype=np.float64)[..., None]
    if body.ndim == 1:
        return body_to_world(body[None], x_m, y_m, psi_rad)[..., 0, :]
    cos_psi, sin_psi = np.cos(psi), np.sin(psi)
    along, across = body[..., 0], body[..., 1]
    return np.stack(
        (x + cos_psi * along - sin_psi * across, y + sin_psi * along + cos_psi * across), axis=-1
    )
