"""A carrier speed profile on the real firmware in simavr, in simulated time.

Two ways to follow it, with the DC motor turning the tail (``fishtail_boards.avr_board``):

* on the board (:func:`run_on_board`): the project's firmware gets ``i RATE``, optionally ``k``
  (the profile controller's lead and feed-forward) and ``u`` (gains), then ``f`` once a second
  against the auto-stop, as the driver sends it;
* from the host (:func:`run_from_host`): the stock firmware at its 30 Hz, and a host that every
  ``poll_ms`` takes the encoder count and writes ``m`` with the law's speed at that angle, as the
  driver's follow loop does. The count is the motor's at the poll, without the ``e`` round trip
  (about 3 ms at 57600 baud): the host's best case.

Every record is one simulated millisecond (the lockstep exchange): its time, the watched firmware
variables, the carrier's angle and speed and the left PWM, so nothing depends on the host's load.
:meth:`BoardRun.following` fits the modulation (fishtail_testkit.modulation_fit).
"""

from __future__ import annotations

import dataclasses
import math
import os
import threading
import tty
from collections.abc import Sequence
from pathlib import Path

from fishtail_boards.avr_board import SimulatedBoard, firmware_functions
from fishtail_boards.board_motors import DcChannelMotor
from fishtail_kinematics.engine.carrier_profile import CarrierSpeedProfile
from fishtail_plant.linkage_load.surroundings import NO_LOAD
from fishtail_plant.motor.board_units import Scale
from fishtail_plant.motor.dc_motor import DcMotorParameters
from fishtail_plant.motor.profile_tuning import profile_tuning
from fishtail_plant.values import tail_load_from_files
from fishtail_testkit.modulation_fit import FollowingResult, measure_following

#: The Pololu 37D 30:1 with its 64-count encoder.
SCALE = Scale(64, 30.0)
#: updatePID, as avr-nm names it (C++).
UPDATE_PID = "_Z9updatePIDv"
#: The auto-stop's 2 s, with a margin: ``f`` (or ``m``) comes again this often [us].
REFRESH_US = 1_000_000


def frame_ms(rate_hz: int) -> int:
    """The firmware's PID interval at ``rate_hz`` (integer ms, as ``i`` sets it)."""
    return 1000 // rate_hz


def ticks_per_frame(speed_rad_s: float, scale: Scale, rate_hz: int) -> float:
    """A carrier speed in encoder ticks per PID frame."""
    return speed_rad_s / scale.rad_per_count * frame_ms(rate_hz) * 1e-3


def profile_command(profile: CarrierSpeedProfile, scale: Scale, rate_hz: int) -> str:
    """``f MEAN:DEPTH:PHASE:REV`` for ``profile`` at ``rate_hz``."""
    revolution = round(scale.counts_per_carrier_rev)
    mean_q6 = round(ticks_per_frame(profile.mean_speed_rad_s, scale, rate_hz) * 64)
    phase = round(profile.phase_rad / (2.0 * math.pi) * revolution) % revolution
    return f"f {mean_q6}:{round(profile.depth * 1000)}:{phase}:{revolution}"


def tuning_for(
    load: str, lead_ms: int, parameters: DcMotorParameters | None = None, scale: Scale = SCALE
) -> str:
    """``k``'s argument for the motor (default: the 37D 30:1) turning the tail in ``load``."""
    return profile_tuning(load, scale, parameters, lead_ms)


@dataclasses.dataclass
class BoardRun:
    """Per simulated ms: time [us], watched variables, carrier angle and speed, left PWM."""

    records: list[tuple[int, tuple[int, ...], float, float, int]]
    #: The simulated times [us] the profile began and ended.
    started_us: int
    ended_us: int

    def kept(self, settle_s: float) -> list[tuple[int, tuple[int, ...], float, float, int]]:
        """The records from ``settle_s`` after the start to the end."""
        start = self.started_us + settle_s * 1e6
        return [record for record in self.records if start <= record[0] < self.ended_us]

    def following(self, profile: CarrierSpeedProfile, settle_s: float) -> FollowingResult:
        """The modulation the carrier achieved after ``settle_s``."""
        kept = self.kept(settle_s)
        return measure_following(
            [record[0] * 1e-6 for record in kept],
            [record[2] for record in kept],
            [record[3] for record in kept],
            profile,
        )

    def saturated(self, settle_s: float) -> float:
        """The share of the milliseconds after ``settle_s`` with the left PWM at +-255."""
        kept = self.kept(settle_s)
        return sum(abs(record[4]) >= 255 for record in kept) / max(len(kept), 1)


def channel_motors(
    load: str, parameters: DcMotorParameters | None = None, scale: Scale = SCALE
) -> list[DcChannelMotor]:
    """Two DC motors turning the tail of config/oscillatory.yaml in ``load`` (or nothing)."""
    motor = parameters or dataclasses.replace(DcMotorParameters(), gear_ratio=scale.gear_ratio)
    if load == NO_LOAD:
        return [DcChannelMotor(motor, scale) for _ in range(2)]
    tail = tail_load_from_files(load)
    return [DcChannelMotor(motor, scale, tail.torque, tail.inertia) for _ in range(2)]


class _Script:
    """Writes commands to the board's port from the motor side, at simulated milliseconds."""

    def __init__(self, run_s: float, setup: Sequence[str], refresh: str | None) -> None:
        self.setup = [*setup]
        self.refresh = refresh
        self.run_us = run_s * 1e6
        self.records: list[tuple[int, tuple[int, ...], float, float, int]] = []
        self.marks: dict[str, int] = {}
        self.fd: int | None = None
        self.board: SimulatedBoard | None = None
        self.finished = threading.Event()

    def write(self, text: str) -> None:
        assert self.fd is not None
        os.write(self.fd, (text + "\r").encode("ascii"))

    def tick(self, now_us: int) -> str | None:
        """What to send at ``now_us`` while the profile runs (None: nothing)."""
        return None

    def __call__(self, now_us: int, pwm: tuple[int, int], watched: tuple[int, ...]) -> None:
        if self.fd is None or self.board is None:
            return
        motor = self.board.side.motors[0]
        speed = motor.speed_rad_s
        self.records.append((now_us, watched, motor.motor.angle_rad, speed, pwm[0]))
        if self.setup:
            self.write(self.setup.pop(0))
            if not self.setup:
                self.marks["started"] = now_us
            return
        since = now_us - self.marks["started"]
        if "ended" not in self.marks:
            if since >= self.run_us:
                self.write("m 0 0")
                self.marks["ended"] = now_us
                return
            text = self.tick(now_us)
            if text is not None:
                self.write(text)
            elif self.refresh is not None and since % REFRESH_US < 1000 and since >= 1000:
                self.write(self.refresh)
        elif now_us - self.marks["ended"] >= 50_000:
            self.finished.set()


def _run(build: Path, folder: Path, script: _Script, motors: list[DcChannelMotor],
         extra: Sequence[str]) -> BoardRun:  # fmt: skip
    with open(folder / "sim.stderr", "wb") as stderr:
        board = SimulatedBoard(
            motors, folder / "board", build, extra=extra, fast=True, observer=script, stderr=stderr
        )
    try:
        assert board.ready.wait(30.0), "the simulator did not start"
        fd = os.open(board.link, os.O_RDWR | os.O_NOCTTY)
        tty.setraw(fd)
        script.board = board
        script.fd = fd
        assert script.finished.wait(60.0 + 30.0 * script.run_us * 1e-6), "the run did not finish"
    finally:
        board.stop()
        if script.fd is not None:
            os.close(script.fd)
    return BoardRun(script.records, script.marks["started"], script.marks["ended"])


def run_on_board(
    build: Path,
    folder: Path,
    profile: CarrierSpeedProfile,
    rate_hz: int,
    run_s: float,
    load: str = "water_swimming",
    tuning: str | None = None,
    gains: str | None = None,
    parameters: DcMotorParameters | None = None,
    scale: Scale = SCALE,
    watch: Sequence[int] = (),
    time_frames: bool = False,
) -> BoardRun:
    """``profile`` followed by the project's firmware in ``build`` at ``rate_hz`` for ``run_s``.

    ``tuning``: ``k``'s argument (none: the firmware's default, the stock loop on the law);
    ``gains``: ``u``'s. ``watch``: data addresses of 4-byte variables to record each ms;
    ``time_frames``: record each updatePID's cycles too (the last watched value).
    """
    command = profile_command(profile, scale, rate_hz)
    setup = [f"i {rate_hz}"]
    setup += [f"k {tuning}"] if tuning is not None else []
    setup += [f"u {gains}"] if gains is not None else []
    setup.append(command)
    extra = [arg for address in watch for arg in ("--watch", f"{address:#x}:4")]
    if time_frames:
        extra += ["--time-function", f"{firmware_functions(build)[UPDATE_PID]:#x}"]
    script = _Script(run_s, setup, command)
    return _run(build, folder, script, channel_motors(load, parameters, scale), extra)


class _HostFollower(_Script):
    """The driver's follow loop: every poll, ``m`` with the law's speed at the count read."""

    def __init__(
        self, run_s: float, profile: CarrierSpeedProfile, scale: Scale, poll_ms: int
    ) -> None:
        super().__init__(run_s, ["r"], None)
        self.profile = profile
        self.scale = scale
        self.poll_us = poll_ms * 1000
        self.next_us = 0

    def tick(self, now_us: int) -> str | None:
        if now_us < self.next_us:
            return None
        self.next_us = now_us + self.poll_us
        assert self.board is not None
        count = self.board.side.motors[0].encoder_counts()
        angle = count * self.scale.rad_per_count
        ticks = round(ticks_per_frame(self.profile.speed_at(angle), self.scale, 30))
        return f"m {ticks} {ticks}"


def run_from_host(
    build: Path,
    folder: Path,
    profile: CarrierSpeedProfile,
    run_s: float,
    load: str = "water_swimming",
    poll_ms: int = 10,
    scale: Scale = SCALE,
) -> BoardRun:
    """``profile`` followed from the host through the stock firmware in ``build`` (30 Hz PID)."""
    script = _HostFollower(run_s, profile, scale, poll_ms)
    return _run(build, folder, script, channel_motors(load, None, scale), [])


def run_pwm(
    build: Path, folder: Path, pwm: int, run_s: float, load: str = "water_swimming"
) -> BoardRun:
    """``o PWM PWM`` (the raw PWM, no loop) for ``run_s``, sent again against the auto-stop."""
    script = _Script(run_s, [f"o {pwm} {pwm}"], f"o {pwm} {pwm}")
    return _run(build, folder, script, channel_motors(load), [])
