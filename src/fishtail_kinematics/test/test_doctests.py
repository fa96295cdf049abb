"""Run the examples in the docstrings of every pure module of fishtail_kinematics."""

from __future__ import annotations

import pytest

import fishtail_kinematics
from fishtail_common.docstring_examples import check_examples, pure_modules


def test_the_engine_modules_are_found():
    """The discovery sees the engine modules (so the doctest run below cannot be empty)."""
    names = {name for name, _ in pure_modules(fishtail_kinematics)}
    for module in ("errors", "mechanisms", "design", "parameters"):
        assert f"fishtail_kinematics.engine.{module}" in names


@pytest.mark.parametrize(("name", "has_examples"), pure_modules(fishtail_kinematics))
def test_doctests(name, has_examples):
    """Every docstring example passes; a module with examples does run them."""
    check_examples(name, has_examples)
