"""The fish's parameters: specs (each default written once), per-fish values, derived masses.

One place for what config/fish.yaml, the simulator, the pilot and the command lines accept.
Every value may be a float or an array with one element per fish, so that a batch of fish needs
no per-fish loop. Each default and its source: docs/swimming-dynamics.md ("Parameters").

>>> fish = FishParameters()
>>> round(fish.surge_mass_kg, 3), round(fish.sway_mass_kg, 3), round(fish.yaw_inertia_kg_m2, 4)
(12.108, 18.45, 0.2073)
>>> FishParameters(drag_coefficient=np.array([0.3, -1.0]))  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
fishtail_plant...SwimParameterError: drag_coefficient = -1.0 is outside [0.0, 100.0] (fish 1)
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any, TypeAlias, cast

import numpy as np
import numpy.typing as npt

from fishtail_common.parameters import ParameterSpec
from fishtail_kinematics.engine.swimming import (
    FIN_SPAN,
    WATER_DENSITY,
    fin_added_mass_per_length,
)
from fishtail_plant.errors import FishParameterError, SwimParameterError
from fishtail_plant.fish.spheroid import crossflow_yaw_damping, prolate_spheroid

FloatArray: TypeAlias = npt.NDArray[np.float64]
#: One value per fish, or one value for all.
PerFish: TypeAlias = float | FloatArray

_DENSITY = float(WATER_DENSITY.default)
_LENGTH = 0.5
_DIAMETER = 0.2
_BODY = prolate_spheroid(_LENGTH, _DIAMETER, _DENSITY)
# Smallest positive mass, length or area accepted: refuses zero and negative values.
_TINY = 1e-6

#: The fish's parameters, in the order of config/fish.yaml.
FISH_PARAMETERS: tuple[ParameterSpec, ...] = (
    WATER_DENSITY,
    ParameterSpec("body_length_m", _LENGTH, "hull length L (prolate spheroid)", "m", _TINY, 20.0),
    ParameterSpec("body_diameter_m", _DIAMETER, "hull diameter D", "m", _TINY, 10.0),
    ParameterSpec("body_mass_kg", _BODY.mass_kg, "body mass m (neutrally buoyant hull)", "kg",
                  _TINY, 1e5),
    ParameterSpec("body_yaw_inertia_kg_m2", _BODY.yaw_inertia_kg_m2,
                  "body moment of inertia I_z about the vertical axis through C", "kg m^2",
                  _TINY, 1e5),
    ParameterSpec("added_mass_surge_kg", _BODY.added_mass_surge_kg,
                  "surge added mass -X_udot (Lamb k1)", "kg", 0.0, 1e5),
    ParameterSpec("added_mass_sway_kg", _BODY.added_mass_sway_kg,
                  "sway added mass -Y_vdot (Lamb k2)", "kg", 0.0, 1e5),
    ParameterSpec("added_yaw_inertia_kg_m2", _BODY.added_yaw_inertia_kg_m2,
                  "yaw added inertia -N_rdot (Lamb k')", "kg m^2", 0.0, 1e5),
    ParameterSpec("drag_coefficient", 0.3, "body drag coefficient C_D on reference_area_m2", "",
                  0.0, 100.0),
    ParameterSpec("lift_coefficient_per_rad", 2.0,
                  "body lift coefficient C_L per radian of sideslip, on reference_area_m2",
                  "1/rad", 0.0, 100.0),
    ParameterSpec("yaw_damping_kg_m2", crossflow_yaw_damping(_LENGTH, _DIAMETER, _DENSITY),
                  "yaw damping K_D of M = -K_D r|r| (Fossen's -N_|r|r)", "kg m^2", 0.0, 1e5),
    ParameterSpec("surge_linear_damping_kg_s", 0.0,
                  "linear surge damping X_u of F_x = -X_u u (skin friction; 0: drag quadratic)",
                  "kg/s", 0.0, 1e5),
    ParameterSpec("sway_linear_damping_kg_s", 0.0, "linear sway damping Y_v of F_y = -Y_v v",
                  "kg/s", 0.0, 1e5),
    ParameterSpec("sway_quadratic_damping_kg_m", 0.0,
                  "sway cross-flow damping Y_|v|v of F_y = -Y_|v|v |v| v, beyond C_D's", "kg/m",
                  0.0, 1e5),
    ParameterSpec("yaw_linear_damping_kg_m2_s", 0.0, "linear yaw damping N_r of M = -N_r r",
                  "kg m^2/s", 0.0, 1e5),
    ParameterSpec("reference_area_m2", math.pi * _DIAMETER**2 / 4.0,
                  "reference area S of drag and lift (the hull's frontal area)", "m^2",
                  _TINY, 100.0),
    ParameterSpec("tail_origin_offset_m", 0.05,
                  "l_O: distance from the centre of mass C back to the ring-gear centre O", "m",
                  0.0, 20.0),
    FIN_SPAN,
    ParameterSpec("fin_chord_m", 0.06,
                  "chord c of the rigid fin plate forward of the trailing edge (0: no recoil or "
                  "resistive drag)", "m", 0.0, 5.0),
    ParameterSpec("fin_normal_drag_coefficient", 1.2,
                  "C_n of the fin plate's quasi-steady cross-flow drag, per unit area (0: none)",
                  "", 0.0, 10.0),
)  # fmt: skip
FISH_PARAMETERS_BY_NAME: dict[str, ParameterSpec] = {spec.name: spec for spec in FISH_PARAMETERS}


def _default(name: str) -> float:
    return float(FISH_PARAMETERS_BY_NAME[name].default)


def _field(name: str) -> Any:
    return dataclasses.field(default=_default(name))


def check_values(spec: ParameterSpec, value: PerFish) -> PerFish:
    """``value`` (float or per-fish array), checked against ``spec``'s range.

    Raises:
        SwimParameterError: a value outside the range or not finite (naming the fish).
    """
    low = -math.inf if spec.minimum is None else spec.minimum
    high = math.inf if spec.maximum is None else spec.maximum
    values = np.asarray(value, dtype=float)
    # Written so that NaN counts as outside.
    bad = ~((values >= low) & (values <= high) & np.isfinite(values))
    if bad.any():
        index = int(np.flatnonzero(bad.ravel())[0])
        offending = float(values.ravel()[index])
        fish = index if values.ndim else None
        raise SwimParameterError(spec.name, offending, low, high, spec.unit, fish)
    return float(values) if values.ndim == 0 else values


@dataclasses.dataclass(frozen=True)
class FishParameters:
    """The fish: floats, or arrays with one element per fish (checked against the specs).

    Raises:
        SwimParameterError: a value outside its spec's range, or m1, m2 or J not positive.
        FishParameterError: per-fish arrays that do not broadcast together.
    """

    water_density_kg_m3: PerFish = _field("water_density_kg_m3")
    body_length_m: PerFish = _field("body_length_m")
    body_diameter_m: PerFish = _field("body_diameter_m")
    body_mass_kg: PerFish = _field("body_mass_kg")
    body_yaw_inertia_kg_m2: PerFish = _field("body_yaw_inertia_kg_m2")
    added_mass_surge_kg: PerFish = _field("added_mass_surge_kg")
    added_mass_sway_kg: PerFish = _field("added_mass_sway_kg")
    added_yaw_inertia_kg_m2: PerFish = _field("added_yaw_inertia_kg_m2")
    drag_coefficient: PerFish = _field("drag_coefficient")
    lift_coefficient_per_rad: PerFish = _field("lift_coefficient_per_rad")
    yaw_damping_kg_m2: PerFish = _field("yaw_damping_kg_m2")
    surge_linear_damping_kg_s: PerFish = _field("surge_linear_damping_kg_s")
    sway_linear_damping_kg_s: PerFish = _field("sway_linear_damping_kg_s")
    sway_quadratic_damping_kg_m: PerFish = _field("sway_quadratic_damping_kg_m")
    yaw_linear_damping_kg_m2_s: PerFish = _field("yaw_linear_damping_kg_m2_s")
    reference_area_m2: PerFish = _field("reference_area_m2")
    tail_origin_offset_m: PerFish = _field("tail_origin_offset_m")
    fin_span_m: PerFish = _field("fin_span_m")
    fin_chord_m: PerFish = _field("fin_chord_m")
    fin_normal_drag_coefficient: PerFish = _field("fin_normal_drag_coefficient")

    def __post_init__(self) -> None:
        """Check every value against its spec and the combined masses for positivity."""
        for spec in FISH_PARAMETERS:
            object.__setattr__(self, spec.name, check_values(spec, getattr(self, spec.name)))
        for name in ("surge_mass_kg", "sway_mass_kg", "yaw_inertia_kg_m2"):
            check_values(ParameterSpec(name, 1.0, name, "", _TINY, math.inf), getattr(self, name))
        try:
            np.broadcast_shapes(*(np.shape(getattr(self, spec.name)) for spec in FISH_PARAMETERS))
        except ValueError as error:
            raise FishParameterError(f"fish parameters do not broadcast: {error}") from None

    @classmethod
    def from_values(cls, values: Mapping[str, object]) -> FishParameters:
        """Build from parameter values by name (names not given keep their defaults).

        Raises:
            FishParameterError: an unknown name or a value that is not a number, or what the
                class refuses.
        """
        chosen: dict[str, PerFish] = {}
        for name, value in values.items():
            spec = FISH_PARAMETERS_BY_NAME.get(name)
            if spec is None:
                raise FishParameterError(f"unknown fish parameter {name!r}")
            if isinstance(value, bool) or not isinstance(value, int | float | np.ndarray):
                raise FishParameterError(f"{name} must be a number, got {value!r}")
            chosen[name] = value if isinstance(value, np.ndarray) else float(value)
        return cls(**chosen)

    def values(self) -> dict[str, PerFish]:
        """The parameter values by name (the inverse of :meth:`from_values`)."""
        return {spec.name: getattr(self, spec.name) for spec in FISH_PARAMETERS}

    @property
    def surge_mass_kg(self) -> PerFish:
        """m1 = m - X_udot."""
        return self.body_mass_kg + self.added_mass_surge_kg

    @property
    def sway_mass_kg(self) -> PerFish:
        """m2 = m - Y_vdot."""
        return self.body_mass_kg + self.added_mass_sway_kg

    @property
    def yaw_inertia_kg_m2(self) -> PerFish:
        """J = I_z - N_rdot."""
        return self.body_yaw_inertia_kg_m2 + self.added_yaw_inertia_kg_m2

    @property
    def fin_added_mass_per_length_kg_m(self) -> PerFish:
        """Lighthill's m = (pi/4) rho d² at the trailing edge."""
        # float64 in, float64 out: the engine's alias admits any float dtype.
        return cast(PerFish, fin_added_mass_per_length(self.water_density_kg_m3, self.fin_span_m))

    @property
    def drag_factor_kg_m(self) -> PerFish:
        """½ rho S C_D: the body's drag is this times V (u, v)."""
        return 0.5 * self.water_density_kg_m3 * self.reference_area_m2 * self.drag_coefficient

    @property
    def fin_drag_factor_kg_m2(self) -> PerFish:
        """½ rho C_n d: the fin's normal force per unit chord is this times -|w| w."""
        return 0.5 * self.water_density_kg_m3 * self.fin_normal_drag_coefficient * self.fin_span_m

    @property
    def has_linear_damping(self) -> bool:
        """Whether any fish has a linear damping term (speed is then not proportional to f)."""
        linear = (
            self.surge_linear_damping_kg_s,
            self.sway_linear_damping_kg_s,
            self.yaw_linear_damping_kg_m2_s,
        )
        return any(bool(np.any(np.asarray(value) > 0.0)) for value in linear)

    @property
    def has_fin_drag(self) -> bool:
        """Whether any fish's fin has a resistive force (C_n > 0 and c > 0)."""
        factor = np.asarray(self.fin_normal_drag_coefficient) * np.asarray(self.fin_chord_m)
        return bool(np.any(factor > 0.0))

    @property
    def lift_factor_kg_m(self) -> PerFish:
        """½ rho S C_L: the body's lift is this times beta V (v, -u)."""
        dynamic_area = 0.5 * self.water_density_kg_m3 * self.reference_area_m2
        return dynamic_area * self.lift_coefficient_per_rad
