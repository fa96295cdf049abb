"""Run the examples in the docstrings of every pure module of fishtail_swim."""

from __future__ import annotations

import pytest

import fishtail_swim
from fishtail_common.docstring_examples import check_examples, pure_modules


def test_the_modules_are_found():
    """The discovery sees the offline modules (so the doctest run below cannot be empty)."""
    names = {name for name, _ in pure_modules(fishtail_swim)}
    for module in ("frames", "offline.cli", "offline.fit"):
        assert f"fishtail_swim.{module}" in names


@pytest.mark.parametrize(("name", "has_examples"), pure_modules(fishtail_swim))
def test_doctests(name, has_examples):
    """Every docstring example passes; a module with examples does run them."""
    check_examples(name, has_examples)
