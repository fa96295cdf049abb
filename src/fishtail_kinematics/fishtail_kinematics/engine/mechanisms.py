"""The tail linkages: a Cardan (Tusi) couple drives a slider-rocker, optionally a second tail joint.

Conventions (see ``docs/kinematics.md``): O = (0, 0) is the ring-gear centre, +x points back
along the body towards the tail, +y to the left, angles counter-clockwise, SI units.

* Mechanism 1 (oscillatory): the Cardan point P = (0, OP), OP = R cos(phi + psi), drives the
  link PR; RS turns about the body pivot S = (OS, 0) and carries the tail ST, so
  theta3 = theta2 - mid-swing.
* Mechanism 2 (undulatory): SW turns with RS; the pin U on SW rides in the slot of AV, whose end A
  slides along the body axis; VT is hinged to AV at V and to SW at W.

Every solver takes either Python floats (the per-message path, ``math`` only) or numpy arrays
(vectorised, no per-sample Python loop) and returns a named tuple of the same kind. Both tails
offer their callers one surface, :class:`Tail` (name, joints, state fields, solving, the points
to draw, the parameters they use), so that no caller needs to know which mechanism it drives.

>>> import math
>>> from fishtail_kinematics.engine.geometry import OscillatoryGeometry
>>> tail = OscillatoryTail(OscillatoryGeometry())
>>> round(math.degrees(tail.swing_range_rad), 2)
53.13
>>> state = tail.solve(0.0, 4.0)
>>> round(state.theta3, 4), round(state.tip_x, 4)
(-0.4636, 0.3342)
"""

from __future__ import annotations

from fishtail_kinematics.engine.geometry import Geometry
from fishtail_kinematics.engine.oscillatory_tail import OscillatoryTail
from fishtail_kinematics.engine.tail_base import Tail, assembly_violations
from fishtail_kinematics.engine.undulatory_tail import UndulatoryTail

__all__ = [
    "TAIL_TYPES", "OscillatoryTail", "Tail", "UndulatoryTail", "assembly_violations", "make_tail",
]  # fmt: skip

#: The tail of each mechanism, by name.
TAIL_TYPES: dict[str, type[Tail]] = {tail.name: tail for tail in (OscillatoryTail, UndulatoryTail)}


def make_tail(geometry: Geometry) -> Tail:
    """The engine for a geometry of either mechanism (validates it)."""
    return TAIL_TYPES[geometry.mechanism](geometry)
