"""The fish and its tail from the command line: parameter files, then flags named after the specs.

The tail from ``--config`` (or ``--mechanism``) and the geometry flags, the fish from ``--fish``
and one flag per fish parameter, the links' masses from the tail's file; flags win, every value
checked by its spec. A ``--config`` file is the suite's (``--params-file`` of every node): it may
hold any node's parameters, and a name that no node of the suite declares is refused, as a name
that is not a fish parameter is in ``--fish``. docs/swimming-dynamics.md ("Command line").
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import NamedTuple

from fishtail_common.command_line import (
    OneLineErrorParser,
    UsageError,
    add_parameter_flags,
    add_parameter_options,
)
from fishtail_common.parameter_files import (
    ParameterFileError,
    default_parameter_file,
    load_parameter_file,
)
from fishtail_driver.parameters import DRIVER_PARAMETERS
from fishtail_kinematics.engine.geometry import GEOMETRY_PARAMETERS
from fishtail_kinematics.engine.input_guard import (
    GUARD_PARAMETERS,
    MAX_CARRIER_SPEED,
    MOTOR_JOINT_NAME,
    STALE_TIMEOUT,
)
from fishtail_kinematics.engine.mechanisms import Tail, make_tail
from fishtail_kinematics.engine.parameters import (
    MECHANISM,
    geometry_from_parameters,
    geometry_parameters_in,
)
from fishtail_kinematics.engine.swimming import SWIMMING_PARAMETERS
from fishtail_kinematics.engine.symmetry import SYMMETRY_PARAMETERS
from fishtail_pilot.pilot import CONTROL_PARAMETERS
from fishtail_pilot.steering import STEERING_PARAMETERS
from fishtail_plant.fish.fish import FISH_PARAMETERS, FishParameters
from fishtail_plant.linkage_load.link_inertia import LinkInertia
from fishtail_plant.values import (
    LOAD_PARAMETERS,
    TAIL_PARAMETERS,
    link_inertia_from_values,
    read_fish_values,
)

PROGRAM = "fishtail-swim"
#: The fish's parameter file, under config/ of the workspace or of the install.
FISH_FILE = "fish"
#: The tail's parameter file when neither --config nor --mechanism says otherwise.
DEFAULT_MECHANISM = "oscillatory"
#: Parameters of the suite's nodes whose specs live in the node modules (which import ROS; this
#: reader does not), and those rclpy declares in every node. test_cli_config_names.py checks
#: :func:`suite_parameter_names` against the nodes' own PARAMETERS.
NODE_MODULE_NAMES = frozenset({
    "base_frame_id", "beat_timeout_sec", "control_rate_hz", "frame_id", "markers_path_length",
    "markers_rate_hz", "markers_trail_length", "max_step_sec", "odom_frame_id", "odom_timeout_sec",
    "publish_tf",
})  # fmt: skip
#: Parameters ROS itself declares (qos_overrides: per publisher, README "QoS overrides").
ROS_NAMES = frozenset({"use_sim_time", "start_type_description_service", "qos_overrides"})


class Swimmer(NamedTuple):
    """What a command swims: the fish's parameters and the engine's tail."""

    fish: FishParameters
    tail: Tail


def swimmer_arguments() -> OneLineErrorParser:
    """The parent parser of the tail's and the fish's files and flags."""
    parent = OneLineErrorParser(add_help=False)
    tail = parent.add_argument_group("tail geometry (SI units; flags override --config)")
    tail.add_argument(
        "--config", type=Path,
        help="kinematics parameter file (default config/oscillatory.yaml, or "
        "config/<mechanism>.yaml with --mechanism)",
    )  # fmt: skip
    add_parameter_options(tail, [MECHANISM], optional=True)
    add_parameter_flags(tail, GEOMETRY_PARAMETERS)
    fish = parent.add_argument_group("fish (SI units; flags override --fish)")
    fish.add_argument("--fish", type=Path, help="fish parameter file (default config/fish.yaml)")
    add_parameter_flags(fish, FISH_PARAMETERS)
    return parent


def suite_parameter_names() -> frozenset[str]:
    """Every parameter name that a node of the suite (driver ... pilot) declares."""
    specs = (
        *DRIVER_PARAMETERS, *LOAD_PARAMETERS, *TAIL_PARAMETERS, *FISH_PARAMETERS,
        *GUARD_PARAMETERS, STALE_TIMEOUT, MAX_CARRIER_SPEED, MOTOR_JOINT_NAME,
        *SYMMETRY_PARAMETERS, *SWIMMING_PARAMETERS, *STEERING_PARAMETERS, *CONTROL_PARAMETERS,
    )  # fmt: skip
    return frozenset(spec.name for spec in specs) | NODE_MODULE_NAMES | ROS_NAMES


def read_config_file(path: Path) -> dict[str, object]:
    """The parameters of a ``--config`` file, every name one that a node of the suite declares.

    Raises:
        ParameterFileError: naming the file, for one that cannot be read or an unknown name.
    """
    values = load_parameter_file(path)
    known = suite_parameter_names()
    for name in values:
        if str(name) not in known:
            raise ParameterFileError(
                f"{path}: unknown parameter {name!r} (no node of the suite declares it)"
            )
    return values


def _default_file(name: str) -> Path:
    try:
        return default_parameter_file(name)
    except LookupError as error:
        raise UsageError(str(error)) from None


def _existing(path: Path, option: str) -> Path:
    # Said here, in the option's words, rather than as the reader's OSError.
    if not path.is_file():
        raise UsageError(f"{option} {path}: no such file")
    return path


def _config_file(arguments: argparse.Namespace) -> Path:
    """The kinematics parameter file: --config, or the --mechanism's (default oscillatory)."""
    if arguments.config is not None:
        return _existing(arguments.config, "--config")
    return _default_file(arguments.mechanism or DEFAULT_MECHANISM)


def link_inertia_from_arguments(arguments: argparse.Namespace) -> LinkInertia:
    """The links' masses and inertias from the tail's parameter file (defaults for the others).

    Raises:
        UsageError: no such file.
        ParameterValueError: an unreadable file or a value out of range.
    """
    return link_inertia_from_values(read_config_file(_config_file(arguments)))


def swimmer_from_arguments(arguments: argparse.Namespace) -> Swimmer:
    """Merge the files and flags into a checked fish and a tail that assembles.

    Raises:
        UsageError: a parameter file that does not exist.
        ParameterValueError: an unreadable file, or a tail or fish value out of range.
        FishtailKinematicsError: a geometry that does not assemble.
    """
    config = _config_file(arguments)
    geometry_values: dict[str, object] = dict(geometry_parameters_in(read_config_file(config)))
    if arguments.mechanism is not None:
        geometry_values[MECHANISM.name] = arguments.mechanism
    for spec in GEOMETRY_PARAMETERS:
        if getattr(arguments, spec.name) is not None:
            geometry_values[spec.name] = getattr(arguments, spec.name)
    tail = make_tail(geometry_from_parameters(geometry_values))
    return Swimmer(fish_from_arguments(arguments), tail)


def fish_from_arguments(arguments: argparse.Namespace) -> FishParameters:
    """The fish of ``--fish`` (default config/fish.yaml) and the fish flags, checked.

    Raises:
        UsageError: a parameter file that does not exist.
        ParameterValueError: an unreadable file, or a fish value out of range.
    """
    if arguments.fish is not None:
        fish_file = _existing(arguments.fish, "--fish")
    else:
        fish_file = _default_file(FISH_FILE)
    fish_values: dict[str, object] = dict(read_fish_values(fish_file))
    for spec in FISH_PARAMETERS:
        if getattr(arguments, spec.name) is not None:
            fish_values[spec.name] = getattr(arguments, spec.name)
    return FishParameters.from_values(fish_values)
