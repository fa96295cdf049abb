"""The pilot flying the simulated fish without ROS: the suite's closed loop as one function.

Carrier samples come at ``sample_rate_hz`` as the driver's would. The carrier follows the pilot's
profile in closed form (:class:`CarrierSpeedProfile`'s motion, restarted at the current angle
whenever the command changes); ``motor_lag_s`` delays the modulation as a motor that reaches each
speed that much late does (by a carrier angle of Omega tau; 0 is an ideal motor).
:class:`SwimFollower` integrates the fish between samples as the simulator node does, and each
sample's odometry goes back to the pilot. The pivot actuator, when the steering has one, moves at
``pivot_speed_m_s`` towards its command, and the follower's tail follows it
(:meth:`SwimFollower.set_tail`).

The tests fly it for the pilot's settling times, turns, goals and routes (:func:`follow`), and
the pilot's benchmark against real time.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from fishtail_kinematics.engine.carrier_profile import CarrierMotion, CarrierSpeedProfile
from fishtail_kinematics.engine.mechanisms import Tail
from fishtail_pilot.pilot import Pilot, PilotCommand
from fishtail_pilot.route import GoalRoute
from fishtail_plant.fish.fish import FishParameters, FloatArray
from fishtail_plant.fish.follower import SwimFollower
from fishtail_plant.fish.model import PSI, SURGE, YAW_RATE, X, Y

#: Called before each sample with the loop's time (s): set commands, goals, stop the pilot.
Script = Callable[[float, Pilot], None]


def follow(route: GoalRoute) -> Script:
    """A script that flies ``route`` as fishtail-run's console does.

    The first waypoint goes to the pilot at the start; after each sample the route is updated
    with the fish's position the pilot last saw, and once the current waypoint is reached the
    next one is set (the console's route, on the same odometry as the pilot's, and the pilot
    reach a waypoint on the same sample; a waypoint passed close by is left for the next).
    """

    def script(time_s: float, pilot: Pilot) -> None:
        if time_s == 0.0 and route.current is not None:
            pilot.set_goal(*route.current)
        elif route.update(pilot.position_m) is not None and route.current is not None:
            pilot.set_goal(*route.current)

    return script


class LoopRun(NamedTuple):
    """One closed-loop run, one row per carrier sample."""

    time_s: FloatArray
    x_m: FloatArray
    y_m: FloatArray
    yaw_rad: FloatArray
    surge_m_s: FloatArray
    mean_speed_m_s: FloatArray  # the pilot's beat mean
    mean_heading_rad: FloatArray  # the pilot's beat mean (unwrapped)
    carrier_mean_speed_rad_s: FloatArray
    modulation_depth: FloatArray
    pivot_shift_m: FloatArray  # the actuator's position (0 without one)


class _Carrier:
    """The carrier under a profile, restarted at the current angle on every new profile."""

    def __init__(self, lag_s: float) -> None:
        self.lag_s = lag_s
        self.profile = CarrierSpeedProfile(0.0)
        self.angle_rad = 0.0
        self._motion: CarrierMotion = self.profile.motion()

    def advance(self, time_s: float, profile: CarrierSpeedProfile) -> float:
        """The angle at ``time_s`` under the profile so far; ``profile`` holds from then on."""
        angle, _, _ = self._motion(time_s)
        self.angle_rad = float(angle)
        if profile != self.profile:
            self.profile = profile
            late = profile.phase_rad + profile.mean_speed_rad_s * self.lag_s
            executed = CarrierSpeedProfile(profile.mean_speed_rad_s, profile.depth, late)
            self._motion = executed.motion(time_s, self.angle_rad)
        return self.angle_rad


def fly(
    pilot: Pilot,
    tail: Tail,
    fish: FishParameters,
    duration_s: float,
    script: Script,
    sample_rate_hz: float = 200.0,
    max_step_s: float = 0.01,
    pivot_speed_m_s: float = 0.01,
    motor_lag_s: float = 0.0,
) -> LoopRun:
    """Run the loop for ``duration_s`` from rest at the origin; ``script`` commands the pilot."""
    follower = SwimFollower(tail, fish, max_step_s)
    carrier = _Carrier(motor_lag_s)
    count = int(math.floor(duration_s * sample_rate_hz)) + 1
    rows = np.full((count, len(LoopRun._fields)), np.nan)
    pivot_position = 0.0
    shifted_tail = tail
    command: PilotCommand = pilot.command
    period_s = 1.0 / sample_rate_hz
    for index in range(count):
        time_s = index * period_s
        script(time_s, pilot)
        angle = carrier.advance(time_s, pilot.command.carrier)
        if command.pivot_shift_m is not None:
            step = pivot_speed_m_s * period_s
            pivot_position += min(step, max(-step, command.pivot_shift_m - pivot_position))
            if pivot_position != shifted_tail.pivot_shift_m:
                shifted_tail = tail.with_pivot_shift(pivot_position)
                follower.set_tail(shifted_tail)
        follower.follow(round(time_s * 1e9), angle)
        state = follower.state[0]
        command = pilot.observe(
            time_s, float(state[X]), float(state[Y]), float(state[PSI]), float(state[SURGE]),
            float(state[YAW_RATE]),
        )  # fmt: skip
        rows[index] = (
            time_s, state[X], state[Y], state[PSI], state[SURGE], pilot.mean_speed_m_s,
            pilot.mean_heading_rad, carrier.profile.mean_speed_rad_s, carrier.profile.depth,
            pivot_position,
        )  # fmt: skip
    return LoopRun(*(rows[:, column].copy() for column in range(rows.shape[1])))
