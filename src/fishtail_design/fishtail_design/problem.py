"""A synthesis problem from its file: the fish, the motor, the mechanism, bounds, limits, goals.

The file is YAML; paths in it are relative to it; every key is checked and a bad file is
refused in one line that names the file and the key. ``mechanism: both`` asks for a search of
each mechanism, their fronts ranked together: the file then gives ``variables`` (and, if it
names them, the ``reference`` files) per mechanism, and :func:`read_problems` returns one
problem for each. The format, key by key, and an example:
docs/design.md ("The problem file"); config/design/*.yaml are worked problems.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml

from fishtail_common.parameter_files import ParameterFileError, default_parameter_file
from fishtail_design.constraints import Band, Limits
from fishtail_design.errors import ProblemFileError
from fishtail_design.objectives import Objective, objectives_named
from fishtail_design.variables import (
    CARRIER_SPEED,
    GEAR_RATIO,
    LINKAGE_VARIABLES,
    DesignSpace,
    Setting,
)
from fishtail_kinematics.engine.geometry import MECHANISMS
from fishtail_kinematics.engine.symmetry import SymmetryTolerances
from fishtail_plant.errors import PlantError
from fishtail_plant.fish.fish import FishParameters
from fishtail_plant.motor.motor_file import MotorSpec, read_motor_file
from fishtail_plant.values import read_fish_values

#: The suite's fish and motor when the file names none (config/<name>.yaml).
DEFAULT_FISH = "fish"
DEFAULT_MOTOR = "motors/pololu-37d-12v"
#: Keys of the file and of its sections.
_KEYS = {"fish", "motor", "reference", "mechanism", "variables", "constraints", "objectives",
         "turning_depth", "search"}  # fmt: skip
_CONSTRAINT_KEYS = {
    "hull_width_at_o_m", "length_behind_o_m", "min_transmission_angle_deg",
    "driver_continuous_current_a", "driver_peak_current_a", "motor_continuous_current_a",
    "motor_peak_current_a", "tip_excursion_m",
    "beat_frequency_hz", "strouhal_number", "symmetry",
}  # fmt: skip
_SEARCH_KEYS = {"population", "generations", "seed", "samples_per_beat", "refine_population",
                "refine_generations"}  # fmt: skip
#: The mechanism setting that asks for a search of each mechanism, merged.
BOTH = "both"
#: Whether the catalogue's ratios or any ratio in the gearbox's range; the fastest carrier.
CATALOGUE, CONTINUOUS, FASTEST = "catalogue", "continuous", "fastest"


@dataclasses.dataclass(frozen=True)
class SearchSettings:
    """The optimiser's population, generations and seed, and the samples per beat of the search.

    ``refine_population`` and ``refine_generations``: the refinement, a second NSGA-II on the
    verified figures started from the search's front and the reference design (0: none).
    """

    population: int = 100
    generations: int = 50
    seed: int = 1
    samples_per_beat: int = 128
    refine_population: int = 20
    refine_generations: int = 6


@dataclasses.dataclass(frozen=True)
class Problem:
    """Everything a search needs, checked; ``path`` is the file it came from."""

    path: Path
    fish_path: Path
    fish: FishParameters
    motor_path: Path
    motor: MotorSpec
    reference_path: Path
    space: DesignSpace
    limits: Limits
    objectives: tuple[Objective, ...]
    turning_depth: float
    search: SearchSettings

    @property
    def mechanism(self) -> str:
        """The mechanism the designs use."""
        return self.space.mechanism


def read_problem(path: Path) -> Problem:
    """The problem of the file at ``path``, a file of one mechanism.

    Raises:
        ProblemFileError: naming the file and the key, for a file that cannot be read, an
            unknown or missing key, a value of the wrong kind or out of range, a fish or
            motor file that is refused, or ``mechanism: both``.
    """
    problems = read_problems(path)
    if len(problems) > 1:
        raise ProblemFileError(
            f"{path}: mechanism: {BOTH} asks for a search of each mechanism (fishtail-design "
            "runs them); this takes a file of one mechanism"
        )
    return problems[0]


def read_problems(path: Path) -> tuple[Problem, ...]:
    """The problems of the file at ``path``: its mechanism's, or one per mechanism for ``both``.

    The problems of ``both`` share everything but their variables and reference files.

    Raises:
        ProblemFileError: as :func:`read_problem`, naming the mechanism's section for ``both``.
    """
    try:
        return _read(path)
    except ProblemFileError as error:
        raise ProblemFileError(f"{path}: {error}") from None


def _read(path: Path) -> tuple[Problem, ...]:
    try:
        document = yaml.safe_load(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError) as error:
        raise ProblemFileError(f"cannot read it ({error.__class__.__name__}: {error})") from None
    except yaml.YAMLError as error:
        raise ProblemFileError(f"not YAML ({str(error).splitlines()[0]})") from None
    values = _mapping(document, "the file")
    _known(values, _KEYS, "")
    base = path.parent
    mechanism = str(values.get("mechanism", MECHANISMS[0]))
    if mechanism not in (*MECHANISMS, BOTH):
        raise ProblemFileError(
            f"mechanism: {mechanism!r} is not one of {', '.join((*MECHANISMS, BOTH))}"
        )
    mechanisms = MECHANISMS if mechanism == BOTH else (mechanism,)
    fish_path = _file(values, "fish", base, DEFAULT_FISH)
    try:
        fish = FishParameters.from_values(read_fish_values(fish_path))
    except (PlantError, ParameterFileError) as error:
        raise ProblemFileError(f"fish: {error}") from None
    motor_path = _file(values, "motor", base, DEFAULT_MOTOR)
    try:
        motor = read_motor_file(motor_path)
    except (PlantError, ValueError) as error:
        raise ProblemFileError(f"motor: {error}") from None
    variables = _mapping(values.get("variables"), "variables")
    references = values.get("reference")
    if mechanism == BOTH:
        _known(variables, set(MECHANISMS), "variables.")
        if references is not None:
            _known(_mapping(references, "reference"), set(MECHANISMS), "reference.")
    spaces, reference_paths = [], []
    for name in mechanisms:
        section = f"variables.{name}." if mechanism == BOTH else "variables."
        own = _mapping(variables.get(name), section[:-1]) if mechanism == BOTH else variables
        spaces.append(_space(name, own, motor, section))
        reference = references.get(name) if isinstance(references, Mapping) else references
        key = f"reference.{name}" if isinstance(references, Mapping) else "reference"
        reference_paths.append(_reference(reference, key, base, name))
    first = Problem(
        path=path, fish_path=fish_path, fish=fish, motor_path=motor_path, motor=motor,
        reference_path=reference_paths[0], space=spaces[0],
        limits=_limits(_mapping(values.get("constraints", {}), "constraints"), fish, motor),
        objectives=objectives_named(_names(values.get("objectives"))),
        turning_depth=_number(values.get("turning_depth", 0.5), "turning_depth", 0.0, 0.9),
        search=_search(_mapping(values.get("search", {}), "search")),
    )  # fmt: skip
    return tuple(
        dataclasses.replace(first, space=space, reference_path=reference)
        for space, reference in zip(spaces, reference_paths, strict=True)
    )


def _mapping(value: object, key: str) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        raise ProblemFileError(f"{key} must be a mapping of keys to values, got {value!r:.60}")
    return value


def _known(values: Mapping[str, Any], keys: set[str], section: str) -> None:
    unknown = sorted(str(key) for key in set(values) - keys)
    if unknown:
        raise ProblemFileError(
            f"{section}{unknown[0]}: unknown key (known: {', '.join(sorted(keys))})"
        )


def _number(value: object, key: str, low: float = 0.0, high: float = math.inf) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ProblemFileError(f"{key} must be a number, got {value!r:.60}")
    number = float(value)
    if not (math.isfinite(number) and low <= number <= high):
        raise ProblemFileError(f"{key} = {number:g} is outside [{low:g}, {high:g}]")
    return number


def _file(values: Mapping[str, Any], key: str, base: Path, default: str) -> Path:
    if key not in values:
        try:
            return default_parameter_file(default)
        except LookupError as error:
            raise ProblemFileError(f"{key}: no default file ({error})") from None
    path = base / str(values[key])
    if not path.is_file():
        raise ProblemFileError(f"{key}: no such file {path}")
    return path


def _reference(value: object, key: str, base: Path, mechanism: str) -> Path:
    """A reference file: the one named, or the mechanism's config/<mechanism>.yaml."""
    return _file({} if value is None else {key: value}, key, base, mechanism)


def _names(value: object) -> list[str]:
    if not isinstance(value, list) or not all(isinstance(item, str) for item in value):
        raise ProblemFileError(f"objectives must be a list of names, got {value!r:.60}")
    return list(value)


def _setting(value: object, key: str) -> Setting:
    if isinstance(value, list):
        if len(value) != 2:
            raise ProblemFileError(f"{key} must be [low, high] or one value, got {value!r:.60}")
        low, high = (_number(item, key) for item in value)
        if not low < high:
            raise ProblemFileError(f"{key}: low {low:g} must be below high {high:g}")
        return low, high
    return _number(value, key)


def _space(
    mechanism: str, variables: Mapping[str, Any], motor: MotorSpec, section: str = "variables."
) -> DesignSpace:
    """The design space of the ``variables`` section (named ``section``) for ``motor``'s gearbox."""
    names = set(LINKAGE_VARIABLES[mechanism]) | {GEAR_RATIO, CARRIER_SPEED}
    _known(variables, names, section)
    settings: dict[str, Setting] = {}
    symmetric = variables.get("rocker_link_m") == "symmetric"
    for name in LINKAGE_VARIABLES[mechanism]:
        if name == "rocker_link_m" and symmetric:
            continue
        if name not in variables:
            raise ProblemFileError(f"{section}{name}: not set (bounds [low, high] or a value)")
        settings[name] = _setting(variables[name], f"{section}{name}")
    gear = variables.get(GEAR_RATIO, CATALOGUE)
    ratios: tuple[float, ...] = ()
    efficiencies: tuple[float, ...] = ()
    efficiency = 1.0
    if gear == CATALOGUE:
        ratios = motor.gear_ratios
        if not ratios:
            raise ProblemFileError(f"{section}{GEAR_RATIO}: the motor's file lists no ratios")
        efficiencies = tuple(motor.efficiency(ratio) for ratio in ratios)
    else:
        setting = _gear_setting(gear, motor, f"{section}{GEAR_RATIO}")
        settings[GEAR_RATIO] = setting
        efficiency = motor.efficiency(setting[0] if isinstance(setting, tuple) else setting)
    speed = variables.get(CARRIER_SPEED, FASTEST)
    if speed != FASTEST:
        settings[CARRIER_SPEED] = _setting(speed, f"{section}{CARRIER_SPEED}")
    return DesignSpace(mechanism, settings, symmetric, ratios, efficiencies, efficiency,
                       speed == FASTEST)  # fmt: skip


def _gear_setting(gear: object, motor: MotorSpec, key: str) -> Setting:
    """A continuous ratio: the gearbox's range, or bounds or a value within what it offers."""
    if gear == CONTINUOUS:
        if motor.gear_ratio_range is None:
            raise ProblemFileError(f"{key}: the motor's file gives no continuous range of ratios")
        return motor.gear_ratio_range
    setting = _setting(gear, key)
    for ratio in setting if isinstance(setting, tuple) else (setting,):
        if not motor.offers(ratio):
            raise ProblemFileError(f"{key}: the motor's gearbox does not come with {ratio:g}:1")
    return setting


def _band(value: object, key: str) -> Band:
    if value is None:
        return None, None
    if not isinstance(value, list) or len(value) != 2:
        raise ProblemFileError(f"{key} must be [low, high] (null for no bound), got {value!r:.60}")
    low, high = (None if item is None else _number(item, key) for item in value)
    if low is not None and high is not None and not low < high:
        raise ProblemFileError(f"{key}: low {low:g} must be below high {high:g}")
    return low, high


def _limits(values: Mapping[str, Any], fish: FishParameters, motor: MotorSpec) -> Limits:
    """The constraints section; the hull's room at O from the fish's spheroid by default."""
    _known(values, _CONSTRAINT_KEYS, "constraints.")
    length = float(fish.body_length_m)
    diameter = float(fish.body_diameter_m)
    offset = float(fish.tail_origin_offset_m)
    # A prolate spheroid's width at O, l_O behind its centre, and the hull's length behind O.
    width = diameter * math.sqrt(max(0.0, 1.0 - (2.0 * offset / length) ** 2))
    symmetry = _mapping(values.get("symmetry", {}), "constraints.symmetry")
    try:
        tolerances = SymmetryTolerances(**{
            str(key): _number(value, f"constraints.symmetry.{key}")
            for key, value in symmetry.items()
        })  # fmt: skip
    except TypeError as error:
        raise ProblemFileError(f"constraints.symmetry: {error}") from None
    except ValueError as error:
        raise ProblemFileError(f"constraints.symmetry: {error}") from None
    def number(key: str, default: float) -> float:
        return _number(values[key], f"constraints.{key}") if key in values else default
    return Limits(
        hull_width_at_o_m=number("hull_width_at_o_m", width),
        length_behind_o_m=number("length_behind_o_m", 0.5 * length - offset),
        min_transmission_angle_deg=_number(
            values.get("min_transmission_angle_deg", 30.0),
            "constraints.min_transmission_angle_deg", 0.0, 90.0,
        ),
        symmetry=tolerances,
        # The motor file's ratings, unless the builder knows better (a measured thermal limit).
        motor_continuous_current_a=number("motor_continuous_current_a",
                                          motor.continuous_current_a),
        motor_peak_current_a=number("motor_peak_current_a", motor.peak_current_a),
        driver_continuous_current_a=number("driver_continuous_current_a", math.inf),
        driver_peak_current_a=number("driver_peak_current_a", math.inf),
        tip_excursion_m=_band(values.get("tip_excursion_m"), "constraints.tip_excursion_m"),
        beat_frequency_hz=_band(values.get("beat_frequency_hz"), "constraints.beat_frequency_hz"),
        strouhal_number=_band(values.get("strouhal_number"), "constraints.strouhal_number"),
    )  # fmt: skip


def _search(values: Mapping[str, Any]) -> SearchSettings:
    _known(values, _SEARCH_KEYS, "search.")
    defaults = SearchSettings()
    chosen = {}
    for key in _SEARCH_KEYS:
        value = values.get(key, getattr(defaults, key))
        low, high = {"population": (4, 100_000), "generations": (1, 100_000),
                     "seed": (0, 2**32 - 1), "samples_per_beat": (16, 4096),
                     "refine_population": (4, 10_000), "refine_generations": (0, 10_000),
                     }[key]  # fmt: skip
        if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
            raise ProblemFileError(f"search.{key} must be an integer in [{low}, {high}]")
        chosen[key] = value
    return SearchSettings(**chosen)
