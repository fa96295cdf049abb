"""``fishtail-design sweep``: evaluate a grid or a Latin hypercube of a problem's designs.

``fishtail-design sweep PROBLEM.yaml --designs N --output FILE.parquet`` scores N designs
spread over the problem's free variables (a Latin hypercube, seeded; or ``--method grid`` with
``--points-per-variable K``) and writes them, chunk by chunk as they are scored, to a CSV or
Parquet file for the user's own analysis. Exit status: 0 written, 1 a refused input (one line),
2 a usage error. Usage and columns: docs/design.md ("Sweeps").
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from fishtail_common.command_line import OneLineErrorParser, add_parameter_options
from fishtail_common.parameters import ParameterSpec
from fishtail_design.errors import DesignError
from fishtail_design.executor_options import add_executor_arguments, executor_from_arguments
from fishtail_design.problem import read_problem
from fishtail_design.sweep import (
    CHUNK_SIZE,
    GEAR_INDEX,
    Grid,
    count_of,
    grid,
    latin_hypercube,
    output_format,
    sweep,
)
from fishtail_plant.fish.fish import FloatArray

PROGRAM = "fishtail-design"
METHODS = ("lhs", "grid")
#: The most designs a sweep takes.
MOST_DESIGNS = 10**12
#: A grid larger than this runs only when --designs repeats its size.
GRID_CONFIRM = 1_000_000
#: Seconds between progress lines when stderr is not a terminal.
PROGRESS_EVERY_S = 10.0

DESIGNS = ParameterSpec(
    "designs", 1000, "designs to evaluate (a grid: its size, needed above "
    f"{GRID_CONFIRM:,} designs to confirm it)", "", 1, MOST_DESIGNS,
)  # fmt: skip
POINTS = ParameterSpec(
    "points_per_variable", 5, "--method grid: values per continuous free variable, evenly "
    "spaced from its low to its high bound (a catalogue's ratios are each taken once)", "", 2,
    100_000,
)  # fmt: skip
SEED = ParameterSpec(
    "seed", 1, "--method lhs: the Latin hypercube's seed (default: the problem's search.seed)",
    "", 0, 2**32 - 1,
)  # fmt: skip
CHUNK = ParameterSpec(
    "chunk_size", CHUNK_SIZE, "designs per chunk, written together (a CSV flush, a Parquet row "
    "group); the sweep holds at most two chunks in memory",
    "", 1, 10_000_000,
)  # fmt: skip


def _output(text: str) -> Path:
    """The output file as argparse checks it: a .csv or .parquet suffix."""
    path = Path(text)
    try:
        output_format(path)
    except DesignError as error:
        raise argparse.ArgumentTypeError(str(error)) from None
    return path


def sweep_parser() -> OneLineErrorParser:
    """The options of a sweep."""
    parser = OneLineErrorParser(
        prog=f"{PROGRAM} sweep",
        description="Evaluate many designs of a problem (the search tier's figures, objectives "
        "and constraint margins) on a Latin hypercube or a grid over its free variables, and "
        "write them chunk by chunk to a CSV or Parquet file. A grid of K points per variable "
        "has K^V designs for V continuous free variables (times the catalogue's ratios).",
    )
    parser.add_argument("problem", type=Path, help="the problem file (docs/design.md)")
    parser.add_argument("--method", choices=METHODS, default="lhs",
                        help="a Latin hypercube of --designs designs (default), or the full "
                        "grid of --points-per-variable values")  # fmt: skip
    add_parameter_options(parser, [DESIGNS, POINTS, SEED], optional=True)
    add_parameter_options(parser, [CHUNK])
    parser.add_argument("--output", type=_output, required=True, metavar="FILE.csv|FILE.parquet",
                        help="the file written; its suffix chooses the format")  # fmt: skip
    parser.add_argument("--parts", action="store_true",
                        help="write --output (.parquet) as a folder of part files, one per chunk, "
                        "each written by the worker that scores it (a cluster's workers must "
                        "share the folder's filesystem); read it back as one dataset")  # fmt: skip
    add_executor_arguments(parser)
    return parser


def _check_usage(parser: OneLineErrorParser, arguments: argparse.Namespace) -> None:
    """Refuse the options that do not go with the method (a usage error)."""
    if arguments.parts and arguments.output.suffix.lower() != ".parquet":
        parser.error("--parts writes Parquet files: --output FOLDER.parquet")
    if arguments.method == "lhs":
        if arguments.designs is None:
            parser.error("--method lhs needs --designs N")
        if arguments.points_per_variable is not None:
            parser.error("--points-per-variable is for --method grid")
    else:
        if arguments.points_per_variable is None:
            parser.error("--method grid needs --points-per-variable K")
        if arguments.seed is not None:
            parser.error("--seed is for --method lhs (a grid is not random)")


def describe_grid(points: Grid, names: Sequence[str], per_variable: int) -> str:
    """How a grid's size comes about: ``5^4 x 9 catalogue ratios = 5,625 designs``."""
    continuous = sum(1 for name in names if name != GEAR_INDEX)
    parts = [f"{per_variable}^{continuous}"] if continuous else []
    if GEAR_INDEX in names:
        parts.append(f"{points.shape[names.index(GEAR_INDEX)]} catalogue ratios")
    return f"{' x '.join(parts)} = {points.count:,} designs"


class _Progress:
    """Designs scored, designs per second and the time left, on stderr.

    On a terminal one line rewritten in place (a few times a second), else a line every
    :data:`PROGRESS_EVERY_S` and the last.
    """

    def __init__(self, total: int) -> None:
        self.total = total
        self.started = time.monotonic()
        self.shown = -math.inf
        self.tty = sys.stderr.isatty()

    def __call__(self, done: int) -> None:
        now = time.monotonic()
        last = done >= self.total
        if not last and now - self.shown < (0.25 if self.tty else PROGRESS_EVERY_S):
            return
        self.shown = now
        elapsed = max(now - self.started, 1e-9)
        rate = done / elapsed
        eta = (self.total - done) / rate if rate > 0 else math.inf
        line = (f"sweep: {done:,}/{self.total:,} designs, {rate:,.0f} designs/s, "
                f"{elapsed:.0f} s, ETA {eta:.0f} s")  # fmt: skip
        if self.tty:
            print("\r\033[K" + line, end="\n" if last else "", file=sys.stderr, flush=True)
        else:
            print(line, file=sys.stderr, flush=True)


def run_sweep(parser: OneLineErrorParser, arguments: argparse.Namespace) -> int:
    """Read the problem, make the designs, sweep them; the exit status."""
    _check_usage(parser, arguments)
    problem = read_problem(arguments.problem)
    names = problem.space.names
    points: FloatArray | Grid
    if arguments.method == "grid":
        points = grid(problem.space, arguments.points_per_variable)
        how = f"a grid of {describe_grid(points, names, arguments.points_per_variable)}"
        if points.count > MOST_DESIGNS:
            raise DesignError(f"{how}: more than the {MOST_DESIGNS:,} a sweep takes")
        if arguments.designs is not None and arguments.designs != points.count:
            raise DesignError(f"--designs {arguments.designs} disagrees with {how}")
        if arguments.designs is None and points.count > GRID_CONFIRM:
            raise DesignError(f"{how}: give --designs {points.count} to run a grid this large")
    else:
        seed = problem.search.seed if arguments.seed is None else arguments.seed
        points = latin_hypercube(problem.space, arguments.designs, seed)
        how = f"a Latin hypercube of {arguments.designs:,} designs (seed {seed})"
    count = count_of(points)
    output: Path = arguments.output
    if output.parent != Path():
        output.parent.mkdir(parents=True, exist_ok=True)
    parts = bool(arguments.parts)
    target = f"{output}/part-*.parquet" if parts else str(output)
    started = time.monotonic()
    with executor_from_arguments(arguments) as executor:
        print(f"{PROGRAM}: {problem.path}: {how} over {len(names)} free variables "
              f"({', '.join(names)}), evaluating on {executor.description}, writing {target}",
              file=sys.stderr)  # fmt: skip
        try:
            result = sweep(problem, points, output, executor, arguments.chunk_size,
                           arguments.batch_size, _Progress(count), parts=parts)  # fmt: skip
        except KeyboardInterrupt:
            print(f"{PROGRAM}: interrupted; {output} holds the chunks written so far",
                  file=sys.stderr)  # fmt: skip
            return 130
    elapsed = time.monotonic() - started
    files = math.ceil(result.designs / arguments.chunk_size)
    where = f"{output}/ ({files} part file{'' if files == 1 else 's'})" if parts else str(output)
    print(
        f"{PROGRAM}: wrote {result.designs:,} designs ({result.feasible:,} feasible) to "
        f"{where} in {elapsed:.1f} s ({result.designs / max(elapsed, 1e-9):,.0f} designs/s)"
    )
    return 0


def sweep_main(argv: Sequence[str]) -> int:
    """``fishtail-design sweep ...``: 0 written, 1 a refused input, 2 a usage error."""
    parser = sweep_parser()
    arguments = parser.parse_args(list(argv))
    try:
        return run_sweep(parser, arguments)
    except (DesignError, OSError) as error:
        print(f"{PROGRAM}: {error}", file=sys.stderr)
        return 1
