import numpy as np

from fishtail_common.parameter_files import default_parameter_file
from fishtail_design.evaluation import FIGURES, constraint_list, evaluate_rows
from fishtail_design.problem import read_problem

PROBLEM = read_problem(default_parameter_file("design/report-fish"))


def _rows(count: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    space = PROBLEM.space
    return space.lower + rng.random((count, len(space.names))) * (space.upper - space.lower)


def test_a_design_s_scores_do_not_depend_on_the_batch_it_is_evaluated_in():
    rows = _rows(120, seed=5)
    whole = evaluate_rows(PROBLEM, rows)
    parts = [evaluate_rows(PROBLEM, rows[start : start + 7]) for start in range(0, 120, 7)]
    for field, values in zip(whole._fields, whole, strict=True):
        joined = np.concatenate([getattr(part, field) for part in parts])
        assert np.array_equal(values, joined, equal_nan=True), field


def test_the_scores_have_a_column_per_objective_constraint_and_figure():
    scores = evaluate_rows(PROBLEM, _rows(9, seed=6))
    assert scores.objectives.shape == (9, len(PROBLEM.objectives))
    assert scores.margins.shape == (9, len(constraint_list(PROBLEM)))
    assert scores.figures.shape == (9, len(FIGURES))
    # Margins are numbers or -inf (a figure that could not be computed), never NaN.
    assert not np.isnan(scores.margins).any()
