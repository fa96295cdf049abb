"""One beat's swimming figures, accumulated sub-step by sub-step while a follower swims it.

The figures follow the definitions of docs/swimming-dynamics.md ("Beats"); on a uniform grid
they equal :func:`~fishtail_plant.fish.figures.beat_means` over one beat (a unit test checks it).
"""

from __future__ import annotations

import math
from typing import NamedTuple

from fishtail_plant.fish.fish import FloatArray
from fishtail_plant.fish.model import PSI, X, Y

__all__ = ["BeatAccumulator", "BeatFigures"]


class BeatFigures(NamedTuple):
    """The spec's swimming figures of one complete beat (see fishtail_msgs/SwimFigures)."""

    beat_index: int
    end_time_s: float  # since the first sample
    duration_s: float
    frequency_hz: float
    mean_speed_m_s: float
    body_lengths_per_s: float
    tip_excursion_m: float
    strouhal_number: float
    mean_thrust_n: float
    mean_tail_power_w: float
    froude_efficiency: float
    turning_radius_m: float
    heading_change_rad: float


def _ratio(numerator: float, denominator: float) -> float:
    # A figure divided by a zero speed or power: inf (or nan for 0/0), never an exception.
    if denominator == 0.0:
        return math.copysign(math.inf, numerator) if numerator != 0.0 else math.nan
    return numerator / denominator


class BeatAccumulator:
    """Integrals and extremes over the beat in progress, from its start state on."""

    def __init__(self, time_s: float, state: FloatArray, thrust: float, power: float,
                 tip_y: float) -> None:  # fmt: skip
        """Start a beat at ``time_s`` in ``state`` with the tail's figures there."""
        self.start_time_s = time_s
        self.start_pose = (float(state[0, X]), float(state[0, Y]), float(state[0, PSI]))
        self.last_time_s = time_s
        self.last_thrust = thrust
        self.last_power = power
        self.thrust_integral = 0.0
        self.power_integral = 0.0
        self.tip_y_low = tip_y
        self.tip_y_high = tip_y

    def add(self, time_s: float, thrust: float, power: float, tip_y: float) -> None:
        """Extend the beat to ``time_s`` (trapezoids) with the tail's figures there."""
        half_step = 0.5 * (time_s - self.last_time_s)
        self.thrust_integral += half_step * (thrust + self.last_thrust)
        self.power_integral += half_step * (power + self.last_power)
        self.last_time_s, self.last_thrust, self.last_power = time_s, thrust, power
        self.tip_y_low = min(self.tip_y_low, tip_y)
        self.tip_y_high = max(self.tip_y_high, tip_y)

    def figures(self, index: int, state: FloatArray, body_length_m: float) -> BeatFigures:
        """The figures of the beat so far, ending in ``state``, as beat number ``index``."""
        duration = self.last_time_s - self.start_time_s
        x0, y0, psi0 = self.start_pose
        chord = math.hypot(float(state[0, X]) - x0, float(state[0, Y]) - y0)
        turn = float(state[0, PSI]) - psi0
        speed = chord / duration
        thrust = self.thrust_integral / duration
        power = self.power_integral / duration
        excursion = self.tip_y_high - self.tip_y_low
        frequency = 1.0 / duration
        radius = chord / (2.0 * math.sin(0.5 * turn)) if turn != 0.0 else math.inf
        return BeatFigures(
            beat_index=index,
            end_time_s=self.last_time_s,
            duration_s=duration,
            frequency_hz=frequency,
            mean_speed_m_s=speed,
            body_lengths_per_s=speed / body_length_m,
            tip_excursion_m=excursion,
            strouhal_number=_ratio(frequency * excursion, speed),
            mean_thrust_n=thrust,
            mean_tail_power_w=power,
            froude_efficiency=_ratio(thrust * speed, power),
            turning_radius_m=radius,
            heading_change_rad=turn,
        )
