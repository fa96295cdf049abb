"""numba's disk cache of compiled code, keyed to every source file the code is compiled from.

numba checks a cached function against its own file's size and modification time only. Code
that compiles functions of other files (the fish formulas into the integrator, the engine's
pose into a batch solve) would then load stale machine code after one of those files changed.
:func:`key_cache_to_sources` adds a hash of their sources to the cache index's stamp. No numba
import here: the dispatcher is whatever the caller compiled.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from types import ModuleType
from typing import Any


def key_cache_to_sources(dispatcher: Any, *modules: ModuleType) -> None:
    """Key numba's disk cache of ``dispatcher`` to the source of ``modules`` too.

    A change to any of them makes the cache stale, and the next call compiles. Nothing for a
    plain function (no numba, or NUMBA_DISABLE_JIT), or with a numba whose cache internals
    differ from 0.5x-0.6x (then as numba does it).
    """
    cache_file: Any = getattr(getattr(dispatcher, "_cache", None), "_cache_file", None)
    stamp = getattr(cache_file, "_source_stamp", None)
    if stamp is None:
        return
    digest = hashlib.sha256()
    for module in modules:
        digest.update(Path(str(module.__file__)).read_bytes())
    cache_file._source_stamp = (stamp, digest.hexdigest())
