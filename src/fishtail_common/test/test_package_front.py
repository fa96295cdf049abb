"""Package fronts: names load their module on first use, and only the names listed."""

from __future__ import annotations

import sys
import types

import pytest

from fishtail_common.package_front import lazy_exports


@pytest.fixture
def front(monkeypatch):
    """A package ``front_pkg`` whose ``Fraction`` and ``sqrt`` live in fractions and math."""
    package = types.ModuleType("front_pkg")
    monkeypatch.setitem(sys.modules, "front_pkg", package)
    package.__getattr__ = lazy_exports(
        "front_pkg", ["Fraction", "sqrt"], {"fractions": ("Fraction",), "math": ("sqrt",)}
    )
    return package


def test_a_name_comes_from_its_home_and_is_kept(front):
    from fractions import Fraction

    assert "Fraction" not in vars(front)
    assert front.Fraction is Fraction
    assert vars(front)["Fraction"] is Fraction  # found directly the next time
    assert front.sqrt(4.0) == 2.0


def test_a_name_not_listed_is_an_attribute_error(front):
    with pytest.raises(AttributeError, match="'front_pkg' has no attribute 'gcd'"):
        _ = front.gcd


def test_the_list_and_the_homes_must_agree():
    with pytest.raises(ValueError, match="__all__ and the names' homes differ"):
        lazy_exports("front_pkg", ["Fraction", "sqrt"], {"fractions": ("Fraction",)})
    with pytest.raises(ValueError, match="__all__ and the names' homes differ"):
        lazy_exports("front_pkg", ["sqrt", "sqrt"], {"math": ("sqrt",)})
