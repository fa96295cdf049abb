"""Columns of numbers (or words) written as an aligned text table or as CSV.

>>> import io, numpy as np
>>> out = io.StringIO()
>>> write_table([Column("f [Hz]", np.array([0.5, 1.0]), ".3f")], out, as_csv=False)
>>> print(out.getvalue(), end="")
f [Hz]
 0.500
 1.000
"""

from __future__ import annotations

import csv
from collections.abc import Sequence
from typing import Any, NamedTuple, TextIO

import numpy.typing as npt


class Column(NamedTuple):
    """A column: its heading (CSV: the name), its values and their text format.

    Values are numbers, or strings (format ``"s"``), which CSV writes as they are.
    """

    heading: str
    values: npt.NDArray[Any]
    format: str
    csv_name: str = ""


def write_table(columns: Sequence[Column], out: TextIO, as_csv: bool) -> None:
    """Write the columns, one row per element: aligned text, or CSV at full precision."""
    if as_csv:
        writer = csv.writer(out, lineterminator="\n")
        writer.writerow([column.csv_name or column.heading for column in columns])
        for row in zip(*(column.values for column in columns), strict=True):
            writer.writerow([value if isinstance(value, str) else f"{value:.12g}" for value in row])
        return
    cells = [[format(value, column.format) for value in column.values] for column in columns]
    widths = [
        max(len(column.heading), *(len(cell) for cell in texts))
        for column, texts in zip(columns, cells, strict=True)
    ]
    out.write("  ".join(c.heading.rjust(w) for c, w in zip(columns, widths, strict=True)) + "\n")
    for row in zip(*cells, strict=True):
        out.write("  ".join(cell.rjust(w) for cell, w in zip(row, widths, strict=True)) + "\n")
