"""Carrier torque throughput: 10^6 carrier angles, both mechanisms, in air and in water.

Prints figures only; target (one core): the carrier's torque from the links' inertia at a constant
speed, mechanism 1, >= 5 M samples/s. Beside it: the same with a tip force given as arrays, the
water's force computed too (fish held at rest), and the engine's solve alone for comparison.
Run with `make bench`.
"""

from __future__ import annotations

import math
import time

import numpy as np

from fishtail_kinematics.engine.geometry import OscillatoryGeometry, UndulatoryGeometry
from fishtail_kinematics.engine.mechanisms import make_tail
from fishtail_plant.fish.fish import FishParameters
from fishtail_plant.linkage_load.carrier_load import CarrierLoadModel
from fishtail_plant.linkage_load.link_inertia import LinkInertia
from fishtail_plant.linkage_load.water import carrier_load_in_water
from measure import pin_to_one_core, verdict

ANGLES = 1_000_000
SPEED_RAD_S = 4.0
TARGET_SAMPLES_PER_S = 5e6
REPEATS = 9


def best_times(functions, repeats: int) -> list[float]:
    """Shortest wall time of each function over ``repeats`` rounds, in seconds.

    The rounds interleave the functions, so that a disturbed moment (another process on the
    core) does not fall on one of them only.
    """
    best = [math.inf] * len(functions)
    for _ in range(repeats):
        for index, function in enumerate(functions):
            start = time.perf_counter()
            function()
            best[index] = min(best[index], time.perf_counter() - start)
    return best


def main() -> None:
    """Print the figures."""
    pinned = pin_to_one_core()
    print(
        f"carrier load benchmark ({pinned}): {ANGLES:.0e} carrier angles over 2 pi, "
        f"{SPEED_RAD_S:g} rad/s, the default link masses, best of {REPEATS}"
    )
    angles = np.linspace(0.0, 2.0 * math.pi, ANGLES)
    force_x = 0.1 * np.cos(angles)
    force_y = 0.5 * np.sin(angles)
    fish = FishParameters()
    for number, geometry in ((1, OscillatoryGeometry()), (2, UndulatoryGeometry())):
        tail = make_tail(geometry)
        model = CarrierLoadModel(tail, LinkInertia())
        model.load(angles[:1000], SPEED_RAD_S)  # warm up
        cases = (
            ("inertia only", lambda m=model: m.load(angles, SPEED_RAD_S)),
            ("inertia + tip force arrays",
             lambda m=model: m.load(angles, SPEED_RAD_S, 0.0, force_x, force_y)),
            ("inertia + water (fish held)",
             lambda m=model: carrier_load_in_water(m, fish, angles, SPEED_RAD_S)),
            ("engine solve alone", lambda t=tail: t.solve(angles, SPEED_RAD_S)),
        )  # fmt: skip
        times = best_times([function for _, function in cases], REPEATS)
        for (label, _), elapsed in zip(cases, times, strict=True):
            rate = ANGLES / elapsed
            line = f"mechanism {number}, {label}: {rate / 1e6:.2f} M samples/s"
            if number == 1 and label == "inertia only":
                met = verdict(rate >= TARGET_SAMPLES_PER_S)
                line += f" (target >= {TARGET_SAMPLES_PER_S / 1e6:g} M/s: {met})"
            print(line)
        torque = model.load(angles, SPEED_RAD_S).torque_n_m
        print(
            f"mechanism {number}: peak inertial torque {np.abs(torque).max() * 1e3:.3f} mN m at "
            f"{SPEED_RAD_S:g} rad/s (a check that the work was done)"
        )


if __name__ == "__main__":
    main()
