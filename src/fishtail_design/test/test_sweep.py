import csv
import functools
import itertools
import json
import math
import random
import re
import tracemalloc
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

from fishtail_common.parameter_files import default_parameter_file
from fishtail_design.errors import DesignError, ExecutorError
from fishtail_design.evaluation import FIGURES, Scores, constraint_list, evaluate_rows
from fishtail_design.executors import InProcessExecutor, LocalProcessExecutor
from fishtail_design.problem import Problem, read_problem
from fishtail_design.sweep import (
    COMPLETE_NAME,
    Grid,
    chunks,
    grid,
    latin_hypercube,
    sweep,
    sweep_columns,
    sweep_table,
)
from fishtail_design.sweep_command import sweep_main
from fishtail_design.variables import DesignSpace

WORKED = default_parameter_file("design/report-fish")
FloatArray = np.ndarray


@pytest.fixture(scope="module")
def problem() -> Problem:
    return read_problem(WORKED)


def _space(ratios: tuple[float, ...] = (10.0, 30.0, 50.0)) -> DesignSpace:
    settings = {"ring_radius_m": (0.02, 0.1), "crank_link_m": 0.1, "tail_link_m": (0.1, 0.3),
                "pivot_offset_m": 0.2, "carrier_speed_rad_s": (5.0, 20.0)}  # fmt: skip
    return DesignSpace("oscillatory", settings, True, ratios, (0.9,) * len(ratios))


def _read_csv(path: Path) -> tuple[list[str], FloatArray]:
    """The header and the numbers of a sweep's CSV (feasible as 1.0 / 0.0)."""
    with path.open(newline="", encoding="utf-8") as stream:
        reader = csv.reader(stream)
        header = next(reader)
        rows = [[{"True": 1.0, "False": 0.0}.get(text, None) if text in ("True", "False")
                 else float(text) for text in row] for row in reader]  # fmt: skip
    return header, np.array(rows, dtype=float).reshape(len(rows), len(header))


def _read_parquet(path: Path) -> tuple[list[str], FloatArray]:
    table = pq.read_table(path)
    columns = [np.asarray(column.to_numpy(), dtype=float) for column in table.columns]
    return table.column_names, np.column_stack(columns)


def _expected(problem: Problem, rows: FloatArray) -> FloatArray:
    """One evaluate_rows call over every design, as a sweep's table."""
    table = sweep_table(problem, rows, evaluate_rows(problem, rows))
    return np.column_stack([np.asarray(column, dtype=float) for column in table])


def _assert_same_designs(actual: FloatArray, expected: FloatArray) -> None:
    """The same numbers to the bit (a design scores the same in any batch), NaN where NaN."""
    np.testing.assert_array_equal(actual, expected)


def test_a_latin_hypercube_puts_one_design_in_each_stratum_of_every_variable() -> None:
    space = _space()
    count = 97
    points = latin_hypercube(space, count, seed=5)
    assert points.shape == (count, len(space.names))
    for column, low, high in zip(points.T, space.lower, space.upper, strict=True):
        assert np.all((column >= low) & (column <= high))
        strata = np.floor((column - low) / (high - low) * count).astype(int)
        assert sorted(strata.tolist()) == list(range(count))
    np.testing.assert_array_equal(points, latin_hypercube(space, count, seed=5))
    assert not np.array_equal(points, latin_hypercube(space, count, seed=6))


def test_a_grid_is_the_full_factorial_last_variable_fastest_with_each_catalogue_ratio() -> None:
    space = _space()
    points = grid(space, 4)
    assert space.names == ("ring_radius_m", "tail_link_m", "carrier_speed_rad_s", "gear_index")
    assert points.shape == (4, 4, 4, 3)
    assert points.count == 4**3 * 3
    axes = [np.linspace(0.02, 0.1, 4), np.linspace(0.1, 0.3, 4), np.linspace(5.0, 20.0, 4),
            np.array([0.5, 1.5, 2.5])]  # fmt: skip
    expected = np.array(list(itertools.product(*axes)))
    np.testing.assert_array_equal(points.rows(0, points.count), expected)
    chunked = np.concatenate(list(chunks(points, 7)))
    np.testing.assert_array_equal(chunked, expected)
    assert [chunk.shape[0] for chunk in chunks(points, 50)] == [50, 50, 50, 42]
    decoded = space.decode(expected)
    assert sorted(set(decoded["gear_ratio"].tolist())) == [10.0, 30.0, 50.0]


def test_a_grid_of_a_million_million_designs_makes_any_rows_without_the_rest() -> None:
    points = grid(_space(), 10_000)
    assert points.count == 10_000**3 * 3
    last = points.rows(points.count - 2, points.count + 5)
    np.testing.assert_array_equal(last, [[0.1, 0.3, 20.0, 1.5], [0.1, 0.3, 20.0, 2.5]])


def test_a_chunked_sweep_is_one_evaluation_row_for_row(problem: Problem, tmp_path: Path) -> None:
    points = latin_hypercube(problem.space, 45, seed=3)
    path = tmp_path / "sweep.csv"
    done: list[int] = []
    with InProcessExecutor() as executor:
        result = sweep(problem, points, path, executor, chunk_size=16, batch_size=5,
                       progress=done.append)  # fmt: skip
    header, values = _read_csv(path)
    assert header == sweep_columns(problem)
    _assert_same_designs(values, _expected(problem, points))
    assert result.designs == 45
    assert result.feasible == int(values[:, header.index("feasible")].sum())
    # A progress call per batch, counting up to every design.
    assert done == sorted(done) and done[-1] == 45 and len(done) == 4 + 4 + 3


def test_the_columns_are_the_variables_objectives_margins_feasible_and_figures(
    problem: Problem,
) -> None:
    columns = sweep_columns(problem)
    margins = [name for name in columns if name.startswith("margin_")]
    assert columns[:8] == ["ring_radius_m", "crank_link_m", "rocker_link_m", "tail_link_m",
                           "pivot_offset_m", "gear_ratio", "gearbox_efficiency",
                           "carrier_speed_rad_s"]  # fmt: skip
    assert columns[8:10] == ["speed_L_per_s", "cost_of_transport_J_per_(kg_m)"]
    assert len(margins) == len(constraint_list(problem))
    assert "margin_rms_current_A" in margins
    assert columns[10 + len(margins)] == "feasible"
    assert columns[11 + len(margins) :] == [f"search_{field}" for field in FIGURES]


def test_the_same_seed_writes_the_same_file(problem: Problem, tmp_path: Path) -> None:
    files = []
    for name, seed in (("a", 7), ("b", 7), ("c", 8)):
        for suffix in (".csv", ".parquet"):
            path = tmp_path / f"{name}{suffix}"
            with InProcessExecutor() as executor:
                sweep(problem, latin_hypercube(problem.space, 12, seed), path, executor, 5, 3)
            files.append(path.read_bytes())
    assert files[0] == files[2] and files[1] == files[3]
    assert files[0] != files[4] and files[1] != files[5]


def test_csv_and_parquet_hold_the_same_numbers(problem: Problem, tmp_path: Path) -> None:
    points = latin_hypercube(problem.space, 30, seed=2)
    for suffix in (".csv", ".parquet"):
        with InProcessExecutor() as executor:
            sweep(problem, points, tmp_path / f"sweep{suffix}", executor, 8, 4)
    csv_header, csv_values = _read_csv(tmp_path / "sweep.csv")
    parquet_header, parquet_values = _read_parquet(tmp_path / "sweep.parquet")
    assert csv_header == parquet_header
    np.testing.assert_array_equal(csv_values, parquet_values)
    parquet = pq.ParquetFile(tmp_path / "sweep.parquet")
    assert parquet.metadata.num_row_groups == 4  # a row group per chunk of 8
    assert str(parquet.schema_arrow.field("feasible").type) == "bool"
    assert str(parquet.schema_arrow.field("speed_L_per_s").type) == "double"


class _Shuffling:
    """A stand-in executor: a map's batches come back in a random order, as from a pool.

    It records the most batches that were handed over and not yet given back.
    """

    description = "shuffled"

    def __init__(self, seed: int) -> None:
        self.random = random.Random(seed)
        self.outstanding = 0
        self.most_outstanding = 0

    def map_batches(
        self, function: Callable[[FloatArray], Scores], batches: Sequence[FloatArray]
    ) -> Iterator[tuple[int, Scores]]:
        self.outstanding += len(batches)
        self.most_outstanding = max(self.most_outstanding, self.outstanding)
        order = list(range(len(batches)))
        self.random.shuffle(order)
        for index in order:
            self.outstanding -= 1
            yield index, function(batches[index])


def test_out_of_order_batches_are_written_in_order_two_chunks_at_most(
    problem: Problem, tmp_path: Path
) -> None:
    points = grid(problem.space, 2)  # 2^4 x 9 ratios
    executor = _Shuffling(seed=1)
    sweep(problem, points, tmp_path / "sweep.csv", executor, chunk_size=20, batch_size=3)
    _, values = _read_csv(tmp_path / "sweep.csv")
    _assert_same_designs(values, _expected(problem, points.rows(0, points.count)))
    assert executor.most_outstanding <= 2 * math.ceil(20 / 3)


def _cheap(shape: tuple[int, int, int], rows: FloatArray) -> Scores:
    """Scores of the right shape from a few operations per design (the memory test's stand-in)."""
    objectives, margins, figures = shape
    first = rows[:, :1]
    return Scores(np.repeat(first, objectives, axis=1), np.repeat(first - 0.05, margins, axis=1),
                  np.repeat(2.0 * first, figures, axis=1))  # fmt: skip


def _peak(problem: Problem, points: Grid, path: Path, chunk_size: int) -> int:
    shape = (len(problem.objectives), len(constraint_list(problem)), len(FIGURES))
    function = functools.partial(_cheap, shape)
    tracemalloc.start()
    try:
        with InProcessExecutor() as executor:
            sweep(problem, points, path, executor, chunk_size, 500, function=function)
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def _designs(count: int) -> Grid:
    """``count`` designs of the worked problem's space, ring radius x crank x tail link."""
    return Grid((np.linspace(0.02, 0.1, count // 100), np.linspace(0.02, 0.2, 10),
                 np.linspace(0.08, 0.3, 10), np.array([0.1]), np.array([0.5])))  # fmt: skip


@pytest.mark.parametrize("suffix", [pytest.param(".csv", marks=pytest.mark.slow), ".parquet"])
def test_memory_holds_a_few_chunks_whatever_the_number_of_designs(
    problem: Problem, tmp_path: Path, suffix: str
) -> None:
    chunk = 200
    _peak(problem, _designs(chunk), tmp_path / f"warm{suffix}", chunk)  # imports, caches
    one = _peak(problem, _designs(chunk), tmp_path / f"one{suffix}", chunk)
    twenty = _peak(problem, _designs(20 * chunk), tmp_path / f"twenty{suffix}", chunk)
    # At most two chunks held at a time, against one chunk alone.
    assert twenty < 4 * one, (twenty, one)
    # A sweep that held every design would peak as one chunk of them all does.
    whole = _peak(problem, _designs(20 * chunk), tmp_path / f"whole{suffix}", 20 * chunk)
    assert whole > 4 * twenty, (whole, twenty)


def test_bad_inputs_are_refused_in_one_line(problem: Problem, tmp_path: Path) -> None:
    with pytest.raises(DesignError, match=r"must be a \.csv or \.parquet file, not \.txt"):
        sweep(problem, np.zeros((1, 5)), tmp_path / "sweep.txt", InProcessExecutor())
    with pytest.raises(DesignError, match="takes 1 to"):
        latin_hypercube(problem.space, 0, seed=1)
    with pytest.raises(DesignError, match="at least 2 points per variable"):
        grid(problem.space, 1)
    fixed = DesignSpace("oscillatory", {"ring_radius_m": 0.05, "crank_link_m": 0.1,
                                        "tail_link_m": 0.15, "pivot_offset_m": 0.2,
                                        "gear_ratio": 30.0, "carrier_speed_rad_s": 10.0},
                        symmetric_rocker=True)  # fmt: skip
    with pytest.raises(DesignError, match="no free variable"):
        grid(fixed, 3)


@pytest.mark.parametrize(
    ("options", "status", "message"),
    [
        (["--designs", "0", "--output", "s.csv"], 2, r"designs = 0 is outside \[1, "),
        (["--designs", "5", "--output", "s.txt"], 2, r"must be a \.csv or \.parquet file"),
        (["--output", "s.csv"], 2, r"--method lhs needs --designs N"),
        (["--method", "grid", "--output", "s.csv"], 2, r"needs --points-per-variable K"),
        (["--designs", "5", "--points-per-variable", "3", "--output", "s.csv"], 2,
         r"--points-per-variable is for --method grid"),
        (["--method", "grid", "--points-per-variable", "3", "--seed", "2", "--output", "s.csv"],
         2, r"--seed is for --method lhs"),
        (["--method", "grid", "--points-per-variable", "2", "--designs", "100", "--output",
          "s.csv"], 1, r"--designs 100 disagrees with a grid of 2\^4 x 9 catalogue ratios = "
         r"144 designs"),
        (["--method", "grid", "--points-per-variable", "40", "--output", "s.csv"], 1,
         r"= 23,040,000 designs: give --designs 23040000 to run a grid this large"),
        (["--method", "grid", "--points-per-variable", "2000", "--designs", "5", "--output",
          "s.csv"], 1, r"more than the 1,000,000,000,000 a sweep takes"),
    ],
)  # fmt: skip
def test_bad_options_are_refused_in_one_line(
    options: list[str],
    status: int,
    message: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.chdir(tmp_path)
    if status == 2:
        with pytest.raises(SystemExit) as exit_:
            sweep_main([str(WORKED), *options])
        assert exit_.value.code == 2
    else:
        assert sweep_main([str(WORKED), *options]) == 1
    error = capsys.readouterr().err
    assert error.startswith("fishtail-design: ") and error.count("\n") == 1, error
    assert re.search(message, error), error
    assert not list(tmp_path.iterdir())


def test_the_command_writes_the_file_and_says_so(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "out" / "sweep.parquet"
    status = sweep_main([str(WORKED), "--designs", "20", "--seed", "4", "--chunk-size", "8",
                        "--batch-size", "4", "--output", str(path)])  # fmt: skip
    assert status == 0
    captured = capsys.readouterr()
    assert captured.out.startswith("fishtail-design: wrote 20 designs (")
    assert f"to {path} in " in captured.out
    assert "a Latin hypercube of 20 designs (seed 4)" in captured.err
    assert "sweep: 20/20 designs, " in captured.err and "designs/s" in captured.err
    header, values = _read_parquet(path)
    problem = read_problem(WORKED)
    _assert_same_designs(values, _expected(problem, latin_hypercube(problem.space, 20, 4)))
    assert header == sweep_columns(problem)


@pytest.mark.integration
def test_local_processes_write_the_in_process_file(problem: Problem, tmp_path: Path) -> None:
    points = latin_hypercube(problem.space, 40, seed=9)
    with InProcessExecutor() as executor:
        sweep(problem, points, tmp_path / "one.csv", executor, 10, 3)
    with LocalProcessExecutor(2) as executor:
        sweep(problem, points, tmp_path / "two.csv", executor, 10, 3)
    assert (tmp_path / "one.csv").read_bytes() == (tmp_path / "two.csv").read_bytes()


def _read_parts(folder: Path) -> tuple[list[str], FloatArray]:
    """A parts folder read back as one dataset (pyarrow takes the files in their names' order)."""
    return _read_parquet(folder)


def test_parts_read_back_as_the_single_file(problem: Problem, tmp_path: Path) -> None:
    points = latin_hypercube(problem.space, 45, seed=3)
    with InProcessExecutor() as executor:
        sweep(problem, points, tmp_path / "one.parquet", executor, 4, 3)
        folder = tmp_path / "parts.parquet"
        folder.mkdir()
        (folder / "part-000099.parquet").write_bytes(b"a stale part")
        done: list[int] = []
        result = sweep(problem, points, folder, executor, 4, 3, done.append, parts=True)
    names = sorted(path.name for path in folder.iterdir())
    # The stale part gone; the completion record last, with the counts.
    assert names == [COMPLETE_NAME, *(f"part-{index:06d}.parquet" for index in range(12))]
    assert json.loads((folder / COMPLETE_NAME).read_text()) == {
        "parts": 12, "designs": 45, "feasible": result.feasible
    }
    header, values = _read_parts(folder)
    assert (header, values.tobytes()) == (
        _read_parquet(tmp_path / "one.parquet")[0],
        _read_parquet(tmp_path / "one.parquet")[1].tobytes(),
    )
    assert result.designs == 45
    assert result.feasible == int(values[:, header.index("feasible")].sum())
    assert done[-1] == 45 and done == sorted(done) and len(done) == 12
    parquet = pq.ParquetFile(folder / "part-000011.parquet")
    assert parquet.metadata.num_rows == 1 and parquet.schema_arrow.names == header
    with pytest.raises(DesignError, match="parts are Parquet files"):
        sweep(problem, points, tmp_path / "parts.csv", InProcessExecutor(), parts=True)
    (tmp_path / "file.parquet").write_bytes(b"")
    with pytest.raises(DesignError, match="writes a folder, and this is a file"):
        sweep(problem, points, tmp_path / "file.parquet", InProcessExecutor(), parts=True)


def test_a_parts_sweep_that_stops_part_way_leaves_no_completion_record(
    problem: Problem, tmp_path: Path
) -> None:
    points = latin_hypercube(problem.space, 20, seed=3)
    folder = tmp_path / "parts.parquet"
    with InProcessExecutor() as executor:
        sweep(problem, points, folder, executor, 4, parts=True)
        assert (folder / COMPLETE_NAME).exists()
        calls: list[int] = []

        def fails_on_the_third_chunk(rows: FloatArray) -> Scores:
            calls.append(rows.shape[0])
            if len(calls) == 3:
                raise RuntimeError("a worker died")
            return evaluate_rows(problem, rows)

        with pytest.raises((RuntimeError, ExecutorError)):
            sweep(problem, points, folder, executor, 4, function=fails_on_the_third_chunk,
                  parts=True)  # fmt: skip
    # The earlier sweep's record is gone with its parts: a reader can tell the folder is short.
    assert not (folder / COMPLETE_NAME).exists()
    assert len(list(folder.glob("part-*.parquet"))) == 2


def test_the_command_writes_parts_and_says_so(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "out" / "sweep.parquet"
    status = sweep_main([str(WORKED), "--designs", "20", "--seed", "4", "--chunk-size", "8",
                        "--parts", "--output", str(path)])  # fmt: skip
    assert status == 0
    captured = capsys.readouterr()
    assert f"to {path}/ (3 part files) in " in captured.out, captured.out
    assert f"writing {path}/part-*.parquet" in captured.err, captured.err
    header, values = _read_parts(path)
    problem = read_problem(WORKED)
    _assert_same_designs(values, _expected(problem, latin_hypercube(problem.space, 20, 4)))
    assert header == sweep_columns(problem)


@pytest.mark.integration
def test_parts_written_by_dask_workers_and_a_pool_are_the_in_process_parts(
    problem: Problem, tmp_path: Path
) -> None:
    pytest.importorskip("distributed")
    from fishtail_design.dask_executor import DaskExecutor

    points = latin_hypercube(problem.space, 150, seed=11)
    with InProcessExecutor() as executor:
        sweep(problem, points, tmp_path / "one.parquet", executor, 10, 3)
        sweep(problem, points, tmp_path / "in-process.parquet", executor, 10, parts=True)
    with LocalProcessExecutor(2) as executor:
        sweep(problem, points, tmp_path / "pool.parquet", executor, 10, parts=True)
    with DaskExecutor(workers=2) as executor:
        result = sweep(problem, points, tmp_path / "dask.parquet", executor, 10, parts=True)
    assert result.designs == 150
    expected = _read_parquet(tmp_path / "one.parquet")
    for name in ("in-process", "pool", "dask"):
        folder = tmp_path / f"{name}.parquet"
        header, values = _read_parts(folder)
        assert header == expected[0]
        _assert_same_designs(values, expected[1])
        files = sorted(folder.glob("part-*"))
        assert [path.name for path in files] == [f"part-{i:06d}.parquet" for i in range(15)]
        assert json.loads((folder / COMPLETE_NAME).read_text())["parts"] == 15
        for path in files:  # the same bytes, whoever wrote them
            assert path.read_bytes() == (tmp_path / "in-process.parquet" / path.name).read_bytes()
