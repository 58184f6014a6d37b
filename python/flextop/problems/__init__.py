"""Optimization problems on a scene's responses: one scene (:mod:`.topology`:
:class:`TopologyProblem`, its tolerance rule, limits and the paper's problems), several
that share the design (:mod:`.scenarios`: :class:`Scenario`, :class:`ScenarioProblem`), or a
spatial scene (:mod:`.spatial`: :class:`SpatialProblem`; :mod:`.sizing`: :class:`SizingProblem`, its
sections' sizes as the design)."""

from . import filters, scenarios, sizing, spatial, topology
from .filters import DensityFilter, SensitivityFilter
from .sizing import SizingProblem
from .spatial import SpatialProblem
from .scenarios import DESIGN_ONLY, WORST_CASE_RANGE, Aggregate, Scenario, ScenarioProblem, evaluate, robust_robot_arm
from .topology import (AGGREGATES, FLOOR_MODES, FLOOR_RHO, FLOOR_RTOL, KEPT_RATIOS, MIN_FREQUENCY, NORMALIZATION_DAMPING,
                       READAPT, TEN_BAR_ALLOWABLE, TopologyProblem, is_aggregate, per_bar_limits, relation,
                       robot_arm_problem, static_truss_problem, ten_bar_truss_problem, tightened, volume_constraints)

__all__ = ["AGGREGATES", "Aggregate", "DESIGN_ONLY", "DensityFilter", "SensitivityFilter", "filters", "FLOOR_MODES", "FLOOR_RHO", "FLOOR_RTOL", "KEPT_RATIOS",
           "MIN_FREQUENCY", "NORMALIZATION_DAMPING", "READAPT", "Scenario", "ScenarioProblem", "SizingProblem", "sizing", "SpatialProblem", "spatial", "TEN_BAR_ALLOWABLE",
           "TopologyProblem", "WORST_CASE_RANGE", "evaluate", "is_aggregate", "per_bar_limits", "relation",
           "robot_arm_problem", "robust_robot_arm", "scenarios", "static_truss_problem", "ten_bar_truss_problem",
           "tightened", "topology", "volume_constraints"]
