"""The names of the columns the synthesis writes, in ``front.csv`` and in sweeps: one home.

A column of an objective or a margin carries its unit (``speed_L_per_s``,
``margin_rms_current_A``), a figure its tier (``search_speed_m_s``, ``verified_speed_m_s``).

>>> from fishtail_design.objectives import OBJECTIVES
>>> objective_column(OBJECTIVES["cost_of_transport"])
'cost_of_transport_J_per_(kg_m)'
>>> figure_column("search", "speed_m_s")
'search_speed_m_s'
"""

from __future__ import annotations

from fishtail_design.constraints import Constraint
from fishtail_design.objectives import Objective


def unit_suffix(unit: str) -> str:
    """``_unit`` for a column name (``/`` as ``_per_``, spaces as ``_``); nothing if unitless."""
    return "" if not unit else "_" + unit.replace("/", "_per_").replace(" ", "_")


def objective_column(objective: Objective) -> str:
    """An objective's column: its name and unit."""
    return f"{objective.name}{unit_suffix(objective.unit)}"


def margin_column(constraint: Constraint) -> str:
    """A constraint's margin's column: ``margin_``, its name and unit."""
    return f"margin_{constraint.name}{unit_suffix(constraint.unit)}"


def figure_column(tier: str, field: str) -> str:
    """A figure's column: the tier that computed it (``search``, ``verified``) and its field."""
    return f"{tier}_{field}"
