"""Scenes: the builder (:mod:`.builder`: :class:`Scene`, TOML in and out) and the catalogue
of examples (:mod:`.catalogue`: the paper's two, the mechanisms of multibody benchmarks,
the literature's ten-bar truss), each builder's arguments checked before it builds."""

from .spatial import SpatialScene, axis_angle
from .spatial_catalogue import heavy_top, spatial_paper_arm, spatial_robot_arm, spatial_slider_crank
from .builder import GroundStructure, Member, Scene, motion_table, read_toml, trapezoidal
from .catalogue import (ALUMINIUM, BUILT_IN, DIAMETER, EXAMPLES, INCH, KIP, KSI, LIMITS, STEEL, continuum_cantilever,
                        continuum_robot_arm, continuum_slider_crank, example_toml, four_bar, half_mbb, half_mbb_unit,
                        pendulum, pendulum_period, robot_arm, slider_crank, spun_beam, static_truss, stayed_frame,
                        ten_bar_truss)

__all__ = ["ALUMINIUM", "BUILT_IN", "DIAMETER", "EXAMPLES", "GroundStructure", "INCH", "Member", "KIP", "KSI", "LIMITS", "STEEL",
           "Scene", "SpatialScene", "axis_angle", "heavy_top", "spatial_paper_arm", "spatial_robot_arm", "spatial_slider_crank", "continuum_cantilever", "continuum_robot_arm", "continuum_slider_crank", "example_toml", "four_bar", "half_mbb", "half_mbb_unit", "motion_table", "pendulum", "pendulum_period", "read_toml", "robot_arm",
           "slider_crank", "spun_beam", "static_truss", "stayed_frame", "ten_bar_truss", "trapezoidal"]
