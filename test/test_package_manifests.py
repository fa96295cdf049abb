"""Every package's package.xml is well-formed and says what colcon and rosdep need."""

from __future__ import annotations

import xml.etree.ElementTree as ElementTree
from pathlib import Path

import pytest

SOURCES = Path(__file__).resolve().parents[1] / "src"
MANIFESTS = sorted(SOURCES.glob("*/package.xml"))


def test_every_package_has_a_manifest():
    assert {path.parent.name for path in MANIFESTS} >= {
        "fishtail_common", "fishtail_msgs", "fishtail_driver", "fishtail_kinematics",
        "fishtail_swim", "fishtail_bringup",
    }  # fmt: skip


@pytest.mark.parametrize("manifest", MANIFESTS, ids=lambda path: path.parent.name)
def test_the_manifest_parses_and_names_its_package_and_build_type(manifest: Path) -> None:
    # A manifest colcon cannot parse (e.g. "--" inside an XML comment) makes it guess the package
    # type from setup.py: the package then builds without its ament index and ROS cannot find it.
    root = ElementTree.parse(manifest).getroot()
    assert root.findtext("name") == manifest.parent.name
    assert root.findtext("export/build_type") in {"ament_python", "ament_cmake"}


def test_the_workspace_dependencies_have_no_cycle():
    depends: dict[str, set[str]] = {}
    for manifest in MANIFESTS:
        root = ElementTree.parse(manifest).getroot()
        names = {element.text for element in root if element.tag.endswith("depend")}
        ours = {name for name in names if name and name.startswith("fishtail_")}
        depends[manifest.parent.name] = ours
    done: set[str] = set()

    def visit(name: str, path: tuple[str, ...]) -> None:
        assert name not in path, f"dependency cycle: {' -> '.join((*path, name))}"
        if name in done:
            return
        for dependency in depends.get(name, ()):
            visit(dependency, (*path, name))
        done.add(name)

    for name in depends:
        visit(name, ())
