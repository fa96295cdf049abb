"""Run the examples in the docstrings of every module of fishtail_design."""

from __future__ import annotations

import pytest

import fishtail_design
from fishtail_common.docstring_examples import check_examples, pure_modules


def test_the_modules_are_found():
    """The discovery sees the modules (so the doctest run below cannot be empty)."""
    names = {name for name, _ in pure_modules(fishtail_design)}
    for module in ("variables", "objectives", "executors", "errors"):
        assert f"fishtail_design.{module}" in names


@pytest.mark.parametrize(("name", "has_examples"), pure_modules(fishtail_design))
def test_doctests(name, has_examples):
    """Every docstring example passes; a module with examples does run them."""
    check_examples(name, has_examples)
