"""Named errors of the synthesis; each message names the file, the key and what is wrong.

>>> raise ProblemFileError("problem.yaml: bounds.ring_radius_m: low 0.2 >= high 0.1")
Traceback (most recent call last):
...
fishtail_design.errors.ProblemFileError: problem.yaml: bounds.ring_radius_m: low 0.2 >= high 0.1
"""

from __future__ import annotations


class DesignError(ValueError):
    """Base class of every error the synthesis raises for bad input."""


class ProblemFileError(DesignError):
    """A problem file (or a file it names) that cannot be read or holds a refused value."""


class CheckpointError(DesignError):
    """A checkpoint that cannot be read, or that belongs to another problem or seed."""


class ExecutorError(DesignError):
    """An executor that cannot start (a scheduler that does not answer) or a failed batch."""
