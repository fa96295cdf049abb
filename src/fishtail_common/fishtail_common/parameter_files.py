"""ROS 2 parameter files (``config/*.yaml``) read without ROS, and where the suite's are.

The nodes get their parameters from ROS (``--params-file``); the command lines, the emulated
board and the analysis read the same files here. One rule for the node sections: the
``ros__parameters`` of every section (``/**``, ``kinematics``, ...) are merged in file order, a
later section's value of a name replacing an earlier one's, so callers pick the names they need.
"""

from __future__ import annotations

import os
from pathlib import Path

import yaml

from fishtail_common.parameters import ParameterValueError

#: The package that installs config/ (share/<package>/config).
CONFIG_PACKAGE = "fishtail_bringup"


class ParameterFileError(ParameterValueError):
    """A parameter file that cannot be read or is not a ROS 2 parameter file; names the file."""


def load_parameter_file(path: str | Path) -> dict[str, object]:
    """The parameters of the ROS 2 parameter file at ``path``, every node section merged.

    Raises:
        ParameterFileError: the file cannot be read, is not UTF-8 YAML, or a section has no
            ``ros__parameters`` mapping.
    """
    try:
        with open(path, encoding="utf-8") as stream:
            document = yaml.safe_load(stream)
    except OSError as error:
        raise ParameterFileError(f"cannot read parameter file {path}: {error.strerror}") from None
    except UnicodeDecodeError as error:
        raise ParameterFileError(f"{path} is not UTF-8 text: {error.reason}") from None
    except yaml.YAMLError as error:
        reason = " ".join(str(error).split())
        raise ParameterFileError(f"{path} is not valid YAML: {reason}") from None
    if not isinstance(document, dict):
        raise ParameterFileError(f"{path} is not a ROS 2 parameter file (expected a mapping)")
    merged: dict[str, object] = {}
    for node_name, entry in document.items():
        parameters = entry.get("ros__parameters") if isinstance(entry, dict) else None
        if not isinstance(parameters, dict):
            raise ParameterFileError(f"{path}: entry {node_name!r} has no ros__parameters mapping")
        merged.update(parameters)
    return merged


def default_parameter_file(name: str) -> Path:
    """The parameter file ``config/<name>.yaml`` of the workspace or of the install.

    The workspace's (``FISHTAIL_ROOT``, set by tools/env.sh) when it has one, else the copy
    installed with fishtail_bringup (found through the ament index).

    Raises:
        LookupError: neither has the file's folder.
    """
    file_name = f"{name}.yaml"
    root = os.environ.get("FISHTAIL_ROOT")
    if root and (Path(root) / "config" / file_name).is_file():
        return Path(root) / "config" / file_name
    from ament_index_python.packages import PackageNotFoundError, get_package_share_directory

    try:
        share = Path(get_package_share_directory(CONFIG_PACKAGE))
    except (PackageNotFoundError, LookupError, ValueError) as error:
        raise LookupError(
            f"no config/{file_name}: set FISHTAIL_ROOT (source tools/env.sh) or install "
            f"{CONFIG_PACKAGE}"
        ) from error
    return share / "config" / file_name
