import csv
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from fishtail_common.parameter_files import default_parameter_file, load_parameter_file
from fishtail_design.errors import ProblemFileError
from fishtail_design.outcome import merge_outcomes, outcome, reference_values
from fishtail_design.output import write_front, write_pick
from fishtail_design.plots import draw_front
from fishtail_design.problem import read_problem, read_problems
from fishtail_design.report import write_report
from fishtail_design.verification import Verified

BOTH = default_parameter_file("design/report-fish-both")


def _write(tmp_path: Path, document: dict[str, object]) -> Path:
    config = BOTH.parent.parent
    document = {"fish": str(config / "fish.yaml"),
                "motor": str(config / "motors" / "pololu-37d-12v.yaml")} | document  # fmt: skip
    path = tmp_path / "problem.yaml"
    path.write_text(yaml.safe_dump(document))
    return path


def _both_document() -> dict[str, object]:
    document = yaml.safe_load(BOTH.read_text())
    for key in ("fish", "motor", "reference"):
        del document[key]
    return document


def test_both_is_a_problem_per_mechanism_sharing_all_but_variables_and_reference():
    oscillatory, undulatory = read_problems(BOTH)
    assert (oscillatory.mechanism, undulatory.mechanism) == ("oscillatory", "undulatory")
    assert oscillatory.reference_path.name == "oscillatory.yaml"
    assert undulatory.reference_path.name == "undulatory.yaml"
    assert "swing_arm_m" in undulatory.space.names and "tail_link_m" in oscillatory.space.names
    assert oscillatory.limits == undulatory.limits
    assert oscillatory.objectives == undulatory.objectives
    assert oscillatory.search == undulatory.search
    # A file of one mechanism is one problem; the one-problem reader refuses both.
    assert len(read_problems(default_parameter_file("design/report-fish-undulatory"))) == 1
    with pytest.raises(ProblemFileError, match="mechanism: both asks for a search of each"):
        read_problem(BOTH)


def test_both_without_references_takes_each_mechanism_s_default(tmp_path):
    problems = read_problems(_write(tmp_path, _both_document()))
    assert [p.reference_path.name for p in problems] == ["oscillatory.yaml", "undulatory.yaml"]


def _set(section: str, name: str, value: object):
    def change(document: dict[str, object]) -> None:
        document[section] = dict(document.get(section) or {}) | {name: value}

    return change


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (_set("variables", "oscillatory", {"gear_ratio": "catalogue"}),
         "variables.oscillatory.ring_radius_m: not set"),
        (_set("variables", "undulatory", 0.1), "variables.undulatory must be a mapping"),
        (_set("variables", "fish", {}), "variables.fish: unknown key"),
        (_set("reference", "undulatory", "nowhere.yaml"), "reference.undulatory: no such file"),
        (_set("reference", "both", "nowhere.yaml"), "reference.both: unknown key"),
    ],
)  # fmt: skip
def test_a_bad_both_file_is_refused_naming_the_mechanism_s_section(tmp_path, change, message):
    document = _both_document()
    change(document)
    with pytest.raises(ProblemFileError, match=message):
        read_problems(_write(tmp_path, document))


def _verified(count: int, speeds: list[float]) -> Verified:
    """Verified figures made up for the merge: sustained, swimming at ``speeds`` (L/s)."""
    figures = Verified(*(np.full(count, 1.0) for _ in Verified._fields))
    speed = np.array(speeds)
    return figures._replace(
        body_lengths_per_s=speed,
        speed_m_s=0.5 * speed,
        cost_of_transport_j_kg_m=2.0 + speed,
        rms_current_a=np.full(count, 0.5),
        peak_current_a=np.full(count, 1.0),
    )


def _outcomes():
    problems = read_problems(BOTH)
    parts = []
    for problem, speeds in zip(problems, ([1.0, 3.0], [2.0]), strict=True):
        reference = reference_values(problem)
        row = problem.space.encode({name: float(value[0]) for name, value in reference.items()})
        rows = np.repeat(row[None, :], len(speeds), axis=0)
        parts.append(outcome(problem, rows, _verified(len(speeds), speeds), 10, 2,
                             _verified(1, [0.5])))  # fmt: skip
    return problems, parts


def test_the_fronts_of_both_mechanisms_are_ranked_together_each_design_with_its_own():
    problems, parts = _outcomes()
    merged = merge_outcomes(parts)
    assert merged.front.count == 3 and merged.evaluated == 20
    # By the first objective, speed, on the verified figures, whatever the mechanism.
    assert merged.front.mechanisms == ("oscillatory", "undulatory", "oscillatory")
    assert merged.front.verified.body_lengths_per_s.tolist() == [3.0, 2.0, 1.0]
    assert merged.reference.mechanisms == ("oscillatory", "undulatory")
    names = [constraint.name for constraint in merged.constraints]
    assert names[:3] == ["assembly_inner", "assembly_outer", "second_loop"]
    second_loop = merged.front.scores.margins[:, names.index("second_loop")]
    assert np.isnan(second_loop[[0, 2]]).all() and second_loop[1] == pytest.approx(0.02)
    assert math.isnan(merged.front.values["swing_arm_m"][0])
    assert math.isnan(merged.front.values["tail_link_m"][1])
    assert merged.front.values["swing_arm_m"][1] == pytest.approx(0.16)
    # The same design in its own outcome and in the merged one: the same margins.
    own = dict(zip([c.name for c in parts[1].constraints], parts[1].front.scores.margins[0],
                   strict=True))  # fmt: skip
    for index, name in enumerate(names):
        assert merged.front.scores.margins[1, index] == own[name]
    assert merged.problem_of("undulatory") is problems[1]


def test_both_writes_one_front_with_a_mechanism_column_and_picks_of_their_mechanism(tmp_path):
    _, parts = _outcomes()
    merged = merge_outcomes(parts)
    write_front(merged, tmp_path / "front.csv")
    with (tmp_path / "front.csv").open() as stream:
        rows = list(csv.DictReader(stream))
    assert [row["mechanism"] for row in rows] == ["oscillatory", "undulatory", "oscillatory"]
    assert rows[1]["margin_second_loop_m"] != "nan" and rows[0]["margin_second_loop_m"] == "nan"
    for index, mechanism in ((0, "oscillatory"), (1, "undulatory")):
        write_pick(merged, index, tmp_path / mechanism)
        values = load_parameter_file(tmp_path / mechanism / "kinematics.yaml")
        assert values["mechanism"] == mechanism
    assert "swing_arm_m" in load_parameter_file(tmp_path / "undulatory" / "kinematics.yaml")
    write_report(merged, [("fastest", 0)], tmp_path / "report.md", {})
    report = (tmp_path / "report.md").read_text()
    assert "reference (oscillatory.yaml) | reference (undulatory.yaml) | fastest" in report
    assert "as the oscillatory reference" in report
    draw_front(merged, tmp_path / "front.png")
    assert (tmp_path / "front.png").stat().st_size > 10_000
