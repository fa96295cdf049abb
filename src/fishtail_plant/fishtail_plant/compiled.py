"""``python -m fishtail_plant.compiled``: every compiled loop of the suite, compiled or loaded.

The swimming integrator's loop (:mod:`~fishtail_plant.fish.fused`), the engine's batch pass
(:mod:`~fishtail_kinematics.engine.drive_pass`) and the synthesis' cycle kernels
(:mod:`~fishtail_plant.fish.cycle_kernel` for mechanism 1, :mod:`~fishtail_plant.fish.loop_kernel`
for mechanism 2), each said with how long it took: ``make setup`` runs
it last, so that no later run waits for the compiler. docs/swimming-dynamics.md ("Integrator").
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Any

from fishtail_kinematics.engine import drive_pass
from fishtail_plant.fish import cycle_kernel, loop_kernel
from fishtail_plant.fish.fused import cache_path, compile_loop, is_cached, loop_signatures


def main() -> int:
    """Compile (or load) the integrator's loop, the engine's batch pass and the cycle kernels."""
    if not loop_signatures():
        print("swimming integrator: not compiled (numba is not installed, or NUMBA_DISABLE_JIT)")
        return 0
    cached = is_cached() and is_cached("shared tail")
    verb = "loading" if cached else "compiling"
    print(f"{verb} the swimming integrator (numba; cache {cache_path()}) ...", flush=True)
    done = compile_loop()
    print(
        f"{verb} the swimming integrator ... took {done.seconds:.1f} s "
        f"({done.compiled} specialisations compiled, {done.loaded} loaded from the cache)"
    )
    others: tuple[tuple[str, Callable[[], bool | None], Callable[[], Any]], ...] = (
        ("the engine's batch pass", drive_pass.is_cached, drive_pass.compile_pass),
        ("the cycle kernel", cycle_kernel.is_cached, cycle_kernel.compile_kernel),
        ("the mechanism-2 loop kernel", loop_kernel.is_cached, loop_kernel.compile_kernel),
    )
    for name, current, prepare in others:
        verb = "loading" if current() else "compiling"
        print(f"{verb} {name} (numba) ...", flush=True)
        prepared = prepare()
        if prepared is not None:
            how = "compiled" if prepared.compiled else "loaded from the cache"
            print(f"{verb} {name} ... took {prepared.seconds:.1f} s ({how})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
