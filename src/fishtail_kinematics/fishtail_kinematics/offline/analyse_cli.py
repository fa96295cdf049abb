"""``fishtail-analyse``: a recording (rosbag2 bag or the CLI's CSV) into a report and figures.

Recomputes the tail from the recorded carrier angle with the engine and reports the worst
disagreement with the recorded tail state, the per-beat symmetry table (the monitor's statistics
and verdicts), the beat frequency, and writes theta3.png, tip_path.png (and theta3_theta5.png for
the undulatory mechanism). Exit status: 0 done, 1 the recording disagrees with the engine for this
geometry, 2 unusable input (one-line error).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from fishtail_kinematics.engine.errors import FishtailKinematicsError
from fishtail_kinematics.offline.analysis import AnalysisError, analyse, format_report
from fishtail_kinematics.offline.cli import OneLineErrorParser

PROGRAM = "fishtail-analyse"


def build_parser() -> argparse.ArgumentParser:
    """Command-line options."""
    parser = OneLineErrorParser(
        prog=PROGRAM,
        description=__doc__.splitlines()[0],
        epilog="Exit status: 0 done, 1 the recording disagrees with the engine, 2 bad input.",
    )
    parser.add_argument(
        "recording",
        type=Path,
        metavar="BAG_OR_CSV",
        help="rosbag2 bag directory (or its .mcap/.db3 file), or a CSV of fishtail-kinematics "
        "table",
    )
    parser.add_argument(
        "--config",
        type=Path,
        help="parameter file of the geometry (default: config/<recorded mechanism>.yaml); "
        "monitor tolerances in it are used too",
    )
    parser.add_argument(
        "--output-dir", type=Path, help="where the PNG figures go (default <input name>_figures)"
    )
    parser.add_argument(
        "--namespace", help="namespace of the suite in the bag, if it holds several"
    )
    swimming = parser.add_argument_group(
        "swimming figures (override --config; defaults are the monitor's)"
    )
    for name, help_text in (
        ("forward_speed_m_s", "forward speed U for St and thrust [m/s]"),
        ("fin_span_m", "fin span at the trailing edge [m]"),
        ("water_density_kg_m3", "water density [kg/m^3]"),
    ):
        swimming.add_argument(
            "--" + name.replace("_", "-"), dest=name, type=float, metavar="X", help=help_text
        )
    return parser


SWIMMING_OPTIONS = ("forward_speed_m_s", "fin_span_m", "water_density_kg_m3")


def _allow_many_open_files() -> None:
    """Raise the soft limit of open files to the hard one, best effort.

    rosbags opens every storage file of a split bag at once; a long ``fishtail-record`` run has
    one file per segment, more than the common soft limit of 1024.
    """
    try:
        import resource

        soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
        if soft != resource.RLIM_INFINITY and (hard == resource.RLIM_INFINITY or soft < hard):
            resource.setrlimit(resource.RLIMIT_NOFILE, (hard, hard))
    except (ImportError, OSError, ValueError):
        pass


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``fishtail-analyse``."""
    arguments = build_parser().parse_args(argv)
    _allow_many_open_files()
    try:
        overrides = {
            name: getattr(arguments, name)
            for name in SWIMMING_OPTIONS
            if getattr(arguments, name) is not None
        }
        report = analyse(
            arguments.recording,
            arguments.config,
            arguments.output_dir,
            arguments.namespace,
            overrides,
        )
    except (AnalysisError, FishtailKinematicsError) as error:
        print(f"{PROGRAM}: error: {error}", file=sys.stderr)
        return 2
    except OSError as error:
        print(f"{PROGRAM}: error: {error.strerror or error}", file=sys.stderr)
        return 2
    try:
        print(format_report(report))
    except BrokenPipeError:
        sys.stderr.close()
        return 0
    disagreement = report.disagreement
    return 1 if disagreement is not None and not disagreement.agrees else 0


if __name__ == "__main__":
    sys.exit(main())
