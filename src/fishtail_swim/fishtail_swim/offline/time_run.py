"""Time-stepped runs from rest with the tail in the loop, and their figures over whole beats.

The stepping is :func:`~fishtail_plant.fish.integrator.simulate` (classical RK4, the tail, engine
or servo, evaluated at every sub-step time, times from the step count) with a progress report
after each block of steps; the figures are the dynamics library's (beat means, tail figures).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from fishtail_plant.errors import SwimInputError
from fishtail_plant.fish.figures import BeatMeans, TailFigures, beat_means, tail_figures
from fishtail_plant.fish.fish import FishParameters, FloatArray
from fishtail_plant.fish.integrator import Trajectory, simulate
from fishtail_plant.fish.model import SwimModel
from fishtail_plant.fish.tail_drive import TailDrive
from fishtail_swim.offline.inputs import Swimmer
from fishtail_swim.offline.progress import Progress
from fishtail_swim.offline.tail_beats import CardanBeats, TailBeats

#: Beats the figures of a run are taken over (the last whole ones).
SUMMARY_BEATS = 2


class TimeRun(NamedTuple):
    """A batch of fish stepped from rest: the model, the tail's beats and the trajectory."""

    model: SwimModel
    beats: TailBeats
    trajectory: Trajectory

    @property
    def drive(self) -> TailDrive:
        """The tail motion the model was stepped with."""
        return self.model.drive

    @property
    def beat_period_s(self) -> FloatArray:
        """One tail beat of each fish."""
        return self.beats.beat_period_s


class RunFigures(NamedTuple):
    """Beat means and tail figures over the last ``beats`` whole beats, one element per fish."""

    beats: int
    start_s: FloatArray
    end_s: FloatArray
    means: BeatMeans
    tail: TailFigures


def run_from_rest(
    swimmer: Swimmer,
    carrier_speed_rad_s: FloatArray,
    step_s: float,
    steps: int,
    progress: Progress | None = None,
    hold_sway_yaw: bool = False,
) -> TimeRun:
    """Step one fish per carrier speed (same fish parameters, or per-fish arrays) from rest.

    Raises:
        SwimInputError: a step or step count that is not positive, or a run that diverges.
    """
    speeds = np.atleast_1d(np.asarray(carrier_speed_rad_s, dtype=float))
    if not (math.isfinite(step_s) and step_s > 0.0) or steps < 1:
        raise SwimInputError(f"a run needs a positive step and steps, got {step_s!r}, {steps}")
    beats = CardanBeats(swimmer.tail, speeds)
    return run_beats_from_rest(swimmer.fish, beats, step_s, steps, progress, hold_sway_yaw)


def run_beats_from_rest(
    fish: FishParameters,
    beats: TailBeats,
    step_s: float,
    steps: int,
    progress: Progress | None = None,
    hold_sway_yaw: bool = False,
) -> TimeRun:
    """Step one fish per beat of ``beats`` (same fish parameters, or per-fish arrays) from rest.

    Raises:
        SwimInputError: a step or step count that is not positive, or a run that diverges.
    """
    if not (math.isfinite(step_s) and step_s > 0.0) or steps < 1:
        raise SwimInputError(f"a run needs a positive step and steps, got {step_s!r}, {steps}")
    model = SwimModel(fish, beats.drive, hold_sway_yaw=hold_sway_yaw)
    report = None if progress is None else progress.update
    try:
        trajectory = simulate(model, beats.beat_period_s.size, step_s, steps, progress=report)
    except SwimInputError:
        raise SwimInputError(
            "the integration diverged (non-finite state): use more steps per beat"
        ) from None
    finally:
        if progress is not None:
            progress.finish()
    return TimeRun(model, beats, trajectory)


def whole_beats(run: TimeRun) -> int:
    """The number of whole beats every fish of the run completed."""
    complete = np.floor(run.trajectory.time_s[-1] / run.beat_period_s * (1.0 + 1e-9))
    return int(complete.min())


def run_figures(run: TimeRun, beats: int = SUMMARY_BEATS) -> RunFigures:
    """Ū, <v>, <r>, turning radius, thrust, power, efficiency and St over the last whole beats.

    Raises:
        SwimInputError: a run shorter than one beat.
    """
    beats = min(beats, whole_beats(run))
    if beats < 1:
        raise SwimInputError(
            f"the run ({run.trajectory.time_s[-1]:.6g} s) is shorter than one beat "
            f"({float(run.beat_period_s.max()):.6g} s)"
        )
    periods = run.beat_period_s
    means = beat_means(run.trajectory, periods, beats)
    tail = tail_figures(run.model, run.trajectory, periods, beats)
    end = np.floor(run.trajectory.time_s[-1] / periods * (1.0 + 1e-9)) * periods
    return RunFigures(beats, end - beats * periods, end, means, tail)
