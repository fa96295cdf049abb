"""The closed-loop figures docs/steering.md states, which the pilot's tests hold it to."""

from __future__ import annotations

from pathlib import Path

#: The steering document, whose closed-loop table has a row per manoeuvre.
STEERING_DOC = Path(__file__).resolve().parents[3] / "docs" / "steering.md"
MECHANISMS = ("oscillatory", "undulatory")


def documented_square_seconds() -> dict[str, float]:
    """The 2 m square's times in docs/steering.md's closed-loop table, by mechanism."""
    for line in STEERING_DOC.read_text(encoding="utf-8").splitlines():
        if line.startswith("| 2 m square"):
            cells = [cell.strip() for cell in line.strip().strip("|").split("|")]
            return {
                mechanism: float(cell.removesuffix(" s"))
                for mechanism, cell in zip(MECHANISMS, cells[1:3], strict=True)
            }
    raise AssertionError(f"no '| 2 m square' row in {STEERING_DOC}")
