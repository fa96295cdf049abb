"""ROS 2 parameter files (``config/*.yaml``) for the command lines and the analysis.

The nodes get their parameters from ROS; the offline tools read the same files here.
"""

from __future__ import annotations

from pathlib import Path

import yaml

from fishtail_kinematics.engine.errors import ParameterError


def load_parameter_file(path: str | Path) -> dict[str, object]:
    """Read the parameters of a ROS 2 parameter file (``<node>: ros__parameters: {...}``).

    Parameters of every node entry are merged in file order; non-geometry parameters (those of the
    driver or the monitor) are kept so that callers can pick what they need.
    """
    try:
        with open(path, encoding="utf-8") as stream:
            document = yaml.safe_load(stream)
    except OSError as error:
        raise ParameterError(f"cannot read parameter file {path}: {error.strerror}") from None
    except UnicodeDecodeError as error:
        raise ParameterError(f"{path} is not UTF-8 text: {error.reason}") from None
    except yaml.YAMLError as error:
        raise ParameterError(f"{path} is not valid YAML: {' '.join(str(error).split())}") from None
    if not isinstance(document, dict):
        raise ParameterError(f"{path} is not a ROS 2 parameter file (expected a mapping)")
    merged: dict[str, object] = {}
    for node_name, entry in document.items():
        parameters = entry.get("ros__parameters") if isinstance(entry, dict) else None
        if not isinstance(parameters, dict):
            raise ParameterError(f"{path}: entry {node_name!r} has no ros__parameters mapping")
        merged.update(parameters)
    return merged
