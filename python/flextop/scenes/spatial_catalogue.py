"""Spatial example scenes: the heavy symmetric top of Brüls, Cardona & Arnold (2012) and a
slider-crank whose crank turns about an axis tilted against the slider's line, its rod on a
ball joint and a Cardan joint moving through space. Units SI."""

from __future__ import annotations

import math

import numpy as np

from ..errors import SceneError
from .builder import trapezoidal
from .spatial import SpatialScene

TOP_MASS = 15.0
"""The top's mass (kg)."""

TOP_INERTIA = (0.234375, 0.46875, 0.234375)
"""The top's principal moments about its centre of mass (kg m²), symmetric about its y."""

TOP_SPIN = (0.0, 150.0, -4.61538)
"""The top's initial angular velocity (rad/s): a fast spin about its axis, a slow
precession."""


def heavy_top(*, t_end: float = 0.5, h: float = 1e-3) -> SpatialScene:
    """The heavy symmetric top: 15 kg, its centre of mass 1 m from a fixed pivot along its
    symmetry axis y, spun at 150 rad/s about it under gravity along −z."""
    scene = SpatialScene("heavy_top", gravity=(0.0, 0.0, -9.81))
    arm = np.array([0.0, 1.0, 0.0])
    spin = np.array(TOP_SPIN)
    scene.rigid_body("top", mass=TOP_MASS, inertia=TOP_INERTIA, position=tuple(arm), points={"tip": tuple(-arm)},
                     velocity=tuple(np.cross(spin, arm)), angular_velocity=TOP_SPIN)
    scene.spherical("pivot", "top.tip")
    scene.tip = "top"
    scene.simulation(t_end=t_end, h=h, rho_inf=0.9)
    return scene


def spatial_slider_crank(*, crank: float = 0.15, rod: float = 0.3, tilt_deg: float = 30.0, turn: float = 2.0 * math.pi,
                         acceleration: float = 200.0, speed: float = 20.0, t_end: float = 0.6,
                         h: float = 1e-3) -> SpatialScene:
    """A slider-crank in space: the crank (``crank`` m, 0.4 kg) turns about an axis through
    the origin tilted by ``tilt_deg`` from z towards y, driven through ``turn`` rad by a
    trapezoidal law; the rod (``rod`` m, 0.6 kg) joins the crank's pin by a ball joint and
    the slider (0.3 kg) by a Cardan joint; the slider runs along x. At crank angle θ the pin
    is at ``r (cos θ, sin θ cos α, −sin θ sin α)`` and the slider at
    ``x = p_x + √(l² − p_y² − p_z²)``."""
    if not (0.0 < crank < rod) or not math.isfinite(rod):
        raise SceneError(f"spatial_slider_crank: the crank ({crank} m) must be shorter than the rod ({rod} m), both positive")
    if not abs(tilt_deg) < 90.0:
        raise SceneError(f"spatial_slider_crank: tilt_deg {tilt_deg} must lie in (−90, 90)")
    alpha = math.radians(tilt_deg)
    scene = SpatialScene("spatial_slider_crank", gravity=(0.0, 0.0, -9.81))
    thin = 1e-5

    def bar(mass: float, length: float) -> tuple[float, float, float]:
        return (mass * thin, mass * length**2 / 12.0, mass * length**2 / 12.0)

    scene.rigid_body("crank", mass=0.4, inertia=bar(0.4, crank), position=(crank / 2, 0.0, 0.0),
                     points={"pivot": (-crank / 2, 0.0, 0.0), "pin": (crank / 2, 0.0, 0.0)})
    scene.rigid_body("rod", mass=0.6, inertia=bar(0.6, rod), position=(crank + rod / 2, 0.0, 0.0),
                     points={"big_end": (-rod / 2, 0.0, 0.0), "small_end": (rod / 2, 0.0, 0.0)})
    scene.rigid_body("slider", mass=0.3, inertia=(1e-4, 1e-4, 1e-4), position=(crank + rod, 0.0, 0.0))
    scene.revolute("crank", "ground", "crank.pivot", axis=(0.0, math.sin(alpha), math.cos(alpha)),
                   drive=trapezoidal(0.0, turn, acceleration=acceleration, speed=speed))
    scene.spherical("pin", "crank.pin", "rod.big_end")
    scene.universal("wrist", "rod.small_end", "slider", axes=((0.0, 1.0, 0.0), (0.0, 0.0, 1.0)))
    scene.prismatic("slide", (crank + rod, 0.0, 0.0), "slider", axis=(1.0, 0.0, 0.0))
    scene.tip = "slider"
    scene.simulation(t_end=t_end, h=h, rho_inf=0.8)
    return scene
