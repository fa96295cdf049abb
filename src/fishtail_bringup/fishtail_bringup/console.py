"""What the live console shows, as plain functions of the latest values (no rclpy here).

>>> verdict_text(7, SymmetryReport.NOT_JUDGED, "not judged: a gap of 315 ms")
'beat 7 NOT_JUDGED: not judged: a gap of 315 ms'

>>> line = status_line(2.5, 4.0, 10.2, 0.372, (0.34, 0.055), "beat 3 OK: symmetric")
>>> for part in line.split(" | "):
...     print(part)
t    2.5 s
speed 4.00 rad/s
carrier   10.20 rad
θ3 +21.31°
tip (0.340, +0.055) m
beat 3 OK: symmetric
"""

from __future__ import annotations

import math

from fishtail_common.interface import Level
from fishtail_msgs.msg import SymmetryReport

#: SymmetryReport.verdict values by name, as the message defines them.
VERDICT_NAMES = {
    getattr(SymmetryReport, name): name for name in ("OK", "WARN", "ERROR", "NOT_JUDGED")
}


def level_name(level: int) -> str:
    """A diagnostic level's name (OK, WARN, ERROR, STALE), or its number if unknown."""
    try:
        return Level(level).name
    except ValueError:
        return str(level)


def status_line(
    elapsed_s: float,
    speed_rad_s: float | None,
    carrier_rad: float | None,
    theta3_rad: float | None,
    tip_m: tuple[float, float] | None,
    verdict_text: str,
) -> str:
    """One line with the carrier, theta3, the tip and the latest symmetry verdict."""
    speed = "  --" if speed_rad_s is None else f"{speed_rad_s:4.2f}"
    carrier = "     --" if carrier_rad is None else f"{carrier_rad:7.2f}"
    theta3 = "    --" if theta3_rad is None else f"{math.degrees(theta3_rad):+6.2f}"
    tip = "(--, --)" if tip_m is None else f"({tip_m[0]:.3f}, {tip_m[1]:+.3f})"
    return (
        f"t {elapsed_s:6.1f} s | speed {speed} rad/s | carrier {carrier} rad | θ3 {theta3}° | "
        f"tip {tip} m | {verdict_text}"
    )


def fish_text(speed_m_s: float | None, heading_rad: float | None) -> str:
    """The simulated fish's part of the status line (``fishtail-run --swim``).

    >>> fish_text(0.1834, -0.0123)
    'fish 0.183 m/s heading  -0.70°'
    >>> fish_text(0.1834, math.radians(222.5))  # a compass heading, however far it has turned
    'fish 0.183 m/s heading -137.50°'
    """
    if speed_m_s is None or heading_rad is None:
        return "fish --"
    return f"fish {speed_m_s:.3f} m/s heading {compass_degrees(heading_rad):+6.2f}°"


def compass_degrees(heading_rad: float) -> float:
    """A heading in degrees in (-180, 180], however many turns the unwrapped angle holds."""
    return math.degrees(math.remainder(heading_rad, math.tau))


def fish_preparing_text(phase: str, seconds: float) -> str:
    """The fish's part of the status line while the simulator prepares its integrator.

    ``phase``: the simulator's diagnostic value ``integrator`` (compiling, loading, preparing).

    >>> fish_preparing_text("compiling", 12.4)
    'fish: preparing (compiling, 12 s so far)'
    """
    return f"fish: preparing ({phase}, {seconds:.0f} s so far)"


def pilot_text(
    position_m: tuple[float, float], heading_rad: float, goal_m: tuple[float, float] | None
) -> str:
    """The pilot's part of the status line: where the fish is, its heading, the distance to go.

    >>> pilot_text((1.0, 2.0), math.pi / 2, (4.0, 6.0))
    'at (1.00, 2.00) m heading  +90.0° goal (4.00, 6.00) m, 5.00 m to go'
    >>> pilot_text((0.0, 0.0), 0.0, None)
    'at (0.00, 0.00) m heading   +0.0° no goal'
    """
    heading = compass_degrees(heading_rad)
    where = f"at ({position_m[0]:.2f}, {position_m[1]:.2f}) m heading {heading:+6.1f}°"
    if goal_m is None:
        return f"{where} no goal"
    distance = math.hypot(goal_m[0] - position_m[0], goal_m[1] - position_m[1])
    return f"{where} goal ({goal_m[0]:.2f}, {goal_m[1]:.2f}) m, {distance:.2f} m to go"


def motor_text(torque_n_m: float, current_a: float | None) -> str:
    """The simulated DC motor's part of the status line: the torque on the carrier, the current.

    >>> motor_text(0.02814, 0.4123)
    'torque +0.0281 N m, 0.41 A'
    >>> motor_text(-0.0012, None)
    'torque -0.0012 N m'
    """
    current = "" if current_a is None else f", {current_a:.2f} A"
    return f"torque {torque_n_m:+.4f} N m{current}"


def verdict_text(beat_index: int | None, verdict: int | None, message: str) -> str:
    """The symmetry part of the status line."""
    if beat_index is None or verdict is None:
        return "waiting for the first beat"
    return f"beat {beat_index} {VERDICT_NAMES.get(verdict, str(verdict))}: {message}"
