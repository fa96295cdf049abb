"""``fishtail-fake-board --motor dc --load``: the board's DC motor turns the tail.

In process: the loaded board's motor turns as the simulated backend's under the same load, and
the options are checked. Over the pty: two boards as processes, the Pololu 37D 30:1 with its
encoder on each, one turning the undulatory tail held in water (config/undulatory.yaml,
config/fish.yaml), one unloaded. The driver's serial backend commands the same speed to both over
their ptys; its samples hold that speed on average, and only the loaded motor's speed ripples
within every revolution.
"""

from __future__ import annotations

import math
import statistics
from pathlib import Path

import pytest

from fishtail_boards.board_firmware import Firmware, FirmwareConfig
from fishtail_boards.fake_board import main as fake_board_main
from fishtail_plant.motor.board_units import Scale
from fishtail_plant.motor.dc_motor import DcMotor, DcMotorParameters
from fishtail_plant.motor.pid_dc_motor import PidDrivenDcMotor
from fishtail_plant.values import tail_load_from_files

CONFIG = Path(__file__).resolve().parents[3] / "config"
POLOLU = {"counts_per_revolution": 64, "gear_ratio": 30.0}
BOARD_POLOLU = ["--motor", "dc", "--counts-per-rev", "64", "--gear-ratio", "30"]
SPEED_RAD_S = 8.0
#: What the loop can hold: 81 ticks per 33 ms frame, within its dead band of 2 ticks.
TICKS = round(SPEED_RAD_S * 64 * 30.0 / (2.0 * math.pi) * 0.033)
HELD_RAD_S = TICKS * 2.0 * math.pi / (64 * 30.0) / 0.033
SETTLE_S = 1.5
REVOLUTIONS = 3


def test_the_loaded_board_motor_turns_as_the_simulated_backends():
    """Same load on the board's DC motor and the sim's: the same ripple, frame by frame."""
    load = tail_load_from_files("water_swimming")
    board = Firmware(
        FirmwareConfig(motor="dc", load=load.torque, load_inertia=load.inertia, **POLOLU), 0.0
    )
    motor = DcMotor(DcMotorParameters(), load.torque, load.inertia)
    drive = PidDrivenDcMotor(motor, Scale(**POLOLU))
    drive.command(SPEED_RAD_S)
    (command,) = [c for c in map(board.feed_byte, f"m {TICKS} 0\r".encode()) if c is not None]
    assert board.execute(command, 0.0) == b"OK\r\n"
    speeds = []
    for step in range(1, 191):  # before the board's auto-stop, 2 s after the m
        board.advance(step * 0.01)
        drive.advance(0.01)
        assert board.motors[0].speed_rad_s == pytest.approx(drive.speed_rad_s, rel=1e-9, abs=1e-9)
        speeds.append(drive.speed_rad_s)
    settled = speeds[100:]  # over a turn
    assert max(settled) - min(settled) > 1.0  # the water's torque, twice a turn
    assert board.motors[1].speed_rad_s == 0.0  # the other channel's tail is at rest


def test_a_load_on_a_motor_that_feels_none_is_refused():
    load = tail_load_from_files("air")
    with pytest.raises(ValueError, match="a load needs motor dc, got motor 'ideal'"):
        FirmwareConfig(load=load.torque, load_inertia=load.inertia)


def refusal(arguments: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    """fishtail-fake-board's one-line error for ``arguments`` (exit status 2)."""
    assert fake_board_main(arguments) == 2
    error = capsys.readouterr().err
    assert error.startswith("fishtail-fake-board: error: ") and error.count("\n") == 1, error
    return error


@pytest.mark.parametrize(
    ("arguments", "reason"),
    [
        (["--load", "air"], "--load air needs --motor dc (the ideal motor feels none)"),
        (["--motor", "dc", "--fish", "fish.yaml"], "--config and --fish describe the tail"),
        (["--motor", "dc", "--load", "air", "--config", "/nowhere.yaml"], "no parameter file"),
    ],
)
def test_the_load_options_are_checked(arguments, reason, capsys):
    assert reason in refusal(arguments, capsys)


def test_an_infeasible_tail_is_refused_with_the_engines_reason(tmp_path, capsys):
    infeasible = tmp_path / "infeasible.yaml"
    infeasible.write_text("/**:\n  ros__parameters:\n    crank_link_m: 0.01\n")
    error = refusal(["--motor", "dc", "--load", "air", "--config", str(infeasible)], capsys)
    assert "motor_load air: linkage cannot assemble over the stroke" in error


def revolutions(samples) -> list[list]:
    """The samples of every complete carrier revolution after the first."""
    turns: dict[int, list] = {}
    for sample in samples:
        turns.setdefault(math.floor(sample.angle_rad / (2.0 * math.pi)), []).append(sample)
    return [turns[k] for k in sorted(turns)[1:-1]]


def spread(values) -> float:
    """5th to 95th percentile: the ripple, without the odd reading of a late poll."""
    cuts = statistics.quantiles(values, n=20)
    return cuts[-1] - cuts[0]


def test_the_serial_path_holds_the_speed_and_sees_the_tails_ripple(
    board_process, serial_backend, tmp_path, wait_until
):
    load = ["--load", "water_held", "--config", str(CONFIG / "undulatory.yaml"),
            "--fish", str(CONFIG / "fish.yaml")]  # fmt: skip
    boards = {
        "loaded": board_process(tmp_path / "loaded", *BOARD_POLOLU, *load),
        "unloaded": board_process(tmp_path / "unloaded", *BOARD_POLOLU),
    }
    backends = {}
    for name, board in boards.items():
        board.next_path()
        backends[name] = serial_backend(tmp_path / name, poll_rate_hz=100.0, **POLOLU)
    for backend in backends.values():
        wait_until(lambda backend=backend: backend.status()[0] == 0, 5.0, "status OK")
        backend.set_speed(SPEED_RAD_S)
    samples: dict[str, list] = {name: [] for name in backends}

    def collected() -> bool:
        for name, backend in backends.items():
            sample = backend.read()
            if sample is not None and (not samples[name] or sample != samples[name][-1]):
                samples[name].append(sample)
        return all(
            len(revolutions(s for s in found if s.monotonic_s > found[0].monotonic_s + SETTLE_S))
            >= REVOLUTIONS
            for found in samples.values()
        )

    wait_until(collected, 15.0, f"{REVOLUTIONS} revolutions of each motor after {SETTLE_S} s")

    ripple = {}
    for name, found in samples.items():
        turns = revolutions(s for s in found if s.monotonic_s > found[0].monotonic_s + SETTLE_S)
        # The held speed on average over the revolutions: one revolution's ends are two host
        # stamps, and a poll late on a loaded machine moves one of them by a few per cent.
        mean = (turns[-1][-1].angle_rad - turns[0][0].angle_rad) / (
            turns[-1][-1].monotonic_s - turns[0][0].monotonic_s
        )
        assert abs(mean / HELD_RAD_S - 1.0) < 0.04, f"{name}: mean {mean:.3f} rad/s"
        ripple[name] = statistics.median(spread([s.velocity_rad_s for s in t]) for t in turns)
    summary = f"ripple {ripple['loaded']:.3f} rad/s loaded, {ripple['unloaded']:.3f} unloaded"
    assert ripple["loaded"] > 0.5, summary
    assert ripple["loaded"] > 3.0 * ripple["unloaded"], summary
