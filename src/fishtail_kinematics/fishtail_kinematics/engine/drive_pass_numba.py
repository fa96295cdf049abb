"""The compiled pass of :mod:`~.drive_pass`: numba's build of :func:`~.oscillatory_tail.drive_pose`.

Imports numba: only :func:`~.drive_pass.compiled_pass` imports this module, on first use.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numba

from fishtail_common.compiled_cache import key_cache_to_sources
from fishtail_kinematics.engine import oscillatory_tail
from fishtail_kinematics.engine.oscillatory_tail import drive_pose

Compiler = Callable[[Callable[..., Any]], Callable[..., Any]]

# The formula as it stands; numpy's error model: a linkage that does not assemble gives NaN.
_formula: Compiler = numba.njit(nogil=True, error_model="numpy")
_cached: Compiler = numba.njit(cache=True, nogil=True, error_model="numpy")
_pose = _formula(drive_pose)


@_formula
def _pose_at(table: Any, n: int, cos_carrier: float, sin_carrier: float, phi_dot: float) -> Any:
    """The formula for linkage ``n`` of the coefficient table."""
    return _pose(
        cos_carrier, sin_carrier, phi_dot, table[0, n], table[1, n], table[2, n], table[3, n],
        table[4, n], table[5, n], table[6, n], table[7, n], table[8, n], table[9, n],
        table[10, n], table[11, n], table[12, n], table[13, n], table[14, n], table[15, n],
    )  # fmt: skip


# Each pass runs three loops over a row, each evaluating the formula and keeping a few of its
# values: LLVM vectorises a loop with at most six such streams (more need too many checks that
# the arrays do not overlap), and the formula vectorised three times costs less than once in
# scalar code. Inputs and outputs are C-contiguous (a strided input is not vectorised either).
def _rates_rows(
    table: Any, cos_carrier: Any, sin_carrier: Any, phi_dot: Any, op: Any, op_dot: Any,
    theta1_dot: Any, theta2_dot: Any, tip_x: Any, tip_y: Any, tip_x_dot: Any, tip_y_dot: Any,
    cos_fin: Any, sin_fin: Any, sin_beta: Any, cos1: Any, sin1: Any,
) -> None:  # fmt: skip
    # The angles and speeds shared by every linkage: one of each a row.
    for row in range(op.shape[0]):
        cos_row, sin_row, speed = cos_carrier[row], sin_carrier[row], phi_dot[row]
        for n in range(op.shape[1]):
            p = _pose_at(table, n, cos_row, sin_row, speed)
            op[row, n], op_dot[row, n] = p[0], p[1]
            sin_beta[row, n], cos1[row, n], sin1[row, n] = p[14], p[15], p[16]
        for n in range(op.shape[1]):
            p = _pose_at(table, n, cos_row, sin_row, speed)
            theta1_dot[row, n], theta2_dot[row, n] = p[3], p[5]
            cos_fin[row, n], sin_fin[row, n] = p[12], p[13]
        for n in range(op.shape[1]):
            p = _pose_at(table, n, cos_row, sin_row, speed)
            tip_x[row, n], tip_y[row, n] = p[7], p[8]
            tip_x_dot[row, n], tip_y_dot[row, n] = p[9], p[10]


def _rates_own(
    table: Any, cos_carrier: Any, sin_carrier: Any, phi_dot: Any, op: Any, op_dot: Any,
    theta1_dot: Any, theta2_dot: Any, tip_x: Any, tip_y: Any, tip_x_dot: Any, tip_y_dot: Any,
    cos_fin: Any, sin_fin: Any, sin_beta: Any, cos1: Any, sin1: Any,
) -> None:  # fmt: skip
    # An angle and a speed of its own for every linkage and row.
    for row in range(op.shape[0]):
        for n in range(op.shape[1]):
            p = _pose_at(table, n, cos_carrier[row, n], sin_carrier[row, n], phi_dot[row, n])
            op[row, n], op_dot[row, n] = p[0], p[1]
            sin_beta[row, n], cos1[row, n], sin1[row, n] = p[14], p[15], p[16]
        for n in range(op.shape[1]):
            p = _pose_at(table, n, cos_carrier[row, n], sin_carrier[row, n], phi_dot[row, n])
            theta1_dot[row, n], theta2_dot[row, n] = p[3], p[5]
            cos_fin[row, n], sin_fin[row, n] = p[12], p[13]
        for n in range(op.shape[1]):
            p = _pose_at(table, n, cos_carrier[row, n], sin_carrier[row, n], phi_dot[row, n])
            tip_x[row, n], tip_y[row, n] = p[7], p[8]
            tip_x_dot[row, n], tip_y_dot[row, n] = p[9], p[10]


#: The compiled passes' numba dispatchers (plain functions with NUMBA_DISABLE_JIT): angles and
#: speeds shared by the linkages, one a row; or their own, one for every linkage and row.
RATES_SHARED: Any = _cached(_rates_rows)
RATES_OWN: Any = _cached(_rates_own)
for _dispatcher in (RATES_SHARED, RATES_OWN):
    key_cache_to_sources(_dispatcher, oscillatory_tail)
