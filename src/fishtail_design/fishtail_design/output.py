"""What a synthesis writes: ``front.csv`` and, for each design picked, files the suite runs.

A pick's directory holds a kinematics parameter file (the linkage, in config/<mechanism>.yaml's
form, with the reference file's link masses), the fish file and a motor file whose default ratio
is the design's: ``make run CONFIG=<dir>/kinematics.yaml``, ``fishtail-swim simulate --config
<dir>/kinematics.yaml --fish <dir>/fish.yaml`` and ``fishtail-swim motor --motor
<dir>/motor.yaml`` take them unchanged. Columns and files: docs/design.md ("Output").
"""

from __future__ import annotations

import csv
import dataclasses
import shutil
from pathlib import Path

import numpy as np
import yaml

from fishtail_common.parameter_files import load_parameter_file
from fishtail_design.columns import figure_column, margin_column, objective_column
from fishtail_design.evaluation import FIGURES
from fishtail_design.outcome import Designs, Outcome
from fishtail_design.variables import GEAR_RATIO, unit_of
from fishtail_design.verification import Verified
from fishtail_kinematics.engine.parameters import GEOMETRY_PARAMETER_NAMES, MECHANISM
from fishtail_plant.motor.motor_file import write_motor_file


def front_columns(outcome: Outcome, designs: Designs) -> list[tuple[str, list[object]]]:
    """``front.csv``'s columns: rank, mechanism, variables, objectives, margins, figures.

    The search's and the verified figures; a variable or a margin that a design's mechanism
    does not have is NaN in its row.
    """
    problem = outcome.problem
    columns: list[tuple[str, list[object]]] = [
        ("rank", list(range(1, designs.count + 1))), ("mechanism", list(designs.mechanisms)),
    ]  # fmt: skip
    for name in outcome.variable_names():
        columns.append((name, designs.values[name].tolist()))
    for index, objective in enumerate(problem.objectives):
        columns.append((objective_column(objective), designs.scores.objectives[:, index].tolist()))
    for index, constraint in enumerate(outcome.constraints):
        columns.append((margin_column(constraint), designs.scores.margins[:, index].tolist()))
    columns.append(("binding", list(designs.binding)))
    for index, field in enumerate(FIGURES):
        columns.append((figure_column("search", field), designs.scores.figures[:, index].tolist()))
    for field in Verified._fields:
        values = np.asarray(getattr(designs.verified, field)).tolist()
        columns.append((figure_column("verified", field), values))
    return columns


def write_front(outcome: Outcome, path: Path) -> None:
    """``front.csv``: every design of the front, ranked on its verified figures."""
    columns = front_columns(outcome, outcome.front)
    with path.open("w", newline="", encoding="utf-8") as stream:
        writer = csv.writer(stream)
        writer.writerow([name for name, _ in columns])
        for row in zip(*(values for _, values in columns), strict=True):
            writer.writerow([f"{value:.10g}" if isinstance(value, float) else value
                             for value in row])  # fmt: skip


def write_pick(outcome: Outcome, index: int, directory: Path) -> list[Path]:
    """The kinematics, fish and motor files of front design ``index`` in ``directory``."""
    problem = outcome.problem_of(outcome.front.mechanisms[index])
    directory.mkdir(parents=True, exist_ok=True)
    values = outcome.front.values
    reference = load_parameter_file(problem.reference_path)
    masses = {name: value for name, value in reference.items()
              if name not in GEOMETRY_PARAMETER_NAMES}  # fmt: skip
    geometry: dict[str, object] = {MECHANISM.name: problem.mechanism}
    geometry |= {name: float(values[name][index]) for name in problem.space.linkage_names}
    geometry["phase_rad"] = 0.0
    kinematics = directory / "kinematics.yaml"
    rank = index + 1
    header = (
        f"# fishtail-design: design {rank} of the front of {problem.path.name} "
        f"({problem.mechanism}).\n# The linkage; the links' masses are the reference file's "
        f"({problem.reference_path.name}), not re-derived for these lengths.\n"
    )
    body = yaml.safe_dump({"/**": {"ros__parameters": geometry | masses}}, sort_keys=False)
    kinematics.write_text(header + body, encoding="utf-8")
    fish = directory / "fish.yaml"
    shutil.copyfile(problem.fish_path, fish)
    motor = directory / "motor.yaml"
    ratio = float(values[GEAR_RATIO][index])
    gearbox = dataclasses.replace(problem.motor.gearbox, default_ratio=ratio)
    write_motor_file(dataclasses.replace(problem.motor, gearbox=gearbox), motor)
    return [kinematics, fish, motor]


def variable_text(designs: Designs, name: str, index: int) -> str:
    """One variable of one design with its unit, for the report."""
    value = float(designs.values[name][index])
    unit = unit_of(name)
    return f"{value:.4g} {unit}".strip()
