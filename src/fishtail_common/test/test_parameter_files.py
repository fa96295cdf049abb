"""The ROS 2 parameter-file reader of the offline tools."""

from __future__ import annotations

import pytest

from fishtail_common.parameter_files import ParameterFileError, load_parameter_file
from fishtail_kinematics.engine.geometry import UndulatoryGeometry
from fishtail_kinematics.engine.parameters import geometry_from_parameters, geometry_parameters_in


def test_load_parameter_file(tmp_path):
    """Entries of every node are merged in file order; other parameters are kept."""
    path = tmp_path / "params.yaml"
    path.write_text(
        "kinematics:\n"
        "  ros__parameters:\n"
        "    mechanism: undulatory\n"
        "    pin_offset_m: 0.05\n"
        "    rate_hz: 100\n"
        "/**:\n"
        "  ros__parameters:\n"
        "    pin_offset_m: 0.06\n",
        encoding="utf-8",
    )
    values = load_parameter_file(path)
    assert values == {"mechanism": "undulatory", "pin_offset_m": 0.06, "rate_hz": 100}
    assert load_parameter_file(str(path)) == values
    geometry = geometry_from_parameters(geometry_parameters_in(values))
    assert geometry == UndulatoryGeometry(pin_offset_m=0.06)


def test_load_missing_file(tmp_path):
    """A missing file raises ParameterFileError naming it."""
    path = tmp_path / "missing.yaml"
    with pytest.raises(ParameterFileError, match="missing.yaml"):
        load_parameter_file(path)


def test_load_directory(tmp_path):
    """A directory is not a readable file."""
    with pytest.raises(ParameterFileError, match="cannot read"):
        load_parameter_file(tmp_path)


@pytest.mark.parametrize("text", ["a: [1, 2\n", "node:\n  ros__parameters: {x: 1\n", "\t- :"])
def test_load_bad_yaml(tmp_path, text):
    """Malformed YAML raises ParameterFileError saying so."""
    path = tmp_path / "bad.yaml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ParameterFileError, match="not valid YAML"):
        load_parameter_file(path)


def test_load_non_utf8_file(tmp_path):
    """A file that is not UTF-8 text raises ParameterFileError, not UnicodeDecodeError."""
    path = tmp_path / "latin1.yaml"
    path.write_bytes("node:\n  ros__parameters:\n    note: d\xe9j\xe0\n".encode("latin-1"))
    with pytest.raises(ParameterFileError, match="latin1.yaml"):
        load_parameter_file(path)


@pytest.mark.parametrize(
    ("text", "message"),
    [("node:\n  pin_offset_m: 0.05\n", "'node' has no ros__parameters"),
     ("node:\n  ros__parameters: [1, 2]\n", "'node' has no ros__parameters"),
     ("node: 3\n", "'node' has no ros__parameters"),
     ("- 1\n- 2\n", "expected a mapping"),
     ("", "expected a mapping"),
     ("just text\n", "expected a mapping")],
)  # fmt: skip
def test_load_not_a_parameter_file(tmp_path, text, message):
    """Valid YAML of the wrong shape raises ParameterFileError saying what is missing."""
    path = tmp_path / "shape.yaml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ParameterFileError, match=message):
        load_parameter_file(path)
