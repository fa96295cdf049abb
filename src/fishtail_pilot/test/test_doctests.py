"""Run the examples in the docstrings of every pure module of fishtail_pilot."""

from __future__ import annotations

import pytest

import fishtail_pilot
from fishtail_common.docstring_examples import check_examples, pure_modules


def test_the_modules_are_found():
    """The discovery sees the modules (so the doctest run below cannot be empty)."""
    names = {name for name, _ in pure_modules(fishtail_pilot)}
    for module in ("pilot", "steering", "steering_map"):
        assert f"fishtail_pilot.{module}" in names


@pytest.mark.parametrize(("name", "has_examples"), pure_modules(fishtail_pilot))
def test_doctests(name, has_examples):
    """Every docstring example passes; a module with examples does run them."""
    check_examples(name, has_examples)
