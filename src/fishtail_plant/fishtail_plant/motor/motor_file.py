r"""Motor files: a DC gear motor's datasheet values in YAML, and the motors they describe.

A motor file (``config/motors/*.yaml``) holds what a maker publishes about one DC gear motor at
one supply voltage: the motor itself, as electrical constants or as datasheet figures at the
motor shaft or at the gearbox output; its rotor inertia and friction; the gear ratios the maker
sells (each with its efficiency, or the stall torque it gives) and/or a continuous range of
ratios; its continuous and peak current. :func:`read_motor_file` reads and checks one into a
:class:`MotorSpec`, whose :meth:`MotorSpec.parameters` is the
:class:`~fishtail_plant.motor.dc_motor.DcMotorParameters` of the motor behind one of its ratios.
The keys, units, derivations and the catalogue: docs/motor-load.md ("Motor files and the
catalogue"). Values are checked against the ranges of :mod:`fishtail_plant.motor.motor_ranges`.

>>> spec = motor_spec_from_document({
...     "name": "example", "source": "a datasheet", "supply_voltage_v": 12.0,
...     "motor": {"resistance_ohm": 2.0, "torque_constant_n_m_a": 0.01,
...               "rotor_inertia_kg_m2": 3e-6,
...               "friction": {"coulomb_friction_n_m": 0.0, "viscous_friction_n_m_s": 0.0}},
...     "gearbox": {"ratios": [{"ratio": 30, "efficiency": 0.8}, {"ratio": 50, "efficiency": 0.7}],
...                 "default_ratio": 30},
...     "current": {"continuous_a": 1.5}})
>>> spec.gear_ratios, spec.peak_current_a                # the peak: the stall current V/R
((30.0, 50.0), 6.0)
>>> round(spec.parameters(50.0).stall_torque_n_m, 6)     # 0.7 * 50 * k V/R
2.1
>>> spec.parameters(40.0)
Traceback (most recent call last):
...
fishtail_plant.errors.MotorSpecError: gear ratio 40 is not offered: the gearbox's ratios are 30, 50
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import yaml

from fishtail_common.parameters import ParameterSpec, ParameterValueError
from fishtail_plant.errors import MotorFileError, MotorSpecError
from fishtail_plant.motor.dc_motor import DcMotorParameters
from fishtail_plant.motor.motor_ranges import (
    MOTOR_FIELDS,
    NO_LOAD_SPEED,
    RPM,
    STALL_TORQUE,
    check_motor_ranges,
)

#: ``figures.shaft``: the figures were measured at the motor's own shaft ...
MOTOR_SHAFT = "motor"
#: ... or at the gearbox output, with the gearbox of ``figures.gear_ratio``.
GEARBOX_OUTPUT = "gearbox_output"
SHAFTS = (MOTOR_SHAFT, GEARBOX_OUTPUT)
#: Two ratios closer than this (relative) are the same ratio.
_SAME_RATIO = 1e-9


def _spec(name: str, description: str, unit: str, low: float, high: float) -> ParameterSpec:
    return ParameterSpec(name, 1.0, description, unit, low, high)


def _field(name: str) -> ParameterSpec:
    description, unit, low, high = MOTOR_FIELDS[name]
    return _spec(name, description, unit, low, high)


def _rpm(spec: ParameterSpec) -> ParameterSpec:
    """``spec``, a speed in rad/s, as the same range in rpm."""
    low = (spec.minimum or 0.0) / RPM
    high = (spec.maximum or math.inf) / RPM
    return _spec(spec.name, spec.description, "rpm", low, high)


#: The ranges of the file's own figures (the others are DcMotorParameters' fields'). Currents:
#: from a micro motor's milliamps to ten times what a small fish's battery could give.
_CURRENT = _spec("current", "current", "A", 1e-3, 1000.0)
_NO_LOAD_CURRENT = _spec("no_load_current", "no-load current", "A", 0.0, 1000.0)
_SHARE = _spec("share", "share of the no-load friction that is Coulomb friction", "", 0.0, 1.0)
_OUTPUT_SPEED_RPM = _rpm(NO_LOAD_SPEED)
#: At the motor shaft: a gear motor's motor turns at a few thousand to tens of thousands of rpm.
_MOTOR_SPEED_RPM = _spec("no_load_speed", "no-load speed of the motor shaft", "rpm", 10.0, 1e5)
_MOTOR_STALL_TORQUE = _spec("stall_torque", "stall torque of the motor shaft", "N m", 1e-5, 10.0)


def _number(value: object, spec: ParameterSpec, key: str) -> float:
    """``value`` as a float, checked against ``spec``'s range; the message names ``key``.

    Raises:
        MotorSpecError: not a number, or outside the range.
    """
    try:
        return float(dataclasses.replace(spec, name=key).check(value))
    except ParameterValueError as error:
        raise MotorSpecError(str(error)) from None


def _text(value: object, key: str) -> str:
    if not isinstance(value, str) or not value.strip():
        raise MotorSpecError(f"{key} must be a non-empty string, got {value!r}")
    return value


def _ratio_text(ratios: tuple[float, ...]) -> str:
    return ", ".join(f"{ratio:g}" for ratio in ratios)


def _same(a: float, b: float) -> bool:
    return abs(a - b) <= _SAME_RATIO * max(abs(a), abs(b), 1.0)


@dataclasses.dataclass(frozen=True)
class DatasheetFigures:
    """The motor as its datasheet gives it at the supply voltage (``motor.figures``).

    ``no_load_speed_rpm`` and ``stall_torque_n_m`` are at ``shaft``: the motor's own, or the
    gearbox output with the gearbox of ``gear_ratio``. R = V / stall current; k = (V − R I₀) / ω₀
    with ω₀ the motor shaft's no-load speed and I₀ ``motor.no_load_current_a`` (0 if not given).
    The stall torque at the gearbox output gives the efficiency at ``gear_ratio``; at the motor
    shaft it is the maker's figure, kept for comparison (the model's is k V/R − τ_c).
    Checked by :class:`MotorSpec`.
    """

    shaft: str
    no_load_speed_rpm: float
    stall_current_a: float
    gear_ratio: float | None = None
    stall_torque_n_m: float | None = None


@dataclasses.dataclass(frozen=True)
class Friction:
    """The friction at the motor shaft (``motor.friction``): given, or from the no-load current.

    Either both ``coulomb_friction_n_m`` and ``viscous_friction_n_m_s``, or
    ``no_load_coulomb_share``: the friction torque at no load is k I₀ (all the no-load current
    does), that share of it Coulomb friction and the rest viscous at the no-load speed (a
    datasheet gives only the sum). Checked by :class:`MotorSpec`.
    """

    coulomb_friction_n_m: float | None = None
    viscous_friction_n_m_s: float | None = None
    no_load_coulomb_share: float | None = None


@dataclasses.dataclass(frozen=True)
class MotorData:
    """The motor without its gearbox (``motor``): electrical constants or datasheet figures.

    Either ``resistance_ohm`` and ``torque_constant_n_m_a``, or ``figures``. Checked by
    :class:`MotorSpec`.
    """

    rotor_inertia_kg_m2: float
    friction: Friction
    resistance_ohm: float | None = None
    torque_constant_n_m_a: float | None = None
    figures: DatasheetFigures | None = None
    no_load_current_a: float | None = None


@dataclasses.dataclass(frozen=True)
class GearRatio:
    """One ratio the maker sells (``gearbox.ratios[i]``), with what the datasheet gives for it.

    ``efficiency`` if the datasheet gives one; otherwise ``stall_torque_n_m`` (at the output)
    gives it: η = τ_stall / (N (k V/R − τ_c)). ``no_load_speed_rpm`` is the maker's figure at
    this ratio, kept for comparison (the model's follows from the motor). Checked by
    :class:`MotorSpec`.
    """

    ratio: float
    efficiency: float | None = None
    stall_torque_n_m: float | None = None
    no_load_speed_rpm: float | None = None


@dataclasses.dataclass(frozen=True)
class GearRange:
    """Any ratio from ``min_ratio`` to ``max_ratio`` with one efficiency (``gearbox.range``).

    For a gearbox built to order or of one's own, where the ratio is a design choice.
    """

    min_ratio: float
    max_ratio: float
    efficiency: float


@dataclasses.dataclass(frozen=True)
class Gearbox:
    """The ratios the maker sells and/or a range of ratios, and the ratio used by default."""

    ratios: tuple[GearRatio, ...] = ()
    ratio_range: GearRange | None = None
    default_ratio: float | None = None


@dataclasses.dataclass(frozen=True)
class CurrentRatings:
    """The motor's continuous (rated, thermal) current and the peak it may take (``current``).

    ``peak_a`` not given is the stall current V/R.
    """

    continuous_a: float
    peak_a: float | None = None


@dataclasses.dataclass(frozen=True)
class _Resolved:
    """What the specification's values give: the motor's constants and friction."""

    resistance_ohm: float
    torque_constant_n_m_a: float
    coulomb_friction_n_m: float
    viscous_friction_n_m_s: float


@dataclasses.dataclass(frozen=True)
class MotorSpec:
    """A DC gear motor as its maker describes it: the content of one motor file, checked.

    The fields mirror the file's sections; the properties and :meth:`parameters` give what they
    mean for the model. Every value is checked on construction (numbers become floats).

    Raises:
        MotorSpecError: a value of the wrong type or outside its range, a missing or doubled
            form (constants and figures, both friction forms), figures that contradict each
            other, or a default ratio the gearbox does not offer; one line naming the key.
    """

    name: str
    source: str
    supply_voltage_v: float
    motor: MotorData
    gearbox: Gearbox
    current: CurrentRatings
    _resolved: _Resolved = dataclasses.field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        """Check every value and work out the motor's constants and friction."""
        set_field = object.__setattr__
        set_field(self, "name", _text(self.name, "name"))
        set_field(self, "source", _text(self.source, "source"))
        voltage = _number(self.supply_voltage_v, _field("supply_voltage_v"), "supply_voltage_v")
        set_field(self, "supply_voltage_v", voltage)
        set_field(self, "motor", _checked_motor(self.motor))
        set_field(self, "gearbox", _checked_gearbox(self.gearbox))
        set_field(self, "current", _checked_current(self.current))
        set_field(self, "_resolved", _resolve(self.supply_voltage_v, self.motor))
        self._check_gearbox()
        peak = self.current.peak_a
        if peak is not None and peak < self.current.continuous_a:
            raise MotorSpecError(
                f"current.peak_a = {peak!r} A is below current.continuous_a = "
                f"{self.current.continuous_a!r} A"
            )

    def _check_gearbox(self) -> None:
        """Every ratio offered gives a motor in range; the default is offered."""
        gearbox = self.gearbox
        default = gearbox.default_ratio
        if default is not None and not self.offers(default):
            raise MotorSpecError(f"gearbox.default_ratio: {self._not_offered(default)}")
        ends = () if gearbox.ratio_range is None else (
            gearbox.ratio_range.min_ratio, gearbox.ratio_range.max_ratio)  # fmt: skip
        for ratio in (*self.gear_ratios, *ends):
            motor = self.parameters(ratio)
            try:
                check_motor_ranges(motor)
            except ParameterValueError as error:
                where = "motor.figures (with supply_voltage_v) give" if self.motor.figures else (
                    "the motor gives")  # fmt: skip
                raise MotorSpecError(f"at gear ratio {ratio:g}, {where} {error}") from None

    # --- what the values mean ------------------------------------------------------------------
    @property
    def resistance_ohm(self) -> float:
        """Armature resistance: given, or V / the stall current."""
        return self._resolved.resistance_ohm

    @property
    def torque_constant_n_m_a(self) -> float:
        """Torque constant = back-EMF constant: given, or (V − R I₀) / ω₀ at the motor shaft."""
        return self._resolved.torque_constant_n_m_a

    @property
    def coulomb_friction_n_m(self) -> float:
        """Coulomb friction at the motor shaft: given, or its share of k I₀."""
        return self._resolved.coulomb_friction_n_m

    @property
    def viscous_friction_n_m_s(self) -> float:
        """Viscous friction at the motor shaft: given, or the rest of k I₀ over ω₀."""
        return self._resolved.viscous_friction_n_m_s

    @property
    def stall_current_a(self) -> float:
        """The current at full voltage with the motor held: V / R."""
        return self.supply_voltage_v / self.resistance_ohm

    @property
    def continuous_current_a(self) -> float:
        """The current the motor may carry continuously (its rated, thermal current)."""
        return self.current.continuous_a

    @property
    def peak_current_a(self) -> float:
        """The current the motor may take for a moment: given, or the stall current."""
        peak = self.current.peak_a
        return self.stall_current_a if peak is None else peak

    @property
    def gear_ratios(self) -> tuple[float, ...]:
        """The ratios the maker sells, smallest first (empty for a range only)."""
        return tuple(sorted(entry.ratio for entry in self.gearbox.ratios))

    @property
    def gear_ratio_range(self) -> tuple[float, float] | None:
        """(smallest, largest) of the continuous range, or None if there is none."""
        span = self.gearbox.ratio_range
        return None if span is None else (span.min_ratio, span.max_ratio)

    @property
    def gear_ratio_efficiencies(self) -> tuple[tuple[float, float], ...]:
        """(ratio, gearbox efficiency) of every ratio the maker sells, smallest first."""
        return tuple((ratio, self.efficiency(ratio)) for ratio in self.gear_ratios)

    @property
    def default_gear_ratio(self) -> float | None:
        """``gearbox.default_ratio``, else the only ratio sold (with no range), else None."""
        if self.gearbox.default_ratio is not None:
            return self.gearbox.default_ratio
        if len(self.gearbox.ratios) == 1 and self.gearbox.ratio_range is None:
            return self.gearbox.ratios[0].ratio
        return None

    def offers(self, gear_ratio: float) -> bool:
        """Whether the gearbox comes with ``gear_ratio`` (a ratio sold, or within the range)."""
        if any(_same(entry.ratio, gear_ratio) for entry in self.gearbox.ratios):
            return True
        span = self.gearbox.ratio_range
        return span is not None and span.min_ratio <= gear_ratio <= span.max_ratio

    def _offered(self) -> str:
        """What the gearbox offers, in words."""
        offered = []
        if self.gearbox.ratios:
            offered.append(f"the gearbox's ratios are {_ratio_text(self.gear_ratios)}")
        if self.gearbox.ratio_range is not None:
            span = self.gearbox.ratio_range
            offered.append(f"its range is {span.min_ratio:g} to {span.max_ratio:g}")
        return " and ".join(offered)

    def _not_offered(self, gear_ratio: float) -> str:
        return f"gear ratio {gear_ratio:g} is not offered: {self._offered()}"

    def _motor_stall_torque(self) -> float:
        """The motor shaft's torque at full voltage, held: k V/R − τ_c."""
        resolved = self._resolved
        return resolved.torque_constant_n_m_a * self.stall_current_a - resolved.coulomb_friction_n_m

    def _efficiency_from_stall(self, gear_ratio: float, stall_torque: float, key: str) -> float:
        """The efficiency that gives ``stall_torque`` at the output of ``gear_ratio``."""
        motor_stall = self._motor_stall_torque()
        if not motor_stall > 0.0:
            raise MotorSpecError(
                f"{key}: the motor's friction ({self.coulomb_friction_n_m:.4g} N m) takes all its "
                f"stall torque k V/R = {motor_stall + self.coulomb_friction_n_m:.4g} N m"
            )
        efficiency = stall_torque / (gear_ratio * motor_stall)
        low, high = MOTOR_FIELDS["gearbox_efficiency"][2:]
        if not low <= efficiency <= high:
            raise MotorSpecError(
                f"{key} = {stall_torque!r} N m needs a gearbox efficiency of {efficiency:.3g} at "
                f"ratio {gear_ratio:g} (the motor's stall torque is {motor_stall:.4g} N m); it "
                f"must be in [{low}, {high}]"
            )
        return efficiency

    def efficiency(self, gear_ratio: float) -> float:
        """The gearbox's efficiency at ``gear_ratio``.

        A ratio sold: its ``efficiency``, else the one its ``stall_torque_n_m`` gives, else the
        one the figures' stall torque gives at their ratio, else the range's if it lies in the
        range. Another ratio within the range: the range's.

        Raises:
            MotorSpecError: a ratio not offered, or one for which nothing gives an efficiency.
        """
        figures = self.motor.figures
        for index, entry in enumerate(self.gearbox.ratios):
            if not _same(entry.ratio, gear_ratio):
                continue
            key = f"gearbox.ratios[{index}]"
            if entry.efficiency is not None:
                return entry.efficiency
            if entry.stall_torque_n_m is not None:
                stall = f"{key}.stall_torque_n_m"
                return self._efficiency_from_stall(entry.ratio, entry.stall_torque_n_m, stall)
            if (figures is not None and figures.shaft == GEARBOX_OUTPUT
                    and figures.stall_torque_n_m is not None and figures.gear_ratio is not None
                    and _same(figures.gear_ratio, entry.ratio)):  # fmt: skip
                return self._efficiency_from_stall(
                    entry.ratio, figures.stall_torque_n_m, "motor.figures.stall_torque_n_m"
                )
            span = self.gearbox.ratio_range
            if span is not None and span.min_ratio <= entry.ratio <= span.max_ratio:
                return span.efficiency
            raise MotorSpecError(
                f"{key} (ratio {entry.ratio:g}) has no efficiency: give its efficiency or "
                "stall_torque_n_m"
            )
        span = self.gearbox.ratio_range
        if span is not None and span.min_ratio <= gear_ratio <= span.max_ratio:
            return span.efficiency
        raise MotorSpecError(self._not_offered(gear_ratio))

    def parameters(self, gear_ratio: float | None = None) -> DcMotorParameters:
        """The motor with its gearbox at ``gear_ratio`` (None: the default ratio).

        Raises:
            MotorSpecError: no ratio given and no default, or a ratio the gearbox does not
                offer (a discrete catalogue offers only its ratios).
        """
        if gear_ratio is None:
            gear_ratio = self.default_gear_ratio
            if gear_ratio is None:
                raise MotorSpecError(f"no default gear ratio: choose one ({self._offered()})")
        efficiency = self.efficiency(gear_ratio)
        resolved = self._resolved
        try:
            return DcMotorParameters(
                resistance_ohm=resolved.resistance_ohm,
                torque_constant_n_m_a=resolved.torque_constant_n_m_a,
                supply_voltage_v=self.supply_voltage_v,
                gear_ratio=float(gear_ratio),
                gearbox_efficiency=efficiency,
                rotor_inertia_kg_m2=self.motor.rotor_inertia_kg_m2,
                viscous_friction_n_m_s=resolved.viscous_friction_n_m_s,
                coulomb_friction_n_m=resolved.coulomb_friction_n_m,
            )
        except ValueError as error:
            raise MotorSpecError(f"at gear ratio {gear_ratio:g}: {error}") from None


# --- checks of the sections -----------------------------------------------------------------
def _optional(value: float | None, spec: ParameterSpec, key: str) -> float | None:
    return None if value is None else _number(value, spec, key)


def _checked_figures(figures: DatasheetFigures) -> DatasheetFigures:
    key = "motor.figures"
    if figures.shaft not in SHAFTS:
        raise MotorSpecError(
            f"{key}.shaft must be one of {', '.join(SHAFTS)}, got {figures.shaft!r}"
        )
    at_output = figures.shaft == GEARBOX_OUTPUT
    if at_output and figures.gear_ratio is None:
        raise MotorSpecError(
            f"missing key '{key}.gear_ratio' (figures at the gearbox output need the ratio they "
            "were measured at)"
        )
    if not at_output and figures.gear_ratio is not None:
        raise MotorSpecError(f"{key}.gear_ratio is for figures at the gearbox output, not at the "
                             "motor shaft")  # fmt: skip
    speed = _OUTPUT_SPEED_RPM if at_output else _MOTOR_SPEED_RPM
    stall = STALL_TORQUE if at_output else _MOTOR_STALL_TORQUE
    return DatasheetFigures(
        shaft=figures.shaft,
        no_load_speed_rpm=_number(figures.no_load_speed_rpm, speed, f"{key}.no_load_speed_rpm"),
        stall_current_a=_number(figures.stall_current_a, _CURRENT, f"{key}.stall_current_a"),
        gear_ratio=_optional(figures.gear_ratio, _field("gear_ratio"), f"{key}.gear_ratio"),
        stall_torque_n_m=_optional(figures.stall_torque_n_m, stall, f"{key}.stall_torque_n_m"),
    )


def _checked_friction(friction: Friction) -> Friction:
    key = "motor.friction"
    given = friction.coulomb_friction_n_m is not None or friction.viscous_friction_n_m_s is not None
    if friction.no_load_coulomb_share is not None:
        if given:
            raise MotorSpecError(
                f"{key}: give either no_load_coulomb_share or coulomb_friction_n_m and "
                "viscous_friction_n_m_s, not both"
            )
        share = _number(friction.no_load_coulomb_share, _SHARE, f"{key}.no_load_coulomb_share")
        return Friction(no_load_coulomb_share=share)
    for name in ("coulomb_friction_n_m", "viscous_friction_n_m_s"):
        if getattr(friction, name) is None:
            other = "or no_load_coulomb_share" if not given else "(both frictions are needed)"
            raise MotorSpecError(f"missing key '{key}.{name}' {other}")
    return Friction(
        coulomb_friction_n_m=_number(friction.coulomb_friction_n_m, _field("coulomb_friction_n_m"),
                                     f"{key}.coulomb_friction_n_m"),
        viscous_friction_n_m_s=_number(friction.viscous_friction_n_m_s,
                                       _field("viscous_friction_n_m_s"),
                                       f"{key}.viscous_friction_n_m_s"),
    )  # fmt: skip


def _checked_motor(motor: MotorData) -> MotorData:
    constants = [name for name in ("resistance_ohm", "torque_constant_n_m_a")
                 if getattr(motor, name) is not None]  # fmt: skip
    if motor.figures is not None and constants:
        raise MotorSpecError(
            f"motor: give either resistance_ohm and torque_constant_n_m_a or figures, not both "
            f"(motor.{constants[0]} and motor.figures)"
        )
    if motor.figures is None and len(constants) < 2:
        missing = "torque_constant_n_m_a" if constants == ["resistance_ohm"] else "resistance_ohm"
        raise MotorSpecError(
            f"missing key 'motor.{missing}' (the motor is resistance_ohm and "
            "torque_constant_n_m_a, or its datasheet figures)"
        )
    return MotorData(
        rotor_inertia_kg_m2=_number(motor.rotor_inertia_kg_m2, _field("rotor_inertia_kg_m2"),
                                    "motor.rotor_inertia_kg_m2"),
        friction=_checked_friction(motor.friction),
        resistance_ohm=_optional(motor.resistance_ohm, _field("resistance_ohm"),
                                 "motor.resistance_ohm"),
        torque_constant_n_m_a=_optional(motor.torque_constant_n_m_a,
                                        _field("torque_constant_n_m_a"),
                                        "motor.torque_constant_n_m_a"),
        figures=None if motor.figures is None else _checked_figures(motor.figures),
        no_load_current_a=_optional(motor.no_load_current_a, _NO_LOAD_CURRENT,
                                    "motor.no_load_current_a"),
    )  # fmt: skip


def _checked_gearbox(gearbox: Gearbox) -> Gearbox:
    ratio_spec, efficiency_spec = _field("gear_ratio"), _field("gearbox_efficiency")
    ratios = []
    for index, entry in enumerate(gearbox.ratios):
        key = f"gearbox.ratios[{index}]"
        ratios.append(GearRatio(
            ratio=_number(entry.ratio, ratio_spec, f"{key}.ratio"),
            efficiency=_optional(entry.efficiency, efficiency_spec, f"{key}.efficiency"),
            stall_torque_n_m=_optional(entry.stall_torque_n_m, STALL_TORQUE,
                                       f"{key}.stall_torque_n_m"),
            no_load_speed_rpm=_optional(entry.no_load_speed_rpm, _OUTPUT_SPEED_RPM,
                                        f"{key}.no_load_speed_rpm"),
        ))  # fmt: skip
        for earlier in ratios[:-1]:
            if _same(earlier.ratio, ratios[-1].ratio):
                raise MotorSpecError(f"{key}.ratio = {entry.ratio!r} is listed twice")
    span = gearbox.ratio_range
    if span is not None:
        span = GearRange(
            min_ratio=_number(span.min_ratio, ratio_spec, "gearbox.range.min_ratio"),
            max_ratio=_number(span.max_ratio, ratio_spec, "gearbox.range.max_ratio"),
            efficiency=_number(span.efficiency, efficiency_spec, "gearbox.range.efficiency"),
        )
        if span.max_ratio < span.min_ratio:
            raise MotorSpecError(
                f"gearbox.range.max_ratio = {span.max_ratio!r} is below gearbox.range.min_ratio = "
                f"{span.min_ratio!r}"
            )
    if not ratios and span is None:
        raise MotorSpecError("missing key 'gearbox.ratios' or 'gearbox.range' (give one or both)")
    default = _optional(gearbox.default_ratio, ratio_spec, "gearbox.default_ratio")
    return Gearbox(ratios=tuple(ratios), ratio_range=span, default_ratio=default)


def _checked_current(current: CurrentRatings) -> CurrentRatings:
    return CurrentRatings(
        continuous_a=_number(current.continuous_a, _CURRENT, "current.continuous_a"),
        peak_a=_optional(current.peak_a, _CURRENT, "current.peak_a"),
    )


def _resolve(supply_voltage_v: float, motor: MotorData) -> _Resolved:
    """The motor's constants and friction from the checked values (docs/motor-load.md).

    Raises:
        MotorSpecError: a no-load current not below the stall current.
    """
    no_load_current = motor.no_load_current_a or 0.0
    figures = motor.figures
    if figures is not None:
        resistance = supply_voltage_v / figures.stall_current_a
        ratio = figures.gear_ratio if figures.shaft == GEARBOX_OUTPUT else None
        motor_speed = figures.no_load_speed_rpm * RPM * (ratio or 1.0)
        torque_constant = (supply_voltage_v - resistance * no_load_current) / motor_speed
    else:
        assert motor.resistance_ohm is not None and motor.torque_constant_n_m_a is not None
        resistance, torque_constant = motor.resistance_ohm, motor.torque_constant_n_m_a
        motor_speed = (supply_voltage_v - resistance * no_load_current) / torque_constant
    if not supply_voltage_v - resistance * no_load_current > 0.0:
        raise MotorSpecError(
            f"motor.no_load_current_a = {no_load_current!r} A is not below the stall current "
            f"V/R = {supply_voltage_v / resistance:.4g} A"
        )
    share = motor.friction.no_load_coulomb_share
    if share is None:
        coulomb = motor.friction.coulomb_friction_n_m
        viscous = motor.friction.viscous_friction_n_m_s
        assert coulomb is not None and viscous is not None
    else:
        if motor.no_load_current_a is None:
            raise MotorSpecError(
                "motor.friction.no_load_coulomb_share needs motor.no_load_current_a"
            )
        no_load_friction = torque_constant * no_load_current
        coulomb = share * no_load_friction
        viscous = (1.0 - share) * no_load_friction / motor_speed
    return _Resolved(resistance, torque_constant, coulomb, viscous)


# --- the file ---------------------------------------------------------------------------------
#: The keys of each section: (required, optional).
_TOP = (("name", "source", "supply_voltage_v", "motor", "gearbox", "current"), ())
_MOTOR = (("rotor_inertia_kg_m2", "friction"),
          ("resistance_ohm", "torque_constant_n_m_a", "figures", "no_load_current_a"))  # fmt: skip
_FIGURES = (("shaft", "no_load_speed_rpm", "stall_current_a"), ("gear_ratio", "stall_torque_n_m"))
_FRICTION = ((), ("coulomb_friction_n_m", "viscous_friction_n_m_s", "no_load_coulomb_share"))
_GEARBOX = ((), ("ratios", "range", "default_ratio"))
_RATIO = (("ratio",), ("efficiency", "stall_torque_n_m", "no_load_speed_rpm"))
_RANGE = (("min_ratio", "max_ratio", "efficiency"), ())
_CURRENT_KEYS = (("continuous_a",), ("peak_a",))


def _section(
    value: object, key: str, keys: tuple[tuple[str, ...], tuple[str, ...]]
) -> dict[str, Any]:
    """``value``, a mapping with the section's keys: no unknown key, no missing one.

    Raises:
        MotorSpecError: not a mapping, an unknown key (named, with the known ones) or a missing one.
    """
    required, optional = keys
    where = f"{key}." if key else ""
    if not isinstance(value, Mapping):
        raise MotorSpecError(f"{key or 'the file'} must be a mapping of keys "
                             f"({', '.join((*required, *optional))}), got {value!r}")  # fmt: skip
    for name in value:
        if name not in (*required, *optional):
            raise MotorSpecError(
                f"unknown key '{where}{name}' (known: {', '.join((*required, *optional))})"
            )
    for name in required:
        if name not in value:
            raise MotorSpecError(f"missing key '{where}{name}'")
    return {str(name): item for name, item in value.items()}


def motor_spec_from_document(document: object) -> MotorSpec:
    """The motor of a motor file's parsed YAML ``document``, checked.

    Raises:
        MotorSpecError: an unknown or missing key, a value of the wrong type or out of range,
            or values that contradict each other; one line naming the key.
    """
    top = _section(document, "", _TOP)
    motor = _section(top["motor"], "motor", _MOTOR)
    friction = _section(motor["friction"], "motor.friction", _FRICTION)
    figures = None
    if "figures" in motor:
        figures = DatasheetFigures(**_section(motor["figures"], "motor.figures", _FIGURES))
    gearbox = _section(top["gearbox"], "gearbox", _GEARBOX)
    entries = gearbox.get("ratios", [])
    if not isinstance(entries, list):
        raise MotorSpecError(f"gearbox.ratios must be a list of mappings (ratio, efficiency, ...), "
                             f"got {entries!r}")  # fmt: skip
    ratios = tuple(GearRatio(**_section(entry, f"gearbox.ratios[{index}]", _RATIO))
                   for index, entry in enumerate(entries))  # fmt: skip
    span = None
    if "range" in gearbox:
        span = GearRange(**_section(gearbox["range"], "gearbox.range", _RANGE))
    current = _section(top["current"], "current", _CURRENT_KEYS)
    return MotorSpec(
        name=top["name"],
        source=top["source"],
        supply_voltage_v=top["supply_voltage_v"],
        motor=MotorData(
            rotor_inertia_kg_m2=motor["rotor_inertia_kg_m2"],
            friction=Friction(**friction),
            resistance_ohm=motor.get("resistance_ohm"),
            torque_constant_n_m_a=motor.get("torque_constant_n_m_a"),
            figures=figures,
            no_load_current_a=motor.get("no_load_current_a"),
        ),
        gearbox=Gearbox(
            ratios=ratios, ratio_range=span, default_ratio=gearbox.get("default_ratio")
        ),
        current=CurrentRatings(continuous_a=current["continuous_a"], peak_a=current.get("peak_a")),
    )


def read_motor_file(path: str | Path) -> MotorSpec:
    """The motor of the motor file at ``path``, checked.

    Raises:
        MotorFileError: one line naming the file and what is wrong: it cannot be read, is not
            YAML, or a key is unknown, missing, of the wrong type, out of range or contradicts
            another.
    """
    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as error:
        raise MotorFileError(f"cannot read motor file {path}: {error.strerror or error}") from None
    except UnicodeDecodeError as error:
        raise MotorFileError(f"{path} is not UTF-8 text: {error.reason}") from None
    try:
        document = yaml.safe_load(text)
    except yaml.YAMLError as error:
        raise MotorFileError(f"{path} is not valid YAML: {' '.join(str(error).split())}") from None
    try:
        return motor_spec_from_document(document)
    except MotorSpecError as error:
        raise MotorFileError(f"{path}: {error}") from None


def _without_none(values: dict[str, Any]) -> dict[str, Any]:
    return {name: value for name, value in values.items() if value is not None}


def motor_document(spec: MotorSpec) -> dict[str, Any]:
    """``spec`` as a motor file's YAML document (the keys it was given with, nothing derived)."""
    motor = spec.motor
    figures = None
    if motor.figures is not None:
        figures = _without_none(dataclasses.asdict(motor.figures))
    gearbox: dict[str, Any] = {}
    if spec.gearbox.ratios:
        gearbox["ratios"] = [
            _without_none(dataclasses.asdict(entry)) for entry in spec.gearbox.ratios
        ]
    if spec.gearbox.ratio_range is not None:
        gearbox["range"] = dataclasses.asdict(spec.gearbox.ratio_range)
    if spec.gearbox.default_ratio is not None:
        gearbox["default_ratio"] = spec.gearbox.default_ratio
    return {
        "name": spec.name,
        "source": spec.source,
        "supply_voltage_v": spec.supply_voltage_v,
        "motor": _without_none({
            "resistance_ohm": motor.resistance_ohm,
            "torque_constant_n_m_a": motor.torque_constant_n_m_a,
            "figures": figures,
            "no_load_current_a": motor.no_load_current_a,
            "rotor_inertia_kg_m2": motor.rotor_inertia_kg_m2,
            "friction": _without_none(dataclasses.asdict(motor.friction)),
        }),
        "gearbox": gearbox,
        "current": _without_none(dataclasses.asdict(spec.current)),
    }  # fmt: skip


def write_motor_file(spec: MotorSpec, path: str | Path) -> None:
    """Write ``spec`` as a motor file that :func:`read_motor_file` reads back equal.

    Raises:
        MotorFileError: the file cannot be written.
    """
    text = yaml.safe_dump(motor_document(spec), sort_keys=False, allow_unicode=True, width=100)
    try:
        Path(path).write_text(f"# Motor file: {spec.name}. Format: docs/motor-load.md.\n{text}",
                              encoding="utf-8")  # fmt: skip
    except OSError as error:
        raise MotorFileError(f"cannot write motor file {path}: {error.strerror or error}") from None
