"""The moving links' masses and moments of inertia: their parameter specs and one dataclass.

Every moving link of either mechanism (:data:`LINKS`) has a mass ``<link>_mass_kg`` and a moment
of inertia ``<link>_inertia_kg_m2`` about its centre of mass, taken at its middle. They are read
from the same parameter files as the geometry but kept out of it, in :class:`LinkInertia`, since
only the carrier's load needs them. The links, their defaults and where each comes from:
docs/motor-load.md ("The links' masses: parameters and defaults").

>>> inertia = LinkInertia()
>>> inertia.mass_and_inertia("tail_link")
(0.0891, 0.0001670625)
>>> inertia.mass_and_inertia("slider")
(0.003, 0.0)
>>> LinkInertia(planet_mass_kg=-1.0)  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
fishtail_plant...InvalidInertiaError: planet_mass_kg must be finite and >= 0, got -1.0 kg
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping

from fishtail_common.parameters import ParameterSpec, ParameterValueError
from fishtail_kinematics.engine.errors import ParameterError
from fishtail_kinematics.engine.geometry import OscillatoryGeometry, UndulatoryGeometry
from fishtail_plant.errors import InvalidInertiaError

#: Every moving link (docs/motor-load.md tabulates them).
LINKS = (
    "carrier", "planet", "crank_link", "rocker_link", "tail_link",
    "swing_arm", "slider", "slotted_link", "fin_link",
)  # fmt: skip
#: Links that only translate: they have a mass and no moment of inertia.
TRANSLATING_LINKS = frozenset({"slider"})

# The report's appendix (kilograms).
REPORT_PLANET_MASS_KG = 0.06776
REPORT_CARRIER_MASS_KG = 0.0026
REPORT_CRANK_LINK_MASS_KG = 0.0026
REPORT_ROCKER_LINK_MASS_KG = 0.0061
REPORT_TAIL_FIN_MASS_KG = 0.0891
#: RS's mass over its length in the report (0.234 m): kg/m.
REPORT_LINK_DENSITY_KG_M = REPORT_ROCKER_LINK_MASS_KG / 0.234
#: A PLA block of 20 x 12 x 10 mm at 1240 kg/m^3 weighs 2.98 g.
SLIDER_MASS_KG = 0.003

_OSCILLATORY = OscillatoryGeometry()
_UNDULATORY = UndulatoryGeometry()
_RING_RADIUS_M = _OSCILLATORY.ring_radius_m
_SWING_ARM_MASS_KG = REPORT_LINK_DENSITY_KG_M * _UNDULATORY.swing_arm_m
_SLOTTED_LINK_MASS_KG = REPORT_LINK_DENSITY_KG_M * _UNDULATORY.slotted_link_m
_MAXIMUM_MASS_KG = 1e3
_MAXIMUM_INERTIA_KG_M2 = 1e3


def _bar(mass_kg: float, length_m: float) -> float:
    """Moment of inertia of a uniform slender bar about its middle."""
    return mass_kg * length_m**2 / 12.0


@dataclasses.dataclass(frozen=True)
class LinkInertia:
    """Mass [kg] and moment of inertia about the centre of mass [kg m^2] of every moving link.

    Both mechanisms' links are here; each mechanism uses its own (``Tail.links``).

    Raises:
        InvalidInertiaError: a value that is not a number, not finite or negative.
    """

    carrier_mass_kg: float = REPORT_CARRIER_MASS_KG
    carrier_inertia_kg_m2: float = _bar(REPORT_CARRIER_MASS_KG, 0.5 * _RING_RADIUS_M)
    planet_mass_kg: float = REPORT_PLANET_MASS_KG
    planet_inertia_kg_m2: float = 0.5 * REPORT_PLANET_MASS_KG * (0.5 * _RING_RADIUS_M) ** 2
    crank_link_mass_kg: float = REPORT_CRANK_LINK_MASS_KG
    crank_link_inertia_kg_m2: float = _bar(REPORT_CRANK_LINK_MASS_KG, _OSCILLATORY.crank_link_m)
    rocker_link_mass_kg: float = REPORT_ROCKER_LINK_MASS_KG
    rocker_link_inertia_kg_m2: float = _bar(REPORT_ROCKER_LINK_MASS_KG, _OSCILLATORY.rocker_link_m)
    tail_link_mass_kg: float = REPORT_TAIL_FIN_MASS_KG
    tail_link_inertia_kg_m2: float = _bar(REPORT_TAIL_FIN_MASS_KG, _OSCILLATORY.tail_link_m)
    swing_arm_mass_kg: float = _SWING_ARM_MASS_KG
    swing_arm_inertia_kg_m2: float = _bar(_SWING_ARM_MASS_KG, _UNDULATORY.swing_arm_m)
    slider_mass_kg: float = SLIDER_MASS_KG
    slotted_link_mass_kg: float = _SLOTTED_LINK_MASS_KG
    slotted_link_inertia_kg_m2: float = _bar(_SLOTTED_LINK_MASS_KG, _UNDULATORY.slotted_link_m)
    fin_link_mass_kg: float = REPORT_TAIL_FIN_MASS_KG
    fin_link_inertia_kg_m2: float = _bar(REPORT_TAIL_FIN_MASS_KG, _UNDULATORY.fin_link_m)

    def __post_init__(self) -> None:
        """Refuse non-finite and negative values, naming the first."""
        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise InvalidInertiaError(f"{field.name} must be a number, got {value!r}")
            unit = "kg" if field.name.endswith("_kg") else "kg m^2"
            if not (math.isfinite(value) and value >= 0.0):
                raise InvalidInertiaError(
                    f"{field.name} must be finite and >= 0, got {value!r} {unit}"
                )
            object.__setattr__(self, field.name, float(value))

    @classmethod
    def massless(cls) -> LinkInertia:
        """Every mass and moment of inertia zero: the linkage needs no torque of its own."""
        return cls(**{field.name: 0.0 for field in dataclasses.fields(cls)})

    def mass_and_inertia(self, link: str) -> tuple[float, float]:
        """(mass [kg], moment of inertia about its centre of mass [kg m^2]) of ``link``.

        Raises:
            InvalidInertiaError: ``link`` is not one of :data:`LINKS`.
        """
        if link not in LINKS:
            raise InvalidInertiaError(f"unknown link {link!r}: one of {', '.join(LINKS)}")
        mass = float(getattr(self, f"{link}_mass_kg"))
        if link in TRANSLATING_LINKS:
            return mass, 0.0
        return mass, float(getattr(self, f"{link}_inertia_kg_m2"))


# ---- the values as parameters

_LINK_TEXT = {
    "carrier": "carrier (crank arm O-C carrying the planet)",
    "planet": "planet gear (radius R/2)",
    "crank_link": "link PR",
    "rocker_link": "link RS",
    "tail_link": "tail link ST with the fin (oscillatory)",
    "swing_arm": "swing arm SW (undulatory)",
    "slider": "slider A on the body axis (undulatory)",
    "slotted_link": "slotted link AV (undulatory)",
    "fin_link": "fin link VT with the fin (undulatory)",
}
_SOURCE = {
    "carrier": "report appendix; bar of length R/2",
    "planet": "report appendix (spur gear); uniform disc of radius R/2",
    "crank_link": "report appendix; bar of length PR",
    "rocker_link": "report appendix; bar of length RS",
    "tail_link": "report appendix (tail fin); bar of length ST",
    "swing_arm": "RS's linear density; bar of length SW",
    "slider": "PLA block 20 x 12 x 10 mm",
    "slotted_link": "RS's linear density; bar of length AV",
    "fin_link": "the report's tail fin; bar of length VT",
}


def _link_of(name: str) -> str:
    return name.removesuffix("_mass_kg").removesuffix("_inertia_kg_m2")


def _spec(name: str) -> ParameterSpec:
    # The default comes from the dataclass so that each number is written once.
    default = next(f.default for f in dataclasses.fields(LinkInertia) if f.name == name)
    assert isinstance(default, float)
    link = _link_of(name)
    if name.endswith("_mass_kg"):
        text = f"mass of the {_LINK_TEXT[link]} (default: {_SOURCE[link]})"
        return ParameterSpec(name, default, text, "kg", 0.0, _MAXIMUM_MASS_KG)
    text = (
        f"moment of inertia of the {_LINK_TEXT[link]} about its centre of mass "
        f"(default: {_SOURCE[link]})"
    )
    return ParameterSpec(name, default, text, "kg m^2", 0.0, _MAXIMUM_INERTIA_KG_M2)


#: The specs of every mass and moment of inertia, in the order of :data:`LINKS`.
INERTIA_PARAMETERS: tuple[ParameterSpec, ...] = tuple(
    _spec(field.name) for field in dataclasses.fields(LinkInertia)
)
INERTIA_PARAMETERS_BY_NAME = {spec.name: spec for spec in INERTIA_PARAMETERS}


def inertia_parameter_names(links: tuple[str, ...]) -> tuple[str, ...]:
    """The parameters of ``links`` (e.g. ``Tail.links``): their masses and moments of inertia.

    >>> inertia_parameter_names(("planet", "slider"))
    ('planet_mass_kg', 'planet_inertia_kg_m2', 'slider_mass_kg')
    """
    return tuple(spec.name for spec in INERTIA_PARAMETERS if _link_of(spec.name) in links)


def inertia_parameters_in(values: Mapping[str, object]) -> dict[str, object]:
    """The subset of ``values`` (e.g. a whole parameter file) that are masses and inertias."""
    return {name: value for name, value in values.items() if name in INERTIA_PARAMETERS_BY_NAME}


def link_inertia_from_parameters(values: Mapping[str, object]) -> LinkInertia:
    """Build the :class:`LinkInertia` that ``values`` describe; names not given keep defaults.

    >>> link_inertia_from_parameters({"tail_link_mass_kg": 0.1}).tail_link_mass_kg
    0.1
    >>> link_inertia_from_parameters({"slider_inertia_kg_m2": 0.1})  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    fishtail_kinematics...ParameterError: unknown link inertia parameter 'slider_inertia_kg_m2'

    Raises:
        ParameterError: an unknown name, a wrong type or a value outside its spec's range.
    """
    chosen: dict[str, float] = {}
    for name, value in values.items():
        spec = INERTIA_PARAMETERS_BY_NAME.get(name)
        if spec is None:
            raise ParameterError(f"unknown link inertia parameter {name!r}")
        try:
            chosen[name] = float(spec.check(value))
        except ParameterValueError as error:
            raise ParameterError(str(error)) from None
    return LinkInertia(**chosen)
