"""Many mechanism-1 linkages at once: one linkage per element of the length arrays.

A synthesis evaluates a population of linkages together. :class:`OscillatoryBatch` holds their
lengths as arrays and gives what
:class:`~fishtail_kinematics.engine.oscillatory_tail.OscillatoryTail` gives one linkage, from
the same formulas: the assembly margins
(:func:`~fishtail_kinematics.engine.tail_base.assembly_margins`), the swing's extremes and the
solve (:func:`~fishtail_kinematics.engine.oscillatory_tail.solve_drive_arrays`). A linkage that
does not assemble is kept, with NaN where it has no pose, so that a batch keeps its shape.

>>> import numpy as np
>>> batch = OscillatoryBatch(np.array([0.1, 0.1]), np.array([0.1, 0.1]),
...                          np.array([0.233926, 0.05]), np.array([0.15, 0.15]),
...                          np.array([0.2, 0.2]))
>>> batch.assembles.tolist()
[True, False]
>>> round(float(np.degrees(batch.swing_range_rad[0])), 2)
53.13
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from fishtail_kinematics.engine import drive_pass
from fishtail_kinematics.engine.blocks import BLOCK_SAMPLES
from fishtail_kinematics.engine.geometry import FloatArray, OscillatoryState
from fishtail_kinematics.engine.oscillatory_tail import (
    DRIVE_ARRAY_FIELDS,
    DRIVE_SCRATCH,
    DriveConstants,
    drive_coefficients,
    solve_drive_arrays,
)
from fishtail_kinematics.engine.tail_base import assembly_margins


class OscillatoryBatch:
    """Mechanism 1 for N linkages: lengths [m] and carrier phase [rad] as arrays of shape (N,).

    Attributes: ``assembly_margins_m`` (2, N), the drive's two conditions (> 0 where each holds);
    ``assembles`` (N,); ``theta2_min``, ``theta2_max``, ``theta2_mid`` and ``swing_range_rad``
    (N,), NaN where a linkage does not assemble.
    """

    def __init__(
        self,
        ring_radius_m: npt.ArrayLike,
        crank_link_m: npt.ArrayLike,
        rocker_link_m: npt.ArrayLike,
        tail_link_m: npt.ArrayLike,
        pivot_offset_m: npt.ArrayLike,
        phase_rad: npt.ArrayLike = 0.0,
    ) -> None:
        """Keep the lengths (broadcast to one shape) and find each linkage's swing extremes."""
        r, pr, rs, st, os_, psi = np.broadcast_arrays(*(
            np.atleast_1d(np.asarray(value, dtype=float))
            for value in (ring_radius_m, crank_link_m, rocker_link_m, tail_link_m,
                          pivot_offset_m, phase_rad)
        ))  # fmt: skip
        self.size = r.size
        self.assembly_margins_m = np.array(assembly_margins(r, pr, rs, os_))
        self.assembles = (self.assembly_margins_m > 0.0).all(axis=0)
        # The swing's extremes sit at the stroke's ends OP = +-R or where d theta2 / d OP = 0,
        # i.e. at OP = sqrt(RS^2 - (OS - PR)^2) when that lies inside the stroke (OscillatoryTail).
        offset_sq = rs * rs - (os_ - pr) ** 2
        with np.errstate(invalid="ignore"):
            stationary = np.sqrt(np.where(offset_sq > 0.0, offset_sq, np.nan))
        inside = stationary < r
        # OP = R cos(phi + psi): the carrier angles of the candidates.
        at_stationary = np.where(inside, np.arccos(np.where(inside, stationary / r, 1.0)), 0.0)
        candidates = np.stack((-psi, np.pi - psi, at_stationary - psi))
        unmounted = DriveConstants(r, pr, rs, st, os_, psi, 0.0, 0.0, True)
        with np.errstate(invalid="ignore"):
            theta2 = solve_drive_arrays(unmounted, candidates, np.zeros_like(candidates))[0].theta2
        theta2 = np.asarray(theta2)
        ends = theta2[:2]
        with_stationary = np.where(inside, theta2[2], ends[0])
        self.theta2_min = np.minimum(ends.min(axis=0), with_stationary)
        self.theta2_max = np.maximum(ends.max(axis=0), with_stationary)
        self.theta2_min[~self.assembles] = np.nan
        self.theta2_max[~self.assembles] = np.nan
        self.theta2_mid = 0.5 * (self.theta2_min + self.theta2_max)
        self.swing_range_rad = self.theta2_max - self.theta2_min
        self.constants = DriveConstants(
            r, pr, rs, st, os_, psi, self.theta2_mid, self.theta2_mid, True
        )
        #: Whether :meth:`solve` uses the compiled pass where numba is there (the same numbers
        #: to rounding; False: numpy's).
        self.compiled = True

    @staticmethod
    def fin_angle_field() -> str:
        """The state field of the tail link's angle to the body axis."""
        return "fin_angle"

    def solve(self, motor_angle: npt.ArrayLike, motor_velocity: npt.ArrayLike) -> OscillatoryState:
        """Every linkage at carrier angles and speeds broadcasting against (N,)."""
        return self.solve_with_tail_trig(motor_angle, motor_velocity)[0]

    def solve_with_tail_trig(
        self, motor_angle: npt.ArrayLike, motor_velocity: npt.ArrayLike
    ) -> tuple[OscillatoryState, FloatArray, FloatArray]:
        """Every linkage at carrier angles and speeds of shape (..., N); cos, sin of the tail link.

        The inputs broadcast against (N,) (e.g. (samples, N) or (samples, 1)); a linkage that does
        not assemble gives NaN. Angles shared by every linkage, (samples, 1), cost one cosine and
        one sine each whatever N (the linkages share their carrier phase). The batch runs a few
        rows at a time (about :data:`~fishtail_kinematics.engine.blocks.BLOCK_SAMPLES` values),
        so that the solve's temporaries stay in the cache, straight into the results: with
        :attr:`compiled` and numba there, by the compiled pass of :mod:`~.drive_pass` (whatever
        the batch's size, so that a linkage's numbers do not depend on it); else, for more than
        a block, by numpy's blocks. The state's ``motor_angle`` and ``motor_velocity`` are the
        inputs broadcast (read-only views).
        """
        angle = np.asarray(motor_angle, dtype=float)
        velocity = np.asarray(motor_velocity, dtype=float)
        shape = np.broadcast_shapes(angle.shape, velocity.shape, (self.size,))
        c = self.constants
        passes = drive_pass.compiled_pass() if self.compiled else None
        if passes is None and (len(shape) < 2 or math.prod(shape) <= BLOCK_SAMPLES):
            with np.errstate(invalid="ignore"):
                return solve_drive_arrays(c, angle, velocity)
        shared = {"fin_angle"} if c.mounted_at_mid else set()
        fields = [name for name in DRIVE_ARRAY_FIELDS if name not in shared]
        # One block for every field: numpy asks the kernel for huge pages for large arrays, so
        # that fresh memory costs a few page faults instead of one every 4 kB (on a virtual
        # machine that cost more than the solve).
        block_of_results = np.empty((len(fields), *shape))
        results = dict(zip(fields, block_of_results, strict=True))
        rows = {name: value.reshape(-1, self.size) for name, value in results.items()}
        angle_rows, velocity_rows = _rows(angle, shape), _rows(velocity, shape)
        step = max(1, min(angle_rows.shape[0], BLOCK_SAMPLES // self.size))
        coefficients = drive_coefficients(c)
        if passes is not None:
            table = drive_pass.coefficient_table(coefficients, self.size)
            scratch = np.empty((drive_pass.SCRATCH, step, self.size))
        else:
            scratch = np.empty((DRIVE_SCRATCH, step, self.size))
        with np.errstate(invalid="ignore"):
            for start in range(0, angle_rows.shape[0], step):
                block = slice(start, start + step)
                count = len(range(*block.indices(angle_rows.shape[0])))
                out = {name: value[block] for name, value in rows.items()}
                work = list(scratch[:, :count])
                if passes is not None:
                    drive_pass.solve_block(
                        passes, c, table, angle_rows[block], velocity_rows[block], out, work
                    )
                else:
                    solve_drive_arrays(
                        c, angle_rows[block], velocity_rows[block], out, work, coefficients
                    )
        if c.mounted_at_mid:
            results["fin_angle"] = results["theta3"]
        theta2_dot = results["theta2_dot"]
        state = OscillatoryState(
            np.broadcast_to(angle, shape), np.broadcast_to(velocity, shape),
            results["slider_position"], results["slider_velocity"], results["theta1"],
            results["theta1_dot"], results["theta2"], theta2_dot, results["theta3"], theta2_dot,
            results["tip_x"], results["tip_y"], results["tip_x_dot"], results["tip_y_dot"],
            results["fin_angle"], theta2_dot,
        )  # fmt: skip
        return state, results["cos_fin"], results["sin_fin"]


def _rows(value: FloatArray, shape: tuple[int, ...]) -> FloatArray:
    """``value`` over the rows of ``shape`` (all but its last axis), its own last axis kept.

    Shape (rows, 1) for a value shared by the linkages, (rows, N) for one per linkage (views
    where the layout allows).
    """
    last = value.shape[-1] if value.ndim else 1
    return np.broadcast_to(value, (*shape[:-1], last)).reshape(-1, last)
