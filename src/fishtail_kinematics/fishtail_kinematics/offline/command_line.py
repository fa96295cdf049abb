"""What the two command lines share: one-line usage errors and flags built from parameter specs."""

from __future__ import annotations

import argparse
from collections.abc import Callable, Iterable
from typing import NoReturn

from fishtail_common.parameters import ParameterSpec


class OneLineErrorParser(argparse.ArgumentParser):
    """argparse, but a usage error is one line (the usage text stays behind --help)."""

    def error(self, message: str) -> NoReturn:
        """Print ``prog: error: message`` and exit with status 2."""
        self.exit(2, f"{self.prog}: error: {message} (see --help)\n")


def flag_name(spec: ParameterSpec) -> str:
    """The flag of a parameter: ``pivot_offset_m`` -> ``--pivot-offset-m``."""
    return "--" + spec.name.replace("_", "-")


def add_parameter_flags(
    group: argparse._ArgumentGroup,
    specs: Iterable[ParameterSpec],
    value_type: Callable[[str], float],
) -> None:
    """One flag per spec (dest: the parameter's name, default None: not given), with its text."""
    for spec in specs:
        group.add_argument(
            flag_name(spec),
            dest=spec.name,
            type=value_type,
            metavar=spec.unit.upper() or "X",
            help=f"{spec.text} (default {spec.default:.6g})",
        )
