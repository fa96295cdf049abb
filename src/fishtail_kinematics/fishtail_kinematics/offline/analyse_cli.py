"""``fishtail-analyse``: a recording (rosbag2 bag or the CLI's CSV) into a report and figures.

Checks a run afterwards against the engine and the monitor. Exit status: 0 done, 1 the recording
disagrees with the engine for this geometry, 2 unusable input (one-line error). Report, figures
and options: docs/recording.md.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from fishtail_common.command_line import OneLineErrorParser, add_parameter_flags
from fishtail_kinematics.engine.errors import FishtailKinematicsError
from fishtail_kinematics.engine.swimming import SWIMMING_PARAMETERS
from fishtail_kinematics.offline.analysis import analyse
from fishtail_kinematics.offline.analysis_report import format_report
from fishtail_kinematics.offline.recording import AnalysisError

PROGRAM = "fishtail-analyse"


def build_parser() -> argparse.ArgumentParser:
    """Command-line options."""
    parser = OneLineErrorParser(
        prog=PROGRAM,
        description=(__doc__ or "").splitlines()[0],
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
    add_parameter_flags(swimming, SWIMMING_PARAMETERS)
    swimming.add_argument(
        "--assumed-speed-only",
        action="store_true",
        help="use forward_speed_m_s for every beat even where the bag recorded the fish "
        "(default: U from fish/odom, else fish/swimming, per beat; the assumed U elsewhere)",
    )
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``fishtail-analyse``."""
    arguments = build_parser().parse_args(argv)
    try:
        overrides = {
            spec.name: getattr(arguments, spec.name)
            for spec in SWIMMING_PARAMETERS
            if getattr(arguments, spec.name) is not None
        }
        report = analyse(
            arguments.recording,
            arguments.config,
            arguments.output_dir,
            arguments.namespace,
            overrides,
            use_recorded_speed=not arguments.assumed_speed_only,
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
