"""A speed profile over the serial backend: the firmware's target follows the measured angle.

The emulated board runs the DC motor (Pololu 37D 30:1, 64-count encoder) under the firmware's
loop; a thread does what the driver node does at each publish tick (read the newest sample,
command the profile's speed at its angle). Checked on the board's own log: the targets span the
profile's range once a revolution, a change of a running target reaches the board at most once
per PID frame, a stop at once; and the modulation the carrier achieved.
"""

from __future__ import annotations

import math
import threading

import pytest

from fishtail_driver.profile_command import CarrierCommand
from fishtail_kinematics.engine.carrier_profile import CarrierSpeedProfile
from fishtail_plant.motor.board_units import Scale
from fishtail_testkit.modulation_fit import measure_following, speeds_from_angles

SCALE = Scale(counts_per_revolution=64, gear_ratio=30.0)
ONE_HZ = 2.0 * math.pi


class NodeLikeFollower:
    """Every 5 ms: the newest sample, and the profile's speed at its angle (as the node does)."""

    def __init__(self, backend, profile: CarrierSpeedProfile) -> None:
        """Command ``profile`` and start following it."""
        self.backend = backend
        self.command = CarrierCommand(max_speed_rad_s=20.0)
        self.command.set_profile(profile.mean_speed_rad_s, profile.depth, profile.phase_rad)
        self.samples = []
        self._stop = threading.Event()
        backend.set_speed(self.command.commanded_speed_rad_s)
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.wait(0.005):
            sample = self.backend.read()
            if sample is None:
                continue
            self.samples.append(sample)
            speed = self.command.follow(sample.angle_rad)
            if speed is not None:
                self.backend.set_speed(speed)

    def turned_rad(self) -> float:
        """The angle since the first sample."""
        return self.samples[-1].angle_rad - self.samples[0].angle_rad if self.samples else 0.0

    def stop(self) -> None:
        """Stop following."""
        self._stop.set()
        self._thread.join(2.0)


@pytest.fixture
def follower():
    """``follower(backend, profile)``: a running NodeLikeFollower, stopped at teardown."""
    made = []

    def make(backend, profile) -> NodeLikeFollower:
        made.append(NodeLikeFollower(backend, profile))
        return made[-1]

    yield make
    for item in made:
        item.stop()


@pytest.mark.slow
def test_the_firmware_target_follows_the_angle_at_most_once_a_frame(
    fake_board, serial_backend, follower, wait_until
):
    board = fake_board(motor="dc", counts_per_revolution=64, gear_ratio=30.0)
    backend = serial_backend(board.link, counts_per_revolution=64, gear_ratio=30.0)
    wait_until(lambda: backend.status()[0] == 0, 5.0, "the backend connected")
    profile = CarrierSpeedProfile(ONE_HZ, 0.5, 2.0)
    following = follower(backend, profile)
    wait_until(lambda: following.turned_rad() > 7 * 2 * math.pi, 30.0, "7 revolutions")
    following.stop()
    backend.stop()
    wait_until(lambda: board.commands("m")[-1] == "m 0 0", 3.0, "m 0 0")

    # The targets the board ran span the profile's speeds, fastest 110 and slowest 37 ticks per
    # frame (10.88 and 3.63 rad/s).
    timed = [(t, int(text.split()[1])) for t, text in list(board.board.commands)
             if text.startswith("m ")]  # fmt: skip
    targets = [ticks for _, ticks in timed if ticks]
    fastest, _ = SCALE.ticks_per_frame(profile.peak_speed_rad_s)
    slowest, _ = SCALE.ticks_per_frame(profile.lowest_speed_rad_s)
    assert (fastest, slowest) == (110, 37)
    assert fastest - 3 <= max(targets) <= fastest and slowest <= min(targets) <= slowest + 3
    # A running target changed at most once per PID frame (33 ms, on the board's clock), so about
    # 30 m a second over the 7 s; the stop went out at once, not a frame later.
    running = [(t, ticks) for t, ticks in timed if ticks]
    gaps = [after[0] - before[0] for before, after in zip(running, running[1:], strict=False)]
    assert min(gaps) >= SCALE.frame_s - 0.001, f"two m {min(gaps) * 1e3:.1f} ms apart"
    assert len(running) <= 31 * (running[-1][0] - running[0][0]) + 1
    assert len(running) >= 20 * (running[-1][0] - running[0][0])
    stop_time = next(t for t, ticks in timed if ticks == 0 and t > running[-1][0])
    assert stop_time - running[-1][0] < SCALE.frame_s + 0.1  # not held back by the frame limit

    samples = following.samples
    times = [sample.monotonic_s for sample in samples]
    angles = [sample.angle_rad for sample in samples]
    result = measure_following(
        times, angles, speeds_from_angles(times, angles), profile, skip_revolutions=2
    )
    # Three runs on the emulated board: depth 0.47-0.49, lag 0.72-0.75 rad, about 28 m a second
    # (the simulated backend's dc motor, without the serial path: 0.49 and 0.57 rad).
    assert abs(result.depth - 0.48) <= 0.04, result
    assert abs(result.phase_lag_rad - 0.74) <= 0.12, result
