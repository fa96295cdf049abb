"""The pilot: its control law's cost per odometry message, and the closed loop without ROS.

Prints figures only (no target is asserted): (a) Pilot.observe per fish/odom message, following
cmd_vel (the yaw-rate path) and swimming to a goal, on one core; (b) the pure closed loop
(carrier samples at 200 Hz, the follower's RK4, the pilot) against real time, the whole suite's
physics in one thread; (c) the steering map's build, which the pilot node runs at start-up. The
processes' CPU and the odometry-to-command latency of the live suite are not measured here.
Run with `make bench`.
"""

from __future__ import annotations

import math
import time

from fishtail_pilot.pilot import Pilot, PilotSettings
from fishtail_pilot.steering_map import build_steering_map
from fishtail_plant.values import fish_from_values, tail_from_values
from fishtail_testkit.closed_loop import fly
from measure import best_of, pin_to_one_core

MESSAGES = 20000
LOOP_SPAN_S = 30.0


def observe_cost_us(pilot: Pilot) -> float:
    """Best-of-5 mean time of one observe() call over MESSAGES odometry messages [us]."""

    def run() -> None:
        for index in range(MESSAGES):
            time_s = index * 0.005
            pilot.observe(time_s, 0.3 * time_s, 0.01 * math.sin(time_s), 0.02, 0.3, 0.1)

    return best_of(run, 5) / MESSAGES * 1e6


def main() -> None:
    """Print the figures."""
    print(pin_to_one_core())
    tail = tail_from_values({"mechanism": "oscillatory"})
    fish = fish_from_values({})
    steering_map = build_steering_map(tail, fish)  # first build: numba's cache load
    started = time.perf_counter()
    steering_map = build_steering_map(tail, fish)
    print(f"steering map build (mechanism 1, both means): {time.perf_counter() - started:.2f} s")
    settings = PilotSettings(steering_map.straight_distance_per_beat_m)
    velocity = Pilot(settings, steering_map.modulation)
    velocity.set_velocity(0.3, 0.1)
    print(f"Pilot.observe following cmd_vel: {observe_cost_us(velocity):.1f} us a message")
    goal = Pilot(settings, steering_map.modulation)
    refusal = goal.set_goal(1e3, 1.0)  # far enough never to be reached, within the goals' range
    assert refusal is None, refusal
    print(f"Pilot.observe swimming to a goal: {observe_cost_us(goal):.1f} us a message")
    pilot = Pilot(settings, steering_map.modulation)
    started = time.perf_counter()
    fly(pilot, tail, fish, LOOP_SPAN_S, lambda t, p: p.set_velocity(0.3, 0.1) if t == 0 else None)
    wall = time.perf_counter() - started
    print(
        f"closed loop without ROS (200 Hz samples, RK4 follower, pilot): {LOOP_SPAN_S:g} s "
        f"simulated in {wall:.2f} s, {LOOP_SPAN_S / wall:.1f}x real time"
    )


if __name__ == "__main__":
    main()
