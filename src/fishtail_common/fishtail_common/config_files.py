"""Where the suite's parameter files are: the workspace's ``config/`` or the installed copy."""

from __future__ import annotations

import os
from pathlib import Path

#: The package that installs config/ (share/<package>/config).
CONFIG_PACKAGE = "fishtail_bringup"


def default_parameter_file(mechanism: str) -> Path:
    """The parameter file ``config/<mechanism>.yaml`` of the workspace or of the install.

    The workspace's (``FISHTAIL_ROOT``, set by tools/env.sh) when it has one, else the copy
    installed with fishtail_bringup (found through the ament index); LookupError when neither.
    """
    name = f"{mechanism}.yaml"
    root = os.environ.get("FISHTAIL_ROOT")
    if root and (Path(root) / "config" / name).is_file():
        return Path(root) / "config" / name
    from ament_index_python.packages import PackageNotFoundError, get_package_share_directory

    try:
        share = Path(get_package_share_directory(CONFIG_PACKAGE))
    except (PackageNotFoundError, LookupError, ValueError) as error:
        raise LookupError(
            f"no config/{name}: set FISHTAIL_ROOT (source tools/env.sh) or install {CONFIG_PACKAGE}"
        ) from error
    return share / "config" / name
