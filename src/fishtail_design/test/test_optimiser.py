import shutil

import numpy as np
import pytest

from fishtail_design.errors import CheckpointError
from fishtail_design.evaluation import Scores
from fishtail_design.executors import InProcessExecutor
from fishtail_design.optimiser import GenerationReport, SearchSpace, search

# ZDT1 on three variables (Zitzler, Deb and Thiele 2000), with a constraint x1 <= 0.8: its front
# is x2 = x3 = 0, f2 = 1 - sqrt(f1), f1 in [0, 0.8].


def zdt1(rows: np.ndarray) -> Scores:
    x = np.atleast_2d(rows)
    first = x[:, 0]
    g = 1.0 + 9.0 * x[:, 1:].mean(axis=1)
    second = g * (1.0 - np.sqrt(first / g))
    objectives = np.stack([first, second], axis=1)
    margins = (0.8 - first)[:, None]
    return Scores(objectives, margins, np.zeros((x.shape[0], 1)))


def _space(generations: int = 60, seed: int = 7) -> SearchSpace:
    return SearchSpace(np.zeros(3), np.ones(3), (False, False), np.array([1.0]), 40, generations,
                       seed, "zdt1")  # fmt: skip


def test_nsga2_finds_a_known_front_and_keeps_infeasible_designs_out():
    result = search(_space(), zdt1, InProcessExecutor(), batch_size=16)
    first, second = result.scores.objectives.T
    assert first.max() <= 0.8
    # Every design of the front lies near the true one, and the front is spread along it.
    assert np.abs(second - (1.0 - np.sqrt(first))).max() < 0.05
    assert first.min() < 0.05 and first.max() > 0.7
    assert result.rows.shape[0] >= 20


def test_the_same_seed_gives_the_same_front_and_another_seed_another():
    one = search(_space(10), zdt1, InProcessExecutor(), batch_size=7)
    two = search(_space(10), zdt1, InProcessExecutor(), batch_size=40)
    other = search(_space(10, seed=8), zdt1, InProcessExecutor(), batch_size=7)
    assert np.array_equal(one.rows, two.rows)
    assert not np.array_equal(one.rows, other.rows)


def test_a_resumed_search_ends_where_an_uninterrupted_one_does(tmp_path):
    whole = search(_space(12), zdt1, InProcessExecutor(), 16)
    checkpoint = tmp_path / "checkpoint.pickle"
    kept = tmp_path / "after-5.pickle"

    class StopSearchError(Exception):
        pass

    def stop_after_five(report: GenerationReport) -> None:
        if report.generation == 5:
            shutil.copyfile(checkpoint, kept)
            raise StopSearchError

    with pytest.raises(StopSearchError):
        search(_space(12), zdt1, InProcessExecutor(), 16, checkpoint, report=stop_after_five)
    shutil.copyfile(kept, checkpoint)
    reports: list[GenerationReport] = []
    resumed = search(_space(12), zdt1, InProcessExecutor(), 16, checkpoint, resume=True,
                     report=reports.append)  # fmt: skip
    assert [report.generation for report in reports] == list(range(6, 13))
    assert reports[-1].evaluated == 12 * 40
    assert np.array_equal(resumed.rows, whole.rows)
    assert np.array_equal(resumed.scores.objectives, whole.scores.objectives)


def test_a_checkpoint_of_another_problem_or_none_is_refused(tmp_path):
    checkpoint = tmp_path / "checkpoint.pickle"
    search(_space(2), zdt1, InProcessExecutor(), 16, checkpoint)
    other = _space(2)._replace(fingerprint="another problem")
    with pytest.raises(CheckpointError, match="belongs to another problem"):
        search(other, zdt1, InProcessExecutor(), 16, checkpoint, resume=True)
    with pytest.raises(CheckpointError, match="no checkpoint"):
        search(_space(2), zdt1, InProcessExecutor(), 16, tmp_path / "absent", resume=True)
    checkpoint.write_bytes(b"not a pickle")
    with pytest.raises(CheckpointError, match="cannot read"):
        search(_space(2), zdt1, InProcessExecutor(), 16, checkpoint, resume=True)


@pytest.mark.integration
def test_the_synthesis_search_on_a_dask_cluster_ends_on_the_in_process_front():
    pytest.importorskip("distributed")
    import dataclasses

    from fishtail_common.parameter_files import default_parameter_file
    from fishtail_design.dask_executor import DaskExecutor
    from fishtail_design.optimiser import optimise
    from fishtail_design.problem import read_problem

    problem = read_problem(default_parameter_file("design/report-fish"))
    settings = dataclasses.replace(problem.search, population=12, generations=3, seed=11,
                                   samples_per_beat=64)  # fmt: skip
    problem = dataclasses.replace(problem, search=settings)
    alone = optimise(problem, InProcessExecutor(), batch_size=5)
    with DaskExecutor(workers=2) as cluster:
        spread = optimise(problem, cluster, batch_size=5)
    assert alone.rows.shape[0] > 0
    assert np.array_equal(alone.rows, spread.rows)
    for field, values in zip(alone.scores._fields, alone.scores, strict=True):
        assert np.array_equal(values, getattr(spread.scores, field), equal_nan=True), field
