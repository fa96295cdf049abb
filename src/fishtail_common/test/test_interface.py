import ast
from pathlib import Path

from fishtail_common.interface import (
    DIAGNOSTICS,
    SUITE_NODES,
    SUITE_TOPICS,
    TAIL_MARKERS,
    Level,
    QosKind,
)

SRC = Path(__file__).resolve().parents[2]


def test_topic_names_are_unique_and_relative_except_diagnostics():
    names = [topic.name for topic in (*SUITE_TOPICS, TAIL_MARKERS)]
    assert len(names) == len(set(names))
    assert [name for name in names if name.startswith("/")] == [DIAGNOSTICS.name]


def test_topic_types_name_a_message_of_a_package():
    for topic in SUITE_TOPICS:
        package, kind, name = topic.type.split("/")
        assert kind == "msg" and package and name[0].isupper(), topic


def test_high_rate_state_is_sensor_data_and_commands_are_reliable():
    kinds = {topic.name: topic.qos for topic in SUITE_TOPICS}
    assert kinds["motor/joint_state"] is QosKind.STATE
    assert kinds["tail/state"] is QosKind.STATE
    assert kinds["motor/cmd_speed"] is QosKind.RELIABLE


def console_scripts(package: str) -> dict[str, str]:
    """Executable -> module:function, as a package's setup.py declares them (read, not run)."""
    tree = ast.parse((SRC / package / "setup.py").read_text())
    scripts = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and " = " in node.value:
            name, target = (part.strip() for part in node.value.split(" = "))
            scripts[name] = target
    return scripts


def test_every_suite_node_is_an_installed_executable_of_its_module():
    for node in SUITE_NODES:
        target = console_scripts(node.package)[node.executable]
        assert target.split(":")[0] == node.module, node


def test_levels_are_diagnostic_msgs_levels():
    from diagnostic_msgs.msg import DiagnosticStatus

    assert Level.OK == int.from_bytes(DiagnosticStatus.OK, "little")
    assert Level.WARN == int.from_bytes(DiagnosticStatus.WARN, "little")
    assert Level.ERROR == int.from_bytes(DiagnosticStatus.ERROR, "little")
    assert Level.STALE == int.from_bytes(DiagnosticStatus.STALE, "little")


def test_default_parameter_file_prefers_the_workspace(monkeypatch, tmp_path):
    from fishtail_common.parameter_files import default_parameter_file

    (tmp_path / "config").mkdir()
    (tmp_path / "config" / "undulatory.yaml").write_text("/**: {}\n")
    monkeypatch.setenv("FISHTAIL_ROOT", str(tmp_path))
    assert default_parameter_file("undulatory") == tmp_path / "config" / "undulatory.yaml"


def test_default_parameter_file_falls_back_to_the_install(monkeypatch, tmp_path):
    from fishtail_common.parameter_files import default_parameter_file

    monkeypatch.setenv("FISHTAIL_ROOT", str(tmp_path))  # a workspace without that file
    path = default_parameter_file("oscillatory")
    assert path.parts[-4:] == ("share", "fishtail_bringup", "config", "oscillatory.yaml")
    assert path.is_file()


def test_mechanism_codes_are_the_messages():
    from fishtail_common.interface import MECHANISM_CODES
    from fishtail_msgs.msg import TailState

    assert MECHANISM_CODES == {
        "oscillatory": TailState.MECHANISM_OSCILLATORY,
        "undulatory": TailState.MECHANISM_UNDULATORY,
    }
