"""The driver's simulated motor at 1 kHz: CPU share of the first-order, DC and loaded DC models.

The driver node runs as its own process (``python -m fishtail_driver.node``, as fishtail-run
starts it) publishing motor/joint_state at ``publish_rate_hz`` 1000 (the parameter's maximum), so
its sim backend advances the motor model at every tick, in three configurations:

* ``first_order``: the default speed lag;
* ``dc``, ``motor_load`` none: the DC motor (Pololu 37D 30:1, its 64-count encoder) under the
  board's speed loop, RK4 on its 1 ms internal step;
* ``dc``, ``motor_load`` water_swimming: the same turning the tail of config/oscillatory.yaml in
  water (the default fish), the load read from its table at every RK4 stage.

A probe in this process commands the carrier at SPEED_RAD_S and records motor/joint_state; after
a WARMUP_S warm-up from the first sample it measures, over a WINDOW_S window, the driver
process's CPU time (utime + stime from /proc/<pid>/stat) as a share of one core, the rate of
motor/joint_state at the probe, and the carrier speed's peak-to-peak within a revolution (median
over the window's revolutions). Prints figures only and writes bench/out/bench_motor.json.
Run with `make bench` (about 40 s).
"""

from __future__ import annotations

import json
import math
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

from sensor_msgs.msg import JointState

from fishtail_common.interface import MOTOR_JOINT_STATE
from fishtail_common.testing import (
    WIDENING_VARIABLES,
    NodeProcess,
    Probe,
    claim_domain,
    isolated_ros_environment,
)
from fishtail_driver.parameters import DC_MOTOR_ENCODER
from measure import GEOMETRY, OUT, cpu_seconds

RATE_HZ = 1000.0
SPEED_RAD_S = 4.0
WARMUP_S = 1.0
WINDOW_S = 10.0
START_TIMEOUT_S = 30.0

DC = {"motor_model": "dc", **DC_MOTOR_ENCODER}
#: Label -> the driver's parameters beyond the publish rate.
CONFIGURATIONS: dict[str, dict[str, object]] = {
    "first_order": {},
    "dc, motor_load none": DC,
    "dc, motor_load water_swimming": {**DC, "motor_load": "water_swimming"},
}


def driver_argv(parameters: dict[str, object]) -> list[str]:
    """The driver's command line: the geometry file, the publish rate, ``parameters``."""
    argv = [sys.executable, "-m", "fishtail_driver.node", "--ros-args"]
    argv += ["--params-file", str(GEOMETRY)]
    for name, value in {"publish_rate_hz": RATE_HZ, **parameters}.items():
        argv += ["-p", f"{name}:={value!r}" if isinstance(value, float) else f"{name}:={value}"]
    return argv


def speed_ripple(messages: list) -> float | None:
    """Median over complete revolutions of the carrier speed's peak-to-peak (rad/s)."""
    turns: dict[int, list[float]] = {}
    for message in messages:
        turn = math.floor(message.position[0] / (2.0 * math.pi))
        turns.setdefault(turn, []).append(message.velocity[0])
    complete = [turns[k] for k in sorted(turns)[1:-1]]
    return statistics.median(max(v) - min(v) for v in complete) if complete else None


def measure(domain: int, work: Path, label: str, parameters: dict[str, object]) -> dict:
    """Run the driver in one configuration; CPU share, sample rate and ripple over the window."""
    process = NodeProcess(label.replace(" ", "_").replace(",", ""), driver_argv(parameters), work)
    probe = Probe(domain, "bench_motor")
    try:
        samples = probe.record(JointState, MOTOR_JOINT_STATE.name)
        probe.command_speed(SPEED_RAD_S)
        probe.wait_for_messages(samples, 1, START_TIMEOUT_S, MOTOR_JOINT_STATE.name)
        probe.spin_for(WARMUP_S)
        first = len(samples)
        cpu_start = cpu_seconds(process.pid)
        wall_start = time.monotonic()
        probe.spin_for(WINDOW_S)
        wall = time.monotonic() - wall_start
        cpu = cpu_seconds(process.pid) - cpu_start
        window = samples.messages[first:]
    finally:
        probe.close()
        process.stop()
    return {
        "cpu_pct": 100.0 * cpu / wall,
        "rate_hz": len(window) / wall,
        "speed_ripple_rad_s": speed_ripple(window),
        "window_s": wall,
    }


def main() -> int:
    """Measure every configuration, print the figures, write bench/out/bench_motor.json."""
    OUT.mkdir(parents=True, exist_ok=True)
    results = {}
    with tempfile.TemporaryDirectory(prefix="bench_motor_") as tmp, claim_domain() as lock:
        work = Path(tmp)
        os.environ.update(isolated_ros_environment(lock.domain, work))
        for name in WIDENING_VARIABLES:
            os.environ.pop(name, None)
        for label, parameters in CONFIGURATIONS.items():
            results[label] = measure(lock.domain, work, label, parameters)
    print(
        f"driver process, sim backend at publish_rate_hz {RATE_HZ:g}, carrier {SPEED_RAD_S:g} "
        f"rad/s, {WINDOW_S:g} s window after {WARMUP_S:g} s warm-up; {os.cpu_count()} cores, "
        f"load average {os.getloadavg()[0]:.2f}"
    )
    for label, result in results.items():
        ripple = result["speed_ripple_rad_s"]
        ripple_text = "--" if ripple is None else f"{ripple:.3f}"
        print(
            f"  {label:<31} CPU {result['cpu_pct']:5.1f} % of a core, motor/joint_state "
            f"{result['rate_hz']:6.1f} Hz at the probe, speed ripple {ripple_text} rad/s p-p"
        )
    (OUT / "bench_motor.json").write_text(json.dumps(results, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
