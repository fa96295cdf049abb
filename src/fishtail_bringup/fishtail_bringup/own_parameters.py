"""A node's own parameters, in a parameter file that wins over the files given before it.

``-p NAME:=VALUE`` and a launch file's parameter dicts join the ``/**`` section of the files, and
ROS applies the sections in the order they first appear: after a user's file with ``/**`` and
then ``driver:``, the file's value won over the command line's. A file of their own, given last,
with a ``/**/<node>`` section (which names the node in any namespace) wins.
"""

from __future__ import annotations

import atexit
import shutil
import tempfile
from collections.abc import Mapping
from pathlib import Path

import yaml

__all__ = ["own_parameters_document", "write_own_parameters"]

_directory: Path | None = None


def own_parameters_document(node_name: str, values: Mapping[str, object]) -> dict[str, object]:
    """The parameter-file document that gives ``node_name`` (in any namespace) ``values``."""
    return {f"/**/{node_name}": {"ros__parameters": dict(values)}}


def write_own_parameters(node_name: str, values: Mapping[str, object]) -> Path:
    """Write ``values`` for ``node_name`` to a new file of their own (removed at exit); its path."""
    global _directory
    if _directory is None:
        _directory = Path(tempfile.mkdtemp(prefix="fishtail-parameters-"))
        atexit.register(shutil.rmtree, _directory, True)
    document = own_parameters_document(node_name, values)
    with tempfile.NamedTemporaryFile(
        "w", encoding="utf-8", dir=_directory, prefix=f"{node_name}-", suffix=".yaml", delete=False
    ) as file:
        yaml.safe_dump(document, file, sort_keys=False)
    return Path(file.name)
