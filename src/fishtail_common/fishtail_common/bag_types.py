"""The suite's message definitions for rosbags: the Jazzy typestore plus fishtail_msgs.

rosbags reads and writes rosbag2 files without ROS; it knows the standard messages but not
ours, so their ``.msg`` files (installed by colcon under ``share/fishtail_msgs/msg``) are
registered once here for the recorder and the offline analysis alike.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any


def package_msg_dir(package: str) -> Path:
    """``share/<package>/msg`` of an installed interface package.

    Raises:
        LookupError: the package is not in the ament index.
    """
    from ament_index_python.packages import PackageNotFoundError, get_package_share_directory

    try:
        return Path(get_package_share_directory(package)) / "msg"
    except (PackageNotFoundError, LookupError, ValueError) as error:
        raise LookupError(f"interface package {package} not found in the ament index") from error


def register_package_types(typestore: Any, package: str) -> list[str]:
    """Register every ``msg/*.msg`` of an installed package not yet known; the names added.

    Raises:
        LookupError: the package or its message files cannot be found.
    """
    from rosbags.typesys import get_types_from_msg

    directory = package_msg_dir(package)
    files = sorted(directory.glob("*.msg"))
    if not files:
        raise LookupError(f"no message definitions in {directory}")
    types: dict[str, Any] = {}
    for path in files:
        text = path.read_text(encoding="utf-8")
        types.update(get_types_from_msg(text, f"{package}/msg/{path.stem}"))
    new = {name: fields for name, fields in types.items() if name not in typestore.fielddefs}
    typestore.register(new)
    return sorted(new)


def suite_typestore() -> Any:
    """The ROS 2 Jazzy typestore with fishtail_msgs registered.

    Raises:
        LookupError: fishtail_msgs is not installed.
    """
    from rosbags.typesys import Stores, get_typestore

    typestore = get_typestore(Stores.ROS2_JAZZY)
    register_package_types(typestore, "fishtail_msgs")
    return typestore
