"""The tail linkages: a Cardan (Tusi) couple drives a slider-rocker, optionally a second tail joint.

Where callers get a tail (:func:`make_tail`): both mechanisms offer one surface, :class:`Tail`
(name, joints, state fields, solving, the points to draw, the parameters they use), so that no
caller needs to know which mechanism it drives. Every solver takes Python floats (the
per-message path, ``math`` only) or numpy arrays (vectorised, no per-sample loop) and returns a
named tuple of the same kind. Conventions and equations: docs/kinematics.md.

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
    """The engine for a geometry of either mechanism (validates it).

    Raises:
        AssemblyError: the linkage cannot assemble over the whole stroke (naming the condition).
        PinOffsetError: mechanism 2's pin U outside 0 < SU < SW - VW.
        SolverError: mechanism 2's loop does not close (a geometry at or near a toggle pose).
    """
    return TAIL_TYPES[geometry.mechanism](geometry)
