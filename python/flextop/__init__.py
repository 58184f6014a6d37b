"""flextop — topology optimization of flexible multibody systems in their real motion.

A Rust engine (geometrically exact co-rotational beams, joints as constraints with Lagrange
multipliers, generalized-α, exact design sensitivities) behind a Python front for scenes,
optimizers, plots and the command line. Method: Brüls, Lemaire, Duysinx & Eberhard,
*Optimization of multibody systems and their structural components*.
"""

from . import scenes
from .errors import DesignError, FlextopError, SceneError, SettingsError, SimulationError
from .scene import GroundStructure, Scene, motion_table, trapezoidal
from .simulation import Results, Simulation, StaticResults

__all__ = [
    "DesignError", "FlextopError", "GroundStructure", "Results", "Scene", "SceneError", "SettingsError",
    "Simulation", "SimulationError", "StaticResults", "motion_table", "scenes", "trapezoidal",
]
__version__ = "0.1.0"
