"""``fishtail-design``: synthesise the tail drive for a fish and a motor, or sweep designs.

``fishtail-design PROBLEM.yaml`` runs the search, verifies its front and writes ``front.csv``,
``front.png``, ``report.md`` and the picked designs' files under ``--output-dir`` (for
``mechanism: both``, a search of each mechanism, its checkpoints in ``<mechanism>/``, the fronts
ranked together);
``fishtail-design sweep PROBLEM.yaml`` evaluates a grid or a Latin hypercube of designs for the
user's own analysis. Every bad input ends in one line. Usage: docs/design.md.
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import math
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from fishtail_common.command_line import OneLineErrorParser
from fishtail_design.errors import DesignError
from fishtail_design.evaluation import FIGURES
from fishtail_design.executor_options import add_executor_arguments, executor_from_arguments
from fishtail_design.executors import Executor, evaluate_in_batches
from fishtail_design.optimiser import (
    GenerationReport,
    SearchResult,
    optimise,
    refinement_space,
    search,
)
from fishtail_design.outcome import (
    PICKS,
    Outcome,
    merge_outcomes,
    outcome,
    reference_values,
    verify_reference,
)
from fishtail_design.output import write_front, write_pick
from fishtail_design.plots import draw_front
from fishtail_design.problem import Problem, read_problems
from fishtail_design.report import write_report
from fishtail_design.verification import Verified, verified_rows, verify_rows
from fishtail_plant.fish.fish import FloatArray

PROGRAM = "fishtail-design"
#: Where the results go unless --output-dir says otherwise (git-ignored).
DEFAULT_OUTPUT = Path("runs/design")
CHECKPOINT = "checkpoint.pickle"
REFINE_CHECKPOINT = "checkpoint-refinement.pickle"


def _pick(text: str) -> str:
    if text in PICKS or (text.isdigit() and int(text) >= 1):
        return text
    raise argparse.ArgumentTypeError(f"{text!r}: choose {', '.join(PICKS)} or a rank (1, 2, ...)")


def run_parser() -> OneLineErrorParser:
    """The options of a search."""
    parser = OneLineErrorParser(
        prog=PROGRAM,
        description="Search the linkage lengths, gear ratio and carrier speed of a fish's tail "
        "drive for the problem's objectives (NSGA-II), verify the front time-stepped, and write "
        "front.csv, front.png, report.md and the picked designs' files. `fishtail-design sweep "
        "--help`: evaluate many designs without a search.",
    )
    parser.add_argument("problem", type=Path, help="the problem file (docs/design.md)")
    parser.add_argument("--output-dir", type=Path, default=DEFAULT_OUTPUT,
                        help=f"where the results and the checkpoint go ({DEFAULT_OUTPUT})")
    parser.add_argument("--resume", action="store_true",
                        help="continue the search from the checkpoint in --output-dir")
    parser.add_argument("--pick", type=_pick, action="append", metavar="NAME|RANK",
                        help="write the files of this design (fastest, efficient, turning, or "
                        "a rank of front.csv); repeat for more (default: fastest and efficient)")
    parser.add_argument("--generations", type=int, metavar="N",
                        help="override the problem's search.generations")
    parser.add_argument("--population", type=int, metavar="N",
                        help="override the problem's search.population")
    parser.add_argument("--seed", type=int, help="override the problem's search.seed")
    parser.add_argument("--refine-generations", type=int, metavar="N",
                        help="override the problem's search.refine_generations (0: no "
                        "refinement on the verified figures)")
    add_executor_arguments(parser)
    return parser


class _Progress:
    """One line per generation on a terminal (rewritten in place), else one per generation."""

    def __init__(self, problem: Problem, stage: str = "generation") -> None:
        self.problem = problem
        self.stage = stage
        self.tty = sys.stderr.isatty()

    def __call__(self, report: GenerationReport) -> None:
        best = ", ".join(
            f"{objective.name} {value:.4g} {objective.unit}"
            for objective, value in zip(self.problem.objectives, report.best, strict=True)
        )
        line = (
            f"{self.stage} {report.generation}/{report.generations}: {report.evaluated} designs, "
            f"{report.feasible} feasible in the last; best {best}; {report.elapsed_s:.1f} s, "
            f"ETA {report.eta_s:.0f} s"
        )
        end = "\n" if not self.tty or report.generation == report.generations else ""
        print(("\r\033[K" if self.tty else "") + line, end=end, file=sys.stderr, flush=True)


def _with_overrides(problem: Problem, arguments: argparse.Namespace) -> Problem:
    names = ("generations", "population", "seed", "refine_generations")
    changes = {name: getattr(arguments, name) for name in names
               if getattr(arguments, name) is not None}  # fmt: skip
    smallest = {"population": 4, "seed": 0, "refine_generations": 0, "generations": 1}
    for name, value in changes.items():
        if value < smallest[name]:
            flag = "--" + name.replace("_", "-")
            raise DesignError(f"{flag} {value}: at least {smallest[name]}")
    return dataclasses.replace(problem, search=dataclasses.replace(problem.search, **changes))


def _seeds(problem: Problem, result: SearchResult) -> FloatArray:
    """The refinement's first population: the search's front, spread, and the reference."""
    count = problem.search.refine_population
    rows = result.rows
    if rows.shape[0] >= count:
        rows = rows[np.linspace(0, rows.shape[0] - 1, count - 1).round().astype(int)]
    try:
        values = {name: float(value[0]) for name, value in reference_values(problem).items()}
        reference = problem.space.encode(values)[None, :]
    except (DesignError, KeyError):  # a reference with another ratio, or a speed variable
        return rows
    return np.vstack([reference, rows])


def _refine(
    problem: Problem, result: SearchResult, executor: Executor, output: Path, resume: bool
) -> SearchResult:
    """NSGA-II on the verified figures from the search's front: the designs it overrated drop."""
    checkpoint = output / REFINE_CHECKPOINT
    return search(
        refinement_space(problem), functools.partial(verified_rows, problem), executor,
        max(1, math.ceil(problem.search.refine_population / 8)), checkpoint,
        resume and checkpoint.is_file(), _Progress(problem, "refinement"),
        _seeds(problem, result),
    )  # fmt: skip


def _verify(problem: Problem, result: SearchResult, executor: Executor) -> Verified:
    """The front's designs time-stepped, a design per task (they take seconds each)."""
    if result.rows.shape[0] == 0:
        return Verified(*(np.empty(0) for _ in Verified._fields))
    speeds = result.scores.figures[:, FIGURES.index("carrier_speed_rad_s")]
    rows = np.column_stack([result.rows, speeds])
    count = rows.shape[0]
    started = time.monotonic()

    def progress(done: int) -> None:
        print(f"verifying the front: {done}/{count} designs, {time.monotonic() - started:.0f} s",
              file=sys.stderr, flush=True)  # fmt: skip

    function = functools.partial(verify_rows, problem)
    return evaluate_in_batches(executor, function, rows, max(1, math.ceil(count / 8)), progress)


def _designed(
    problem: Problem, arguments: argparse.Namespace, executor: Executor, place: Path
) -> Outcome:
    """One mechanism's search (its checkpoints in ``place``), verified front and reference."""
    print(f"{PROGRAM}: {problem.path}: {problem.mechanism}, {len(problem.space.names)} "
          f"variables, evaluating on {executor.description}", file=sys.stderr)  # fmt: skip
    result = optimise(problem, executor, arguments.batch_size, place / CHECKPOINT,
                      arguments.resume, _Progress(problem))  # fmt: skip
    if problem.search.refine_generations > 0 and result.rows.shape[0] > 0:
        result = _refine(problem, result, executor, place, arguments.resume)
    verified = _verify(problem, result, executor)
    return outcome(problem, result.rows, verified, result.evaluated, result.generations,
                   verify_reference(problem))  # fmt: skip


def run(arguments: argparse.Namespace) -> int:
    """Search, verify and write; the exit status."""
    problems = [_with_overrides(problem, arguments)
                for problem in read_problems(arguments.problem)]  # fmt: skip
    output = arguments.output_dir
    if output.exists() and not output.is_dir():
        raise DesignError(f"--output-dir {output}: not a directory")
    output.mkdir(parents=True, exist_ok=True)
    picks = arguments.pick or ["fastest", "efficient"]
    with executor_from_arguments(arguments) as executor:
        parts = []
        for problem in problems:
            place = output if len(problems) == 1 else output / problem.mechanism
            place.mkdir(parents=True, exist_ok=True)
            parts.append(_designed(problem, arguments, executor, place))
    final = parts[0] if len(parts) == 1 else merge_outcomes(parts)
    write_front(final, output / "front.csv")
    draw_front(final, output / "front.png")
    chosen: list[tuple[str, int]] = []
    directories: dict[str, Path] = {}
    for name in picks:
        try:
            index = final.pick(name)
        except DesignError as error:
            print(f"{PROGRAM}: {error}", file=sys.stderr)
            continue
        label = name if not name.isdigit() else f"rank-{name}"
        chosen.append((label, index))
        directories[label] = output / label
        write_pick(final, index, directories[label])
    write_report(final, chosen, output / "report.md", directories)
    print(f"{PROGRAM}: {final.front.count} designs on the front; wrote {output}/front.csv, "
          f"front.png, report.md" + "".join(f", {d}/" for d in directories.values()))
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """The command line; 0 on success, 1 on a refused input, 2 on a usage error."""
    args = list(sys.argv[1:] if argv is None else argv)
    if args and args[0] == "sweep":
        from fishtail_design.sweep_command import sweep_main

        return sweep_main(args[1:])
    arguments = run_parser().parse_args(args)
    try:
        return run(arguments)
    except (DesignError, OSError) as error:
        print(f"{PROGRAM}: {error}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"{PROGRAM}: interrupted; --resume continues from the last generation's checkpoint",
              file=sys.stderr)  # fmt: skip
        return 130
