"""The columns of ``fishtail-kinematics table``: written by the CLI, read back by the analysis.

A column is an engine state field, some under the report's short name (OP, Tx, ...).

>>> table_columns(("motor_angle", "slider_position", "theta3", "theta5", "tip_x_dot"))
('motor_angle_rad', 'OP', 'theta3', 'theta5')
>>> FIELD_OF_COLUMN["Tx"]
'tip_x'
"""

from __future__ import annotations

from collections.abc import Iterable

#: Every column, in table order; a mechanism's table has those of its state fields.
COLUMNS = (
    "motor_angle_rad", "OP", "theta1", "theta2", "theta3", "theta3_dot", "Tx", "Ty",
    "theta4", "AU", "AS", "theta5", "theta5_dot",
)  # fmt: skip
#: Engine state field of each column.
FIELD_OF_COLUMN = {
    **{column: column for column in COLUMNS},
    "motor_angle_rad": "motor_angle",
    "OP": "slider_position",
    "Tx": "tip_x",
    "Ty": "tip_y",
    "AU": "pin_u_distance",
    "AS": "slider_a_distance",
}


def table_columns(state_fields: Iterable[str]) -> tuple[str, ...]:
    """The columns of a table of states with these fields, in table order."""
    fields = set(state_fields)
    return tuple(column for column in COLUMNS if FIELD_OF_COLUMN[column] in fields)
