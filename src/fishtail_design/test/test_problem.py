import math
from pathlib import Path

import pytest
import yaml

from fishtail_common.parameter_files import default_parameter_file
from fishtail_design.errors import ProblemFileError
from fishtail_design.problem import read_problem

WORKED = default_parameter_file("design/report-fish")


def _write(tmp_path: Path, changes: dict[str, object], drop: tuple[str, ...] = ()) -> Path:
    document = yaml.safe_load(WORKED.read_text())
    config = WORKED.parent.parent
    document["fish"] = str(config / "fish.yaml")
    document["motor"] = str(config / "motors" / "pololu-37d-12v.yaml")
    document["reference"] = str(config / "oscillatory.yaml")
    for key in drop:
        section, _, name = key.partition(".")
        if name:
            del document[section][name]
        else:
            del document[section]
    for key, value in changes.items():
        section, _, name = key.partition(".")
        if name:
            document.setdefault(section, {})[name] = value
        else:
            document[section] = value
    path = tmp_path / "problem.yaml"
    path.write_text(yaml.safe_dump(document))
    return path


def test_the_worked_problem_reads_with_the_hull_of_the_fish():
    problem = read_problem(WORKED)
    assert problem.mechanism == "oscillatory"
    assert [objective.name for objective in problem.objectives] == ["speed", "cost_of_transport"]
    # A prolate spheroid 0.5 m by 0.2 m, O 0.05 m behind its centre: its width there.
    assert problem.limits.hull_width_at_o_m == pytest.approx(0.2 * math.sqrt(1.0 - 0.2**2))
    assert problem.limits.length_behind_o_m == pytest.approx(0.2)
    assert problem.space.gear_ratios == problem.motor.gear_ratios
    assert problem.limits.motor_continuous_current_a == problem.motor.continuous_current_a


@pytest.mark.parametrize(
    ("changes", "drop", "message"),
    [
        ({"colour": "red"}, (), r"colour: unknown key"),
        ({"mechanism": "flapping"}, (), r"mechanism: 'flapping' is not one of"),
        ({"variables.ring_radius_m": [0.1, 0.05]}, (), r"variables.ring_radius_m: low 0.1 must"),
        ({"variables.ring_radius_m": "big"}, (), r"variables.ring_radius_m must be a number"),
        ({}, ("variables.tail_link_m",), r"variables.tail_link_m: not set"),
        ({"variables.fin_link_m": 0.1}, (), r"variables.fin_link_m: unknown key"),
        ({"variables.gear_ratio": 33.0}, (), r"does not come with 33:1"),
        ({"objectives": ["speed"]}, (), r"objectives: pick two to four"),
        ({"objectives": ["speed", "beauty"]}, (), r"objectives: unknown 'beauty'"),
        ({"constraints.min_transmission_angle_deg": 120}, (), r"outside \[0, 90\]"),
        ({"constraints.symmetry": {"time_share_warn": 0.5}}, (), r"constraints.symmetry:"),
        ({"constraints.strouhal_number": [0.4, 0.2]}, (), r"low 0.4 must be below high 0.2"),
        ({"search.population": 2}, (), r"search.population must be an integer"),
        ({"fish": "missing.yaml"}, (), r"fish: no such file"),
        ({"turning_depth": 0.95}, (), r"turning_depth = 0.95 is outside"),
    ],
)
def test_a_bad_problem_is_refused_in_one_line_naming_the_file_and_the_key(
    tmp_path, changes, drop, message
):
    path = _write(tmp_path, changes, drop)
    with pytest.raises(ProblemFileError, match=message) as caught:
        read_problem(path)
    text = str(caught.value)
    assert text.startswith(f"{path}: ") and "\n" not in text


def test_a_file_that_is_not_yaml_or_not_a_mapping_is_refused(tmp_path):
    path = tmp_path / "p.yaml"
    path.write_text("objectives: [speed\n")
    with pytest.raises(ProblemFileError, match="not YAML"):
        read_problem(path)
    path.write_text("- a list\n")
    with pytest.raises(ProblemFileError, match="must be a mapping"):
        read_problem(path)
    with pytest.raises(ProblemFileError, match="cannot read it"):
        read_problem(tmp_path / "absent.yaml")


def test_paths_are_relative_to_the_problem_file(tmp_path):
    path = _write(tmp_path, {})
    document = yaml.safe_load(path.read_text())
    (tmp_path / "fish.yaml").write_text(Path(document["fish"]).read_text())
    document["fish"] = "fish.yaml"
    path.write_text(yaml.safe_dump(document))
    assert read_problem(path).fish_path == tmp_path / "fish.yaml"
