"""Named errors of the kinematics engine.

Each error says which condition failed and by how much, so that the edge (a parameter callback, the
CLI, a diagnostic) can pass the message on unchanged.
"""

from fishtail_common.parameters import ParameterValueError


class FishtailKinematicsError(ValueError):
    """Base class of every error the engine raises for bad input."""


class InvalidLengthError(FishtailKinematicsError):
    """A length or angle parameter is non-finite, or a length is not positive."""


class AssemblyError(FishtailKinematicsError):
    """The linkage cannot be assembled over the whole stroke of the Cardan point."""


class PivotShiftError(FishtailKinematicsError):
    """A shift of the pivot S is non-finite or outside the range where the linkage assembles."""


class PinOffsetError(FishtailKinematicsError):
    """The pin U of the undulatory mechanism lies outside 0 < SU < SW - VW."""


class InvalidInputError(FishtailKinematicsError):
    """A carrier angle or speed given to a solver is NaN or infinite."""


class SolverError(FishtailKinematicsError):
    """The undulatory loop did not close to tolerance (a geometry at or near a toggle pose)."""


class DesignError(FishtailKinematicsError):
    """A design helper has no answer for the given geometry."""


class ParameterError(FishtailKinematicsError, ParameterValueError):
    """A parameter is unknown, of the wrong type or outside its documented range.

    Also a :class:`~fishtail_common.parameters.ParameterValueError`, so that code handling the
    suite's parameter refusals handles the engine's too.
    """


class CarrierProfileError(FishtailKinematicsError):
    """A carrier speed profile with a negative or non-finite speed, or a depth out of range."""
