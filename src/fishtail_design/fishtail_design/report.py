"""``report.md``: the reference design against the picked ones, and what binds each.

Speed, cost of transport, current, symmetry and turning of each, from the search and verified,
so that a builder sees how much the synthesis gains over the report's own linkage under the
same motor and what limits it further. The figures' meaning: docs/design.md ("Output").
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from fishtail_design.outcome import Designs, Outcome, verified_feasible
from fishtail_design.variables import CARRIER_SPEED, GEAR_RATIO, SYMBOLS, unit_of


def _number(value: float, digits: int = 4) -> str:
    return "–" if not math.isfinite(value) else f"{value:.{digits}g}"


def _column(designs: Designs, index: int, outcome: Outcome) -> list[str]:
    """One design's rows of the comparison table."""
    v = designs.verified
    mechanism = designs.mechanisms[index]
    names = outcome.problem_of(mechanism).space.linkage_names
    lengths = ", ".join(f"{SYMBOLS[name]} {1000.0 * designs.values[name][index]:.1f}"
                        for name in names)  # fmt: skip
    margins = designs.scores.margins[index]
    # NaN: a constraint of another mechanism (a merged front's).
    feasible_search = bool(np.all(margins[~np.isnan(margins)] >= 0.0))
    verified_ok = bool(verified_feasible(outcome.problem, v)[index])
    return [
        mechanism,
        f"{lengths} mm",
        f"{designs.values[GEAR_RATIO][index]:g}:1",
        f"{_number(designs.figure('carrier_speed_rad_s')[index])} / "
        f"{_number(v.carrier_speed_rad_s[index])}",
        f"{_number(designs.figure('beat_frequency_hz')[index], 3)} / "
        f"{_number(v.beat_frequency_hz[index], 3)}",
        f"{_number(designs.figure('body_lengths_per_s')[index], 3)} / "
        f"{_number(v.body_lengths_per_s[index], 3)}",
        f"{_number(designs.figure('speed_m_s')[index], 3)} / {_number(v.speed_m_s[index], 3)}",
        f"{_number(designs.figure('cost_of_transport_j_kg_m')[index], 3)} / "
        f"{_number(v.cost_of_transport_j_kg_m[index], 3)}",
        f"{_number(designs.figure('rms_current_a')[index], 3)} / "
        f"{_number(v.rms_current_a[index], 3)}",
        f"{_number(designs.figure('peak_current_a')[index], 3)} / "
        f"{_number(v.peak_current_a[index], 3)}",
        f"{_number(designs.figure('turning_rad_per_beat')[index], 3)} / "
        f"{_number(v.turning_rad_per_beat[index], 3)}",
        f"{designs.figure('time_share_imbalance')[index]:.2e}, "
        f"{designs.figure('mean_angle_rad')[index]:.2e} rad",
        f"{math.degrees(designs.figure('transmission_angle_rad')[index]):.1f}°",
        ("yes" if feasible_search else "no") + " / " + ("yes" if verified_ok else "no"),
        designs.binding[index],
    ]


ROWS = (
    "mechanism", "linkage", "gear ratio", "carrier speed [rad/s]", "beat frequency [Hz]",
    "speed [L/s]", "speed [m/s]", "cost of transport [J/(kg m)]", "RMS current [A]",
    "peak current [A]", "turning [rad/beat]", "symmetry: time share, mean angle",
    "smallest transmission angle", "feasible", "binding (smallest margin)",
)  # fmt: skip


def _gain(outcome: Outcome, index: int) -> str:
    """How the fastest pick compares with the reference, verified."""
    front, reference = outcome.front.verified, outcome.reference.verified
    mechanism = outcome.front.mechanisms[index]
    own = outcome.reference.mechanisms.index(mechanism)  # the reference of its mechanism
    speed, reference_speed = front.speed_m_s[index], reference.speed_m_s[own]
    cost = front.cost_of_transport_j_kg_m[index]
    reference_cost = reference.cost_of_transport_j_kg_m[own]
    if not all(math.isfinite(value) and value > 0.0
               for value in (speed, reference_speed, cost, reference_cost)):  # fmt: skip
        return "The reference design has no verified figures to compare with."
    return (
        f"Verified, the fastest feasible design swims **{speed / reference_speed:.2f}×** as fast "
        f"as the {mechanism} reference ({speed:.3f} against {reference_speed:.3f} m/s) at "
        f"**{cost / reference_cost:.2f}×** its cost of transport ({cost:.3g} against "
        f"{reference_cost:.3g} J/(kg m)), under the same motor."
    )


def write_report(outcome: Outcome, picks: Sequence[tuple[str, int]], path: Path,
                 directories: dict[str, Path]) -> None:  # fmt: skip
    """``report.md``: the problem, the comparison table, the gain and how to run the picks."""
    problem = outcome.problem
    mechanisms = outcome.reference.mechanisms
    searched = (f"{mechanisms[0]} mechanism" if len(mechanisms) == 1 else
                f"{' and '.join(mechanisms)} mechanisms, a search of each, the fronts ranked "
                "together")  # fmt: skip
    lines = [
        f"# fishtail-design: {problem.path.name}", "",
        f"Fish `{problem.fish_path}`, motor `{problem.motor_path}` ({problem.motor.name}), "
        f"{searched}; objectives: "
        + ", ".join(f"{o.label} [{o.unit}]" for o in problem.objectives) + ".",
        f"NSGA-II, population {problem.search.population}, {outcome.generations} generations, "
        f"seed {problem.search.seed}: {outcome.evaluated} designs evaluated, "
        f"{outcome.front.count} feasible on the final front.", "",
        "Each cell: search (cycle-average balance, carrier at constant speed) / verified "
        "(motor at full duty against the exact load, free body stepped from rest).", "",
    ]  # fmt: skip
    references = [f"reference ({outcome.problem_of(mechanism).reference_path.name})"
                  for mechanism in mechanisms]  # fmt: skip
    header = ["", *references, *(name for name, _ in picks)]
    lines.append("| " + " | ".join(header) + " |")
    lines.append("|" + "---|" * len(header))
    columns = [_column(outcome.reference, index, outcome) for index in range(len(mechanisms))]
    columns += [_column(outcome.front, index, outcome) for _, index in picks]
    for row, label in enumerate(ROWS):
        lines.append("| " + " | ".join([label, *(column[row] for column in columns)]) + " |")
    lines.append("")
    fastest = [index for name, index in picks if name == "fastest"]
    if fastest:
        lines += [_gain(outcome, fastest[0]), ""]
    for index, mechanism in enumerate(mechanisms):
        failing = [constraint.name for constraint, margin in
                   zip(outcome.constraints, outcome.reference.scores.margins[index], strict=True)
                   if margin < 0.0]  # fmt: skip
        if failing:
            own = f"{mechanism} " if len(mechanisms) > 1 else ""
            lines += [f"The {own}reference design does not meet: {', '.join(failing)}.", ""]
    if directories:
        lines += ["Run a pick in the suite:", "", "```"]
        for name, directory in directories.items():
            lines += [
                f"make run CONFIG={directory}/kinematics.yaml            # {name}",
                f"fishtail-swim simulate --config {directory}/kinematics.yaml "
                f"--fish {directory}/fish.yaml",
                f"fishtail-swim motor --config {directory}/kinematics.yaml "
                f"--fish {directory}/fish.yaml --motor {directory}/motor.yaml",
            ]
        lines += ["```", ""]
    speed_unit = unit_of(CARRIER_SPEED)
    lines.append(f"Carrier speeds in {speed_unit}; lengths in mm; the verified figures of a "
                 "design run as fast as its motor holds it are at the full-duty run's mean speed.")
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
