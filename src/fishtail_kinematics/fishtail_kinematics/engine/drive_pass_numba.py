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


@_cached
def _rates(
    table: Any, cos_carrier: Any, sin_carrier: Any, phi_dot: Any, op: Any, op_dot: Any,
    theta1_dot: Any, theta2_dot: Any, tip_x: Any, tip_y: Any, tip_x_dot: Any, tip_y_dot: Any,
    cos_fin: Any, sin_fin: Any, sin_beta: Any, cos1: Any, sin1: Any,
) -> None:  # fmt: skip
    for row in range(op.shape[0]):
        for n in range(op.shape[1]):
            p = _pose(
                cos_carrier[row, n], sin_carrier[row, n], phi_dot[row, n], table[0, n],
                table[1, n], table[2, n], table[3, n], table[4, n], table[5, n], table[6, n],
                table[7, n], table[8, n], table[9, n], table[10, n], table[11, n], table[12, n],
                table[13, n], table[14, n], table[15, n],
            )  # fmt: skip
            op[row, n], op_dot[row, n] = p[0], p[1]
            theta1_dot[row, n], theta2_dot[row, n] = p[3], p[5]
            tip_x[row, n], tip_y[row, n], tip_x_dot[row, n], tip_y_dot[row, n] = (
                p[7], p[8], p[9], p[10],
            )  # fmt: skip
            cos_fin[row, n], sin_fin[row, n] = p[12], p[13]
            sin_beta[row, n], cos1[row, n], sin1[row, n] = p[14], p[15], p[16]


#: The compiled pass's numba dispatcher (the plain function with NUMBA_DISABLE_JIT).
RATES: Any = _rates
key_cache_to_sources(RATES, oscillatory_tail)
