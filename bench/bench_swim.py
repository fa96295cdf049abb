"""Swimming dynamics throughput: one fish in real time, a batch sweep, the steady table.

Prints figures only; targets (one core): (a) one fish stepped at 1 kHz with the engine in the loop
(RK4, the engine solved at every sub-step) >= 200x faster than real time; (b) 100 fish (100 drag
coefficients, one batch of arrays) x 60 simulated s at 1 kHz in <= 10 s (both with the compiled
loop; the numpy model's loop, used without numba, is printed beside for comparison);
(c) `fishtail-swim steady` for 50 carrier speeds in < 1 s. Run with `make bench`.
"""

from __future__ import annotations

import time

import numpy as np

from fishtail_kinematics.engine.geometry import Geometry, OscillatoryGeometry, UndulatoryGeometry
from fishtail_kinematics.engine.mechanisms import make_tail
from fishtail_plant.fish import fused
from fishtail_plant.fish.fish import FishParameters
from fishtail_plant.fish.integrator import simulate
from fishtail_plant.fish.model import SwimModel
from fishtail_plant.fish.tail_drive import EngineTailDrive, constant_carrier_speed
from fishtail_swim.offline.inputs import Swimmer
from fishtail_swim.offline.steady_table import steady_rows
from measure import best_of, pin_to_one_core, verdict

STEP_S = 1e-3
CARRIER_SPEED_RAD_S = 4.0
REAL_TIME_TARGET = 200.0
SWEEP_FISH = 100
SWEEP_SPAN_S = 60.0
SWEEP_TARGET_S = 10.0
STEADY_SPEEDS = 50
STEADY_TARGET_S = 1.0
#: Simulated seconds stepped for (a); (b) steps its whole span.
SINGLE_SPAN_S = 60.0
#: Simulated seconds of the numpy model's loop (the fallback without numba), for comparison.
NUMPY_SPAN_S = 1.0


def step_fish(
    fish: FishParameters,
    count: int,
    span_s: float,
    geometry: Geometry | None = None,
    speeds: float | np.ndarray = CARRIER_SPEED_RAD_S,
) -> None:
    """``count`` fish from rest for ``span_s`` at STEP_S, recording only the last state.

    One carrier speed for all: the batch shares one tail motion (solved once); an array of
    speeds: each fish's tail is solved on its own.
    """
    tail = make_tail(geometry if geometry is not None else OscillatoryGeometry())
    drive = EngineTailDrive(tail, constant_carrier_speed(speeds))
    steps = round(span_s / STEP_S)
    simulate(SwimModel(fish, drive), count, STEP_S, steps, record_every=steps)


def main() -> None:
    """Print the figures."""
    pinned = pin_to_one_core()
    print(f"swimming benchmark ({pinned}), mechanism 1, carrier {CARRIER_SPEED_RAD_S:g} rad/s")

    start = time.perf_counter()
    step_fish(FishParameters(), 1, 0.1)  # imports, and the compiled loop (from numba's cache)
    first_s = time.perf_counter() - start
    print(f"first call (imports, loading or compiling the loop): {first_s:.2f} s")
    for name, geometry in (("mechanism 1", OscillatoryGeometry()),
                           ("mechanism 2", UndulatoryGeometry())):  # fmt: skip
        single_s = best_of(
            lambda chosen=geometry: step_fish(FishParameters(), 1, SINGLE_SPAN_S, chosen), 3
        )
        factor = SINGLE_SPAN_S / single_s
        print(
            f"(a) one fish, {name}, at {1 / STEP_S:g} Hz, engine in the loop: {SINGLE_SPAN_S:g} s "
            f"simulated in {single_s:.3f} s, {factor:.0f}x real time, "
            f"{single_s / (SINGLE_SPAN_S / STEP_S) * 1e6:.2f} us/step "
            f"(target >= {REAL_TIME_TARGET:g}x: {verdict(factor >= REAL_TIME_TARGET)})"
        )
    fused.AVAILABLE = False
    try:
        numpy_s = best_of(lambda: step_fish(FishParameters(), 1, NUMPY_SPAN_S), 1)
    finally:
        fused.AVAILABLE = True
    print(
        f"    the numpy model's loop (without numba), mechanism 1: {NUMPY_SPAN_S / numpy_s:.1f}x "
        f"real time, {numpy_s / (NUMPY_SPAN_S / STEP_S) * 1e6:.0f} us/step"
    )

    sweep = FishParameters(drag_coefficient=np.linspace(0.1, 1.0, SWEEP_FISH))
    sweep_s = best_of(lambda: step_fish(sweep, SWEEP_FISH, SWEEP_SPAN_S), 2)
    print(
        f"(b) {SWEEP_FISH} fish (drag coefficients 0.1 to 1.0, one batch, one tail motion) x "
        f"{SWEEP_SPAN_S:g} s at {1 / STEP_S:g} Hz: {sweep_s:.2f} s "
        f"({SWEEP_FISH * SWEEP_SPAN_S / sweep_s:.0f} fish-seconds per second) "
        f"(target <= {SWEEP_TARGET_S:g} s: {verdict(sweep_s <= SWEEP_TARGET_S)})"
    )
    speeds = np.linspace(2.0, 20.0, SWEEP_FISH)
    own_s = best_of(
        lambda: step_fish(FishParameters(), SWEEP_FISH, SWEEP_SPAN_S, speeds=speeds), 1
    )
    print(
        f"    {SWEEP_FISH} fish at carrier speeds 2 to 20 rad/s (a tail solved per fish): "
        f"{own_s:.2f} s (target <= {SWEEP_TARGET_S:g} s: {verdict(own_s <= SWEEP_TARGET_S)})"
    )

    swimmer = Swimmer(FishParameters(), make_tail(OscillatoryGeometry()))
    speeds = np.linspace(2.0, 20.0, STEADY_SPEEDS)
    steady_rows(swimmer, speeds)
    steady_s = best_of(lambda: steady_rows(swimmer, speeds), 5)
    print(
        f"(c) steady table for {STEADY_SPEEDS} carrier speeds: {steady_s * 1e3:.1f} ms "
        f"(target < {STEADY_TARGET_S:g} s: {verdict(steady_s < STEADY_TARGET_S)})"
    )


if __name__ == "__main__":
    main()
