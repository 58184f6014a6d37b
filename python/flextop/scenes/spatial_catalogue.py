"""Spatial example scenes: the heavy symmetric top of Brüls, Cardona & Arnold (2012) and a
slider-crank whose crank turns about an axis tilted against the slider's line, its rod on a
ball joint and a Cardan joint moving through space. Units SI."""

from __future__ import annotations

import math

import numpy as np

from ..errors import SceneError
from .builder import trapezoidal
from .spatial import SpatialScene, axis_angle

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


def spatial_robot_arm(*, nx: int = 5, ny: int = 2, nz: int = 2, connectivity: str = "diagonals", payload: float = 2.0,
                      t_end: float = 1.0, h: float = 0.01) -> SpatialScene:
    """A robot arm in space: a base turning about the vertical z, a shoulder and an elbow
    pitching about horizontal axes, each driven by a trapezoidal law, two aluminium lattice
    links (``nx × ny × nz`` nodes of tubes joined by ``connectivity``; 0.6 m and 0.5 m long,
    0.1 m high, 0.08 m wide), each welded face by face to the joints' hubs, and a
    ``payload`` (kg, on a hub of its own, 2 kg by default) welded to the second link's end. The base turns 1 rad while the shoulder lifts
    0.4 rad and the elbow folds 0.8 rad: the payload moves out of every plane. Each bar's
    density is a design variable."""
    scene = SpatialScene("spatial_robot_arm", gravity=(0.0, 0.0, -9.81))
    scene.section("alu", E=7e10, rho=2700.0, nu=0.33, shape="tube", outer=0.012, inner=0.009)
    height, width, shoulder = 0.1, 0.08, np.array([0.0, 0.0, 0.2])
    upright = axis_angle((1.0, 0.0, 0.0), math.pi / 2)  # the links' height along z, their width along −y

    def face(origin: np.ndarray, x: float) -> dict[str, tuple[float, float, float]]:
        """The points of a link's face at ``x`` (from ``origin``), by lattice row and layer."""
        frac = lambda i, n: i / (n - 1) - 0.5 if n > 1 else 0.0  # noqa: E731
        return {f"p{j}{k}": (x, -width * frac(k, nz), height * frac(j, ny)) for j in range(ny) for k in range(nz)}

    def hub(name: str, at: np.ndarray, mass: float, links: list[tuple[str, int]]) -> None:
        """A rigid hub at ``at`` welded to each ``(link, column)`` face of lattice nodes."""
        points = {f"{link}{key}": p for link, _ in links for key, p in face(at, 0.0).items()}
        scene.rigid_body(name, mass=mass, inertia=(mass * 1e-3,) * 3, position=tuple(at), points=points)
        for link, column in links:
            for j in range(ny):
                for k in range(nz):
                    scene.weld(f"{name}_{link}{j}{k}", f"{name}.{link}p{j}{k}", f"{link}[{column},{j},{k}]")

    lengths = {"link1": 0.6, "link2": 0.5}
    elbow, tip = shoulder + [lengths["link1"], 0.0, 0.0], shoulder + [lengths["link1"] + lengths["link2"], 0.0, 0.0]
    for link, origin in (("link1", shoulder), ("link2", elbow)):
        scene.ground_structure(link, nx=nx, ny=ny, nz=nz, length=lengths[link], height=height, width=width,
                               section="alu", connectivity=connectivity, origin=tuple(origin), orientation=upright)
    scene.rigid_body("base", mass=5.0, inertia=(0.02, 0.02, 0.02), position=(0.0, 0.0, 0.1),
                     points={"floor": (0.0, 0.0, -0.1), "shoulder": (0.0, 0.0, 0.1)})
    scene.revolute("turn", "ground", "base.floor", axis=(0.0, 0.0, 1.0),
                   drive=trapezoidal(0.0, 1.0, acceleration=12.0, speed=2.0))
    hub("shoulder", shoulder, 0.3, [("link1", 0)])
    scene.revolute("lift", "base.shoulder", "shoulder", axis=(0.0, 1.0, 0.0),
                   drive=trapezoidal(0.0, -0.4, acceleration=8.0, speed=1.0))
    hub("elbow_a", elbow, 0.2, [("link1", nx - 1)])
    hub("elbow_b", elbow, 0.2, [("link2", 0)])
    scene.revolute("fold", "elbow_a", "elbow_b", axis=(0.0, 1.0, 0.0),
                   drive=trapezoidal(0.0, 0.8, acceleration=10.0, speed=1.5))
    if not (isinstance(payload, (int, float)) and math.isfinite(payload) and payload > 0.0):
        raise SceneError(f"spatial_robot_arm: the payload {payload!r} must be a positive mass in kg")
    hub("payload", tip, payload, [("link2", nx - 1)])
    scene.tip = "payload"
    scene.simulation(t_end=t_end, h=h, rho_inf=0.8)
    return scene


def spatial_paper_arm(*, nz: int = 2, depth: float = 0.1, offset: float = 0.05, connectivity: str = "full",
                      t_end: float = 1.3, h: float = 0.02) -> SpatialScene:
    """The paper's two-link arm (reference scenes: horizontal plane, no gravity, links of
    1 m by 0.1 m, solid aluminium bars of 20 mm, θ₁ and θ₂ from π/3 to π/2 on trapezoidal
    laws, a 5 kg payload at the tip) built as 3D lattices of ``5 × 3 × nz`` nodes, ``depth``
    deep (along z) with the bars of ``connectivity``, each link welded face by face to its
    joints' hubs (0.1 kg); the payload sits ``offset`` out of the links' mid-plane, so that
    its inertia twists and bends them out of their plane and the design needs depth. At
    ``offset = 0`` the arm moves in its plane. Each bar's density is a design variable."""
    if not (isinstance(nz, int) and nz >= 1):
        raise SceneError(f"nz: {nz!r} must be a whole number of layers, at least 1")
    scene = SpatialScene("spatial_paper_arm", gravity=(0.0, 0.0, 0.0))
    scene.section("al", E=7e10, rho=2700.0, nu=0.32, diameter=0.02)
    length, height, theta = 1.0, 0.1, math.pi / 3
    frac = lambda i, n: i / (n - 1) - 0.5 if n > 1 else 0.0  # noqa: E731
    face = {f"p{j}{k}": (0.0, height * frac(j, 3), depth * frac(k, nz)) for j in range(3) for k in range(nz)}
    links = {"link1": (np.zeros(3), theta), "link2": (length * np.array([math.cos(theta), math.sin(theta), 0.0]), 2 * theta)}
    for name, (origin, angle) in links.items():
        scene.ground_structure(name, nx=5, ny=3, nz=nz, length=length, height=height, width=depth, section="al",
                               connectivity=connectivity, origin=tuple(origin),
                               orientation=axis_angle((0.0, 0.0, 1.0), angle))

    def hub(name: str, link: str, column: int, mass: float, lateral: float = 0.0) -> None:
        """A hub on ``link``'s face ``column``, welded to its nodes, ``lateral`` out of plane."""
        origin, angle = links[link]
        at = origin + column / 4 * length * np.array([math.cos(angle), math.sin(angle), 0.0])
        points = {key: (x, y, z - lateral) for key, (x, y, z) in face.items()}
        scene.rigid_body(name, mass=mass, inertia=(mass * 1e-4,) * 3, position=tuple(at + [0.0, 0.0, lateral]),
                         orientation=axis_angle((0.0, 0.0, 1.0), angle), points=points)
        for j in range(3):
            for k in range(nz):
                scene.weld(f"{name}_{j}{k}", f"{name}.p{j}{k}", f"{link}[{column},{j},{k}]")

    law = trapezoidal(math.pi / 3, math.pi / 2, acceleration=2.0, speed=0.5)
    hub("shoulder", "link1", 0, 0.1)
    scene.revolute("shoulder_drive", "ground", "shoulder", axis=(0.0, 0.0, 1.0), drive=law)
    hub("elbow_a", "link1", 4, 0.1)
    hub("elbow_b", "link2", 0, 0.1)
    scene.revolute("elbow_drive", "elbow_a", "elbow_b", axis=(0.0, 0.0, 1.0), drive=law)
    hub("payload", "link2", 4, 5.0, lateral=offset)
    scene.tip = "payload"
    scene.simulation(t_end=t_end, h=h, rho_inf=0.8)
    return scene
