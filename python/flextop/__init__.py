"""flextop — topology optimization of flexible multibody systems in their real motion.

A Rust engine (co-rotational beams with the exact Timoshenko local stiffness, joints as
constraints with Lagrange multipliers, generalized-α, exact design sensitivities) behind a
Python front for scenes, optimizers, plots and the command line. Method: Brüls, Lemaire,
Duysinx & Eberhard, *Optimization of multibody systems and their structural components*.
"""

from . import responses, scenes
from .errors import (CheckpointError, DesignError, ExecutionError, FlextopError, PlausibilityWarning, SceneError, SceneFileError,
                     SettingsError, SimulationError, ToleranceError)
from .optimizers import OptimizeResult, optimize
from .problems import Scenario, ScenarioProblem, TopologyProblem, robot_arm_problem, static_truss_problem, volume_constraints
from .scenes import GroundStructure, Member, Scene, motion_table, trapezoidal
from .results import Bars, Joint, Results, Sensitivities, StaticResults
from .simulation import Simulation, load
from .spatial import SpatialSimulation
from .scenes.spatial import SpatialScene, axis_angle

__all__ = [
    "Bars", "CheckpointError", "DesignError", "ExecutionError", "FlextopError", "GroundStructure", "Joint", "Member", "OptimizeResult", "PlausibilityWarning", "Results", "Scenario", "ScenarioProblem", "Scene", "SceneError", "SceneFileError", "SettingsError",
    "Sensitivities", "Simulation", "SpatialScene", "SpatialSimulation", "axis_angle", "SimulationError", "StaticResults", "TopologyProblem", "motion_table", "optimize", "robot_arm_problem",
    "load", "responses", "scenes", "static_truss_problem", "ToleranceError", "trapezoidal", "volume_constraints",
]
__version__ = "0.1.0"


def __getattr__(name: str) -> object:
    """``flextop.plots`` on first use: matplotlib is imported only when a figure is asked
    for."""
    if name == "plots":
        import importlib

        return importlib.import_module(f".{name}", __name__)
    raise AttributeError(f"module 'flextop' has no attribute {name!r}")
