"""The design variables: each mechanism's linkage lengths, the gear ratio and the carrier speed.

A :class:`DesignSpace` says which variables the search moves (each between a low and a high
bound), which it holds fixed, whether RS follows from the symmetry condition, whether the gear
ratio is one of a motor's catalogue ratios, and whether the carrier runs as fast as the motor
holds it. It turns the optimiser's rows (one design per row, one column per free variable) into
named arrays and back. The variables and their meaning: docs/design.md ("Variables").

>>> space = DesignSpace("oscillatory", {"ring_radius_m": (0.05, 0.1), "crank_link_m": 0.1,
...     "tail_link_m": 0.15, "pivot_offset_m": 0.2, "gear_ratio": 30.0,
...     "carrier_speed_rad_s": (5.0, 20.0)}, symmetric_rocker=True)
>>> space.names
('ring_radius_m', 'carrier_speed_rad_s')
>>> designs = space.decode(np.array([[0.1, 10.0]]))
>>> round(float(designs["rocker_link_m"][0]), 6), float(designs["gear_ratio"][0])
(0.233926, 30.0)
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence

import numpy as np
import numpy.typing as npt

from fishtail_design.errors import ProblemFileError
from fishtail_kinematics.engine.geometry import GEOMETRY_SYMBOLS, OSCILLATORY, UNDULATORY
from fishtail_plant.fish.fish import FloatArray

#: The linkage lengths each mechanism's design moves (its carrier phase stays 0).
LINKAGE_VARIABLES = {
    OSCILLATORY: ("ring_radius_m", "crank_link_m", "rocker_link_m", "tail_link_m",
                  "pivot_offset_m"),
    UNDULATORY: ("ring_radius_m", "crank_link_m", "rocker_link_m", "pivot_offset_m",
                 "swing_arm_m", "slotted_link_m", "fin_link_m", "fin_joint_offset_m",
                 "pin_offset_m"),
}  # fmt: skip
GEAR_RATIO = "gear_ratio"
CARRIER_SPEED = "carrier_speed_rad_s"
#: What every design also has: the gearbox's efficiency at its ratio.
GEARBOX_EFFICIENCY = "gearbox_efficiency"
#: Symbols and units for tables and figures.
SYMBOLS = {**GEOMETRY_SYMBOLS, GEAR_RATIO: "N", CARRIER_SPEED: "Omega"}
UNITS = {GEAR_RATIO: "", CARRIER_SPEED: "rad/s"}

#: A variable's setting: (low, high) bounds, or one value that fixes it.
Setting = tuple[float, float] | float


def unit_of(name: str) -> str:
    """The unit of a variable: metres for lengths."""
    return UNITS.get(name, "m")


def symmetric_rocker_link(
    ring_radius_m: npt.ArrayLike, crank_link_m: npt.ArrayLike, pivot_offset_m: npt.ArrayLike
) -> FloatArray:
    """RS of the symmetric swing, RS² = PR² + OS sqrt(OS² + R²) (docs/kinematics.md), for arrays."""
    pr = np.asarray(crank_link_m, dtype=float)
    os_ = np.asarray(pivot_offset_m, dtype=float)
    return np.asarray(np.sqrt(pr * pr + os_ * np.hypot(os_, ring_radius_m)), dtype=float)


@dataclasses.dataclass(frozen=True)
class DesignSpace:
    """The variables of one mechanism's designs: free within bounds, or fixed.

    ``settings`` maps each linkage length of the mechanism (except RS when ``symmetric_rocker``),
    ``gear_ratio`` (unless ``gear_ratios`` lists a catalogue to choose from) and
    ``carrier_speed_rad_s`` (unless ``fastest``: as fast as the motor holds the carrier) to bounds
    or a value. ``gear_efficiencies`` go with ``gear_ratios``; ``gearbox_efficiency`` is the
    efficiency of a continuous ratio.

    Raises:
        ProblemFileError: a missing or unknown variable, or bounds that are not finite and
            increasing.
    """

    mechanism: str
    settings: Mapping[str, Setting]
    symmetric_rocker: bool = False
    gear_ratios: tuple[float, ...] = ()
    gear_efficiencies: tuple[float, ...] = ()
    gearbox_efficiency: float = 1.0
    fastest: bool = False

    def __post_init__(self) -> None:
        """Check that every variable is set once, and its bounds."""
        expected = set(self.linkage_names)
        if self.symmetric_rocker:
            expected.discard("rocker_link_m")
        if not self.gear_ratios:
            expected.add(GEAR_RATIO)
        if not self.fastest:
            expected.add(CARRIER_SPEED)
        given = set(self.settings)
        if given - expected:
            raise ProblemFileError(
                f"variables: {sorted(given - expected)[0]} is not a variable of this problem "
                f"(the {self.mechanism} mechanism's are {', '.join(expected)})"
            )
        if expected - given:
            raise ProblemFileError(f"variables: {sorted(expected - given)[0]} is not set")
        for name, setting in self.settings.items():
            low, high = _bounds(setting)
            if not (math.isfinite(low) and math.isfinite(high) and 0.0 < low <= high):
                raise ProblemFileError(
                    f"variables: {name}: bounds must be finite, > 0 and low <= high, got "
                    f"{setting!r}"
                )
        if len(self.gear_ratios) != len(self.gear_efficiencies):
            raise ProblemFileError("variables: each catalogue gear ratio needs its efficiency")

    @property
    def linkage_names(self) -> tuple[str, ...]:
        """The mechanism's linkage lengths."""
        return LINKAGE_VARIABLES[self.mechanism]

    @property
    def names(self) -> tuple[str, ...]:
        """The free variables, the optimiser's columns, in order (a catalogue index last)."""
        free = tuple(name for name, setting in self.settings.items() if _is_free(setting))
        return free + (("gear_index",) if len(self.gear_ratios) > 1 else ())

    @property
    def lower(self) -> FloatArray:
        """The free variables' low bounds."""
        return np.array([self._bounds_of(name)[0] for name in self.names])

    @property
    def upper(self) -> FloatArray:
        """The free variables' high bounds."""
        return np.array([self._bounds_of(name)[1] for name in self.names])

    def _bounds_of(self, name: str) -> tuple[float, float]:
        if name == "gear_index":
            # A continuous column floored to an index: every ratio gets an equal share of it.
            return 0.0, float(len(self.gear_ratios))
        return _bounds(self.settings[name])

    def decode(self, rows: npt.ArrayLike) -> dict[str, FloatArray]:
        """Each design's variables by name, shape (N,), from the optimiser's rows (N, columns).

        ``rocker_link_m`` from the symmetry condition when the space asks for it,
        ``gearbox_efficiency`` at each design's ratio, ``carrier_speed_rad_s`` NaN when the
        carrier runs as fast as the motor holds it.
        """
        x = np.atleast_2d(np.asarray(rows, dtype=float))
        count = x.shape[0]
        columns = dict(zip(self.names, x.T, strict=True))
        designs: dict[str, FloatArray] = {}
        for name, setting in self.settings.items():
            fixed = np.full(count, _bounds(setting)[0])
            designs[name] = columns[name] if _is_free(setting) else fixed
        if self.symmetric_rocker:
            designs["rocker_link_m"] = symmetric_rocker_link(
                designs["ring_radius_m"], designs["crank_link_m"], designs["pivot_offset_m"]
            )
        if self.gear_ratios:
            index = np.zeros(count, dtype=int)
            if "gear_index" in columns:
                last = len(self.gear_ratios) - 1
                index = np.clip(np.floor(columns["gear_index"]).astype(int), 0, last)
            designs[GEAR_RATIO] = np.asarray(self.gear_ratios)[index]
            designs[GEARBOX_EFFICIENCY] = np.asarray(self.gear_efficiencies)[index]
        else:
            designs[GEARBOX_EFFICIENCY] = np.full(count, self.gearbox_efficiency)
        if self.fastest:
            designs[CARRIER_SPEED] = np.full(count, np.nan)
        return designs

    def encode(self, values: Mapping[str, float]) -> FloatArray:
        """The optimiser's row of one design given by name (e.g. the report's own design).

        Raises:
            ProblemFileError: a free variable without a value, or a ratio not in the catalogue.
        """
        row = []
        for name in self.names:
            if name == "gear_index":
                ratio = values[GEAR_RATIO]
                if ratio not in self.gear_ratios:
                    raise ProblemFileError(f"gear ratio {ratio:g} is not in the motor's catalogue")
                row.append(self.gear_ratios.index(ratio) + 0.5)
            elif name not in values:
                raise ProblemFileError(f"no value for the variable {name}")
            else:
                row.append(float(values[name]))
        return np.array(row)

    def variable_names(self) -> Sequence[str]:
        """Every named value of a design, in table order: lengths, gear, efficiency, speed."""
        return (*self.linkage_names, GEAR_RATIO, GEARBOX_EFFICIENCY, CARRIER_SPEED)


def _bounds(setting: Setting) -> tuple[float, float]:
    if isinstance(setting, tuple):
        return float(setting[0]), float(setting[1])
    return float(setting), float(setting)


def _is_free(setting: Setting) -> bool:
    low, high = _bounds(setting)
    return low < high
