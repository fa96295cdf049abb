"""Package fronts whose names load their module on first use.

A package's ``__init__`` lists what callers may use (``__all__``) and where each name lives; a
name's module is imported when the name is first read, so that ``from fishtail_plant import
DcMotor`` does not load the fish dynamics (and numba) that other names of the front need.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Mapping, Sequence


def lazy_exports(
    package: str, exports: Sequence[str], homes: Mapping[str, Sequence[str]]
) -> Callable[[str], object]:
    """The ``__getattr__`` of package ``package``: each name of ``homes[module]`` from ``module``.

    Raises:
        ValueError: ``exports`` (the package's ``__all__``) and the names of ``homes`` differ.
    """
    module_of = {name: module for module, names in homes.items() for name in names}
    if set(module_of) != set(exports) or len(module_of) != len(exports):
        raise ValueError(f"{package}: __all__ and the names' homes differ")

    def __getattr__(name: str) -> object:  # noqa: N807 - the module attribute hook (PEP 562)
        module = module_of.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module), name)
        setattr(sys.modules[package], name, value)  # the next read finds it directly
        return value

    return __getattr__
