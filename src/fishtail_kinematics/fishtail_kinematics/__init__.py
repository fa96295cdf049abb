"""The tail linkage: the kinematics engine (numpy only), its nodes and its command lines.

The engine solves both mechanisms from the carrier angle (geometry, rates, design helpers,
symmetry statistics, the carrier's speed profile); the kinematics and monitor nodes and the
``fishtail-kinematics`` / ``fishtail-analyse`` commands build on it. Names load their module on
first use. Equations and conventions: docs/kinematics.md.
"""

from typing import TYPE_CHECKING

from fishtail_common.package_front import lazy_exports

__all__ = [
    "BeatTracker",
    "CarrierSpeedProfile",
    "FishtailKinematicsError",
    "OscillatoryGeometry",
    "SymmetryTolerances",
    "Tail",
    "UndulatoryGeometry",
    "geometry_from_parameters",
    "make_tail",
]

_HOMES = {
    "fishtail_kinematics.engine.carrier_profile": ("CarrierSpeedProfile",),
    "fishtail_kinematics.engine.errors": ("FishtailKinematicsError",),
    "fishtail_kinematics.engine.geometry": ("OscillatoryGeometry", "UndulatoryGeometry"),
    "fishtail_kinematics.engine.mechanisms": ("make_tail",),
    "fishtail_kinematics.engine.parameters": ("geometry_from_parameters",),
    "fishtail_kinematics.engine.symmetry": ("BeatTracker", "SymmetryTolerances"),
    "fishtail_kinematics.engine.tail_base": ("Tail",),
}
__getattr__ = lazy_exports(__name__, __all__, _HOMES)

if TYPE_CHECKING:
    from fishtail_kinematics.engine.carrier_profile import CarrierSpeedProfile
    from fishtail_kinematics.engine.errors import FishtailKinematicsError
    from fishtail_kinematics.engine.geometry import OscillatoryGeometry, UndulatoryGeometry
    from fishtail_kinematics.engine.mechanisms import make_tail
    from fishtail_kinematics.engine.parameters import geometry_from_parameters
    from fishtail_kinematics.engine.symmetry import BeatTracker, SymmetryTolerances
    from fishtail_kinematics.engine.tail_base import Tail
