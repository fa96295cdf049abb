"""The verified tier: every design of the front time-stepped, the motor and the free fish.

The search ranks designs by the cycle-average balance with the carrier at constant speed. Each
design of its front is then run as the suite runs it: the DC motor at full duty against the
tail's exact load (links' inertia, water, the towed fish; :class:`TailLoad` and
:func:`run_at_full_duty`, what ``fishtail-swim motor`` runs), and the free body (sway and yaw
free) stepped from rest at the carrier speed the motor sustains (what ``fishtail-swim steady``
checks). The front is re-ranked on these figures. docs/design.md ("Fidelity").
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
import numpy.typing as npt
from pymoo.util.nds.non_dominated_sorting import NonDominatedSorting

from fishtail_common.parameter_files import load_parameter_file
from fishtail_design.evaluation import FIGURES, Scores, score_designs
from fishtail_design.problem import Problem
from fishtail_design.variables import CARRIER_SPEED, GEAR_RATIO
from fishtail_kinematics.engine.errors import FishtailKinematicsError
from fishtail_kinematics.engine.geometry import GEOMETRY_TYPES
from fishtail_kinematics.engine.mechanisms import Tail, make_tail
from fishtail_plant.fish.fish import FloatArray
from fishtail_plant.fish.steady_turn import modulation_turns, steady_turn, strongest_phases
from fishtail_plant.fish.tail_drive import EngineTailDrive, constant_carrier_speed
from fishtail_plant.linkage_load.link_inertia import LinkInertia
from fishtail_plant.linkage_load.tail_load import TailLoad
from fishtail_plant.motor.dc_motor import DcMotorParameters
from fishtail_plant.motor.duty import MotorConstants, duty
from fishtail_plant.motor.full_duty_run import DEFAULT_RUN_LIMITS, run_at_full_duty
from fishtail_plant.values import link_inertia_from_values

#: Modulation phases of the verified turn (their interpolant gives the strongest ones).
VERIFIED_TURNING_PHASES = 8
#: Samples of the exact load over a revolution for a design at a set carrier speed.
_LOAD_SAMPLES = 256


class Verified(NamedTuple):
    """The time-stepped figures of each design, one element per design (NaN: not run)."""

    carrier_speed_rad_s: FloatArray  # the full-duty run's mean, or the set speed
    beat_frequency_hz: FloatArray
    sustained: FloatArray  # 1: the motor holds the carrier speed, 0: it does not
    full_duty_speed_rad_s: FloatArray  # the full-duty run's mean carrier speed (0: it stalls)
    speed_m_s: FloatArray  # the free body's mean over the last beats
    body_lengths_per_s: FloatArray
    turning_radius_m: FloatArray  # of the unsteered free body (straight: large)
    electrical_power_w: FloatArray
    cost_of_transport_j_kg_m: FloatArray
    rms_current_a: FloatArray
    peak_current_a: FloatArray
    turning_rad_per_beat: FloatArray


def link_inertia_of(problem: Problem) -> LinkInertia:
    """The links' masses and inertias of the problem's reference file (not rescaled)."""
    return link_inertia_from_values(load_parameter_file(problem.reference_path))


def _tail(problem: Problem, designs: dict[str, FloatArray], index: int) -> Tail | None:
    geometry_type = GEOMETRY_TYPES[problem.mechanism]
    lengths = {name: float(designs[name][index]) for name in problem.space.linkage_names}
    try:
        return make_tail(geometry_type(**lengths))
    except (FishtailKinematicsError, ValueError):
        return None


def _turning(problem: Problem, tail: Tail, speed: float) -> float:
    phases = np.arange(VERIFIED_TURNING_PHASES) * (2.0 * math.pi / VERIFIED_TURNING_PHASES)
    turns = modulation_turns(tail, problem.fish, speed, problem.turning_depth, phases)
    strongest = strongest_phases(phases, turns.yaw_per_beat_rad)
    return min(strongest.left_yaw_per_beat_rad, -strongest.right_yaw_per_beat_rad)


def verify_one(
    problem: Problem,
    tail: Tail,
    motor: DcMotorParameters,
    set_speed_rad_s: float,
    start_rad_s: float,
) -> tuple[float, ...]:
    """One design's verified figures (the fields of :class:`Verified`, in order)."""
    fish = problem.fish
    load = TailLoad(tail, link_inertia_of(problem), fish, "water_swimming")
    run = run_at_full_duty(motor, load.torque, load.inertia, start_rad_s, DEFAULT_RUN_LIMITS)
    turns = run.started and run.stopped_at_rad is None and run.mean_speed_rad_s > 0.0
    if math.isnan(set_speed_rad_s):
        if not turns:
            return (0.0, 0.0, 0.0, 0.0, *(math.nan,) * 8)
        speed = run.mean_speed_rad_s
        electrical, rms, peak = run.mean_supply_power_w, run.rms_current_a, run.peak_current_a
        sustained = 1.0
    else:
        speed = set_speed_rad_s
        sustained = float(turns and run.mean_speed_rad_s >= speed)
        angles = np.arange(_LOAD_SAMPLES) * (2.0 * math.pi / _LOAD_SAMPLES)
        exact = np.asarray(load.exact(angles, 1.0).torque_n_m, dtype=float)
        current, voltage = duty(MotorConstants.of(motor), exact, speed)
        electrical = float((current * voltage).mean())
        rms, peak = float(np.sqrt((current**2).mean())), float(np.abs(current).max())
    period = 2.0 * math.pi / speed
    free = steady_turn(EngineTailDrive(tail, constant_carrier_speed(speed)), fish, 1, period)
    swim = float(free.speed_m_s[0])
    mass = float(np.asarray(fish.body_mass_kg))
    turn = _turning(problem, tail, speed)
    return (
        speed, 1.0 / period, sustained, run.mean_speed_rad_s if turns else 0.0, swim,
        swim / float(np.asarray(fish.body_length_m)),
        float(free.turning_radius_m[0]), electrical, electrical / (swim * mass), rms, peak, turn,
    )  # fmt: skip


def verify_rows(problem: Problem, rows: npt.ArrayLike) -> Verified:
    """The verified figures of the designs ``rows`` (a batch function for an executor).

    Each row is the optimiser's variables followed by the speed the search found, which starts
    the design's motor run.
    """
    table = np.atleast_2d(np.asarray(rows, dtype=float))
    return verify_designs(problem, problem.space.decode(table[:, :-1]), table[:, -1])


def verify_designs(
    problem: Problem, designs: dict[str, FloatArray], search_speed: npt.ArrayLike
) -> Verified:
    """The verified figures of ``designs``; ``search_speed`` starts each motor run."""
    starts = np.asarray(search_speed, dtype=float)
    results = []
    for index in range(starts.size):
        tail = _tail(problem, designs, index)
        if tail is None:
            results.append((math.nan,) * len(Verified._fields))
            continue
        motor = problem.motor.parameters(float(designs[GEAR_RATIO][index]))
        set_speed = float(designs[CARRIER_SPEED][index])
        start = float(starts[index]) if math.isfinite(starts[index]) else 1.0
        results.append(verify_one(problem, tail, motor, set_speed, start))
    table = np.array(results, dtype=float).reshape(-1, len(Verified._fields))
    return Verified(*table.T)


def verified_order(problem: Problem, verified: Verified, feasible: FloatArray) -> FloatArray:
    """The designs ranked on the verified figures: non-dominated fronts in turn, feasible first.

    Within a front, by the first objective. ``feasible``: the designs whose verified figures
    meet the limits (the others go last, in their order).
    """
    objectives = np.stack([
        objective.to_minimise(np.asarray(getattr(verified, objective.field), dtype=float))
        for objective in problem.objectives
    ], axis=1)  # fmt: skip
    usable = np.flatnonzero(feasible & np.all(np.isfinite(objectives), axis=1))
    order: list[int] = []
    if usable.size:
        fronts = NonDominatedSorting().do(objectives[usable])
        for front in fronts:
            members = usable[np.asarray(front, dtype=int)]
            order.extend(members[np.argsort(objectives[members, 0], kind="stable")].tolist())
    order.extend(index for index in range(objectives.shape[0]) if index not in set(order))
    return np.asarray(order, dtype=int)


def verified_rows(problem: Problem, rows: npt.ArrayLike) -> Scores:
    """The scores of the designs ``rows`` on their verified figures (the refinement's function).

    The stroke's constraints stay the search tier's (they are exact); whether it swims, whether
    the motor sustains the carrier speed and the currents come from the verified runs.
    """
    table = np.atleast_2d(np.asarray(rows, dtype=float))
    designs = problem.space.decode(table)
    search, margins = score_designs(problem, designs)
    start = search.figures[:, FIGURES.index("carrier_speed_rad_s")]
    verified = verify_designs(problem, designs, start)
    limits = problem.limits
    continuous = min(limits.motor_continuous_current_a, limits.driver_continuous_current_a)
    peak = min(limits.motor_peak_current_a, limits.driver_peak_current_a)
    replaced = {
        "swims": verified.speed_m_s,
        "motor_speed": verified.full_duty_speed_rad_s * (1.0 + 1e-9)
        - verified.carrier_speed_rad_s,
        "rms_current": continuous - verified.rms_current_a,
        "peak_current": peak - verified.peak_current_a,
    }
    columns = [
        np.where(np.isnan(value), -np.inf, value) if (value := replaced.get(constraint.name))
        is not None else margin
        for constraint, margin in margins.items()
    ]  # fmt: skip
    objectives = np.stack([objective.value(verified) for objective in problem.objectives], axis=1)
    return Scores(objectives, np.stack(columns, axis=1), search.figures)
