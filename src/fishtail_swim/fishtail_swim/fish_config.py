"""Read the fish's parameters from a ROS 2 parameter file (``config/fish.yaml``).

The file has the ROS 2 format (``/**: ros__parameters: {...}``) so that a simulator node can load
it with ``--params-file``; here it is read without ROS. Every name must be a fish parameter
(:data:`~fishtail_swim.dynamics.fish.FISH_PARAMETERS`) and every value inside its spec's range;
anything else is refused with a one-line :class:`FishConfigError` naming the file and the reason.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from fishtail_swim.dynamics.errors import FishParameterError
from fishtail_swim.dynamics.fish import FISH_PARAMETERS_BY_NAME, FishParameters


class FishConfigError(FishParameterError):
    """A fish parameter file that cannot be read or holds a refused value."""


def read_fish_values(path: str | Path) -> dict[str, float]:
    """The parameter values of the file at ``path``, checked against the specs."""
    path = Path(path)
    try:
        document: Any = yaml.safe_load(path.read_text(encoding="utf-8"))
    except (OSError, yaml.YAMLError) as error:
        reason = str(error).replace("\n", " ")
        raise FishConfigError(f"{path}: cannot read the fish parameters: {reason}") from None
    parameters = None
    if isinstance(document, dict):
        for section in document.values():
            if isinstance(section, dict) and isinstance(section.get("ros__parameters"), dict):
                parameters = section["ros__parameters"]
                break
    if parameters is None:
        raise FishConfigError(f"{path}: no '<node>: ros__parameters:' mapping")
    values: dict[str, float] = {}
    for name, value in parameters.items():
        spec = FISH_PARAMETERS_BY_NAME.get(str(name))
        if spec is None:
            raise FishConfigError(f"{path}: unknown fish parameter {name!r}")
        try:
            values[str(name)] = float(spec.check(value))
        except ValueError as error:
            raise FishConfigError(f"{path}: {error}") from None
    return values


def load_fish_parameters(path: str | Path) -> FishParameters:
    """The fish the file at ``path`` describes (names not in the file keep their defaults)."""
    return FishParameters.from_values(read_fish_values(path))
