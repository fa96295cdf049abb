"""Every package's package.xml is well-formed and says what colcon and rosdep need."""

from __future__ import annotations

import ast
import importlib
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


# --------------------------------------------------------------------------------------------
# The layers: each package uses only packages to its left, says so in its manifest, and no
# module of the product imports itself back through others.

#: The packages in the order of dependence (fishtail_msgs, interfaces only, may be used by all).
LAYERS = (
    "fishtail_msgs", "fishtail_common", "fishtail_kinematics", "fishtail_plant", "fishtail_design",
    "fishtail_driver", "fishtail_pilot", "fishtail_swim", "fishtail_boards", "fishtail_bringup",
)  # fmt: skip


def _manifest_depends(package: str) -> set[str]:
    root = ElementTree.parse(SOURCES / package / "package.xml").getroot()
    names = {element.text for element in root if element.tag.endswith("depend")}
    return {name for name in names if name and name.startswith("fishtail_")}


def _product_modules() -> dict[str, Path]:
    """Module name -> source file, for every package's own code (not its tests)."""
    modules: dict[str, Path] = {}
    for package in LAYERS[1:]:
        root = SOURCES / package
        for path in sorted((root / package).rglob("*.py")):
            parts = path.relative_to(root).with_suffix("").parts
            name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
            modules[name] = path
    return modules


def _run_time_nodes(tree: ast.AST) -> list[ast.AST]:
    """Every node of ``tree`` but those under ``if TYPE_CHECKING:`` (never imported at run time)."""
    nodes: list[ast.AST] = []
    pending = [tree]
    while pending:
        node = pending.pop()
        nodes.append(node)
        for child in ast.iter_child_nodes(node):
            checking = isinstance(child, ast.If) and ast.unparse(child.test) == "TYPE_CHECKING"
            pending.extend(child.orelse if checking else [child])
    return nodes


def _imports(path: Path) -> set[str]:
    """Every module ``path`` imports at run time, at any depth (function-level imports included)."""
    found: set[str] = set()
    for node in _run_time_nodes(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.add(node.module)
            found.update(f"{node.module}.{alias.name}" for alias in node.names)
    return found


def test_the_manifests_follow_the_layers():
    assert {path.parent.name for path in MANIFESTS} == set(LAYERS)
    for index, package in enumerate(LAYERS):
        later = set(LAYERS[index + 1 :]) & _manifest_depends(package)
        assert not later, f"{package} depends on {sorted(later)}, which build on it"


def test_the_driver_takes_nothing_of_the_simulator_pilot_or_boards_onto_the_fish():
    assert not _manifest_depends("fishtail_driver") & {
        "fishtail_swim", "fishtail_pilot", "fishtail_boards", "fishtail_bringup",
    }  # fmt: skip


def test_every_package_declares_the_packages_its_code_imports():
    modules = _product_modules()
    for name, path in modules.items():
        package = name.split(".")[0]
        used = {imported.split(".")[0] for imported in _imports(path)}
        ours = {other for other in used if other in LAYERS and other != package}
        undeclared = ours - _manifest_depends(package)
        assert not undeclared, f"{path} imports {sorted(undeclared)}, not in its package.xml"
        later = ours & set(LAYERS[LAYERS.index(package) + 1 :])
        assert not later, f"{path} imports {sorted(later)}, which build on {package}"


def test_no_module_imports_itself_back():
    modules = _product_modules()
    graph = {
        name: {imported for imported in _imports(path) if imported in modules and imported != name}
        for name, path in modules.items()
    }
    state: dict[str, int] = {}  # 1: on the current path, 2: done

    def visit(name: str, path: tuple[str, ...]) -> None:
        if state.get(name) == 1:
            cycle = path[path.index(name) :]
            raise AssertionError(f"import cycle: {' -> '.join((*cycle, name))}")
        if state.get(name) == 2:
            return
        state[name] = 1
        for imported in sorted(graph[name]):
            visit(imported, (*path, name))
        state[name] = 2

    for name in sorted(graph):
        visit(name, ())


@pytest.mark.parametrize("package", [name for name in LAYERS if name != "fishtail_msgs"])
def test_every_name_of_a_package_front_resolves(package):
    front = importlib.import_module(package)
    for name in getattr(front, "__all__", ()):
        assert getattr(front, name) is not None, f"{package}.{name}"
