"""The suite's message definitions for rosbags: the Jazzy typestore plus fishtail_msgs.

rosbags reads and writes rosbag2 files without ROS; it knows the standard messages but not
ours, so their ``.msg`` files (installed by colcon under ``share/fishtail_msgs/msg``) are
registered once here for the recorder and the offline analysis alike.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any


def package_msg_dir(package: str) -> Path:
    """``share/<package>/msg`` of an installed interface package (the ament index finds it)."""
    from ament_index_python.packages import get_package_share_directory

    return Path(get_package_share_directory(package)) / "msg"


def register_package_types(typestore: Any, package: str) -> list[str]:
    """Register every ``msg/*.msg`` of an installed package not yet known; the names added."""
    from rosbags.typesys import get_types_from_msg

    types: dict[str, Any] = {}
    for path in sorted(package_msg_dir(package).glob("*.msg")):
        types.update(
            get_types_from_msg(path.read_text(encoding="utf-8"), f"{package}/msg/{path.stem}")
        )
    new = {name: fields for name, fields in types.items() if name not in typestore.fielddefs}
    typestore.register(new)
    return sorted(new)


def suite_typestore() -> Any:
    """The ROS 2 Jazzy typestore with fishtail_msgs registered."""
    from rosbags.typesys import Stores, get_typestore

    typestore = get_typestore(Stores.ROS2_JAZZY)
    register_package_types(typestore, "fishtail_msgs")
    return typestore
