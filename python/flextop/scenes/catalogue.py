"""The paper's two examples with the fixed dimensions of the project's reference scenes
(``docs/reference-scenes.md``), every number a parameter; and the mechanisms of multibody
benchmarks: a rigid pendulum, the flexible slider-crank of Song & Haug, a four-bar with a
flexible coupler.

These builders are the one definition of the example scenes: ``examples/*.toml`` are their
output at the defaults (:func:`example_toml`), written by ``python scripts/write_examples.py``;
a test checks the committed files are up to date."""

from __future__ import annotations

import functools
import inspect
import math
from collections.abc import Callable
from typing import Any, TypeVar

import numpy as np

from .. import _core
from ..checks import number, real, whole
from ..errors import SceneError
from .builder import Scene, motion_table, trapezoidal
from .spatial_catalogue import heavy_top, spatial_paper_arm, spatial_robot_arm, spatial_slider_crank

#: The engine's limits on a model's size, by name (``grid_nodes``, ``split``, ``nodes``,
#: ``elements``): the builders check their counts against them before building.
LIMITS = dict(_core.size_limits())

_POSITIVE = ("length", "height", "E", "rho", "diameter", "p", "t_end", "h", "acceleration", "speed", "mass", "g", "thickness",
             "periods", "crank", "rod", "coupler", "rocker", "ground", "time_constant", "bay", "area")
#: Each builder argument's interval by name, the same everywhere: (low, high, brackets).
_RANGES: dict[str, tuple[float, float, str]] = {**dict.fromkeys(_POSITIVE, (0.0, math.inf, "()")),
                                                 "x_min": (0.0, 1.0, "()"), "nu": (-1.0, 0.5, "()"),
                                                 "tip_mass": (0.0, math.inf, "[)"), "rho_inf": (0.0, 1.0, "[]")}

_Builder = TypeVar("_Builder", bound=Callable[..., Scene])


def _checked(sizes: Callable[..., dict[str, int]], **ranges: tuple[float, float, str]) -> Callable[[_Builder], _Builder]:
    """A builder whose arguments are checked before it builds anything: counts (``int``)
    whole numbers ≥ 1, other numbers finite reals in their range (``_RANGES``, or this
    builder's own ``ranges``), and the sizes they make (``sizes`` of the arguments: limit
    name → size) within :data:`LIMITS`. Each refusal is a ``SceneError`` naming the
    builder's argument; so is a float the scene's arithmetic overflows (its largest
    number, :func:`_largest`)."""

    def wrap(builder: _Builder) -> _Builder:
        signature = inspect.signature(builder)

        @functools.wraps(builder)
        def checked(*args: Any, **kwargs: Any) -> Scene:
            try:
                bound = signature.bind(*args, **kwargs)
            except TypeError as e:
                raise SceneError(f"{builder.__name__}: {e}") from None
            bound.apply_defaults()
            given = bound.arguments
            for name, value in given.items():
                _check_argument(builder.__name__, name, value, signature.parameters[name].annotation,
                                ranges.get(name, _RANGES.get(name)))
            for limit, size in sizes(**given).items():
                if size > LIMITS[limit]:
                    raise SceneError(f"{builder.__name__}: these arguments make {size:,} {limit.replace('_', ' ')}, "
                                     f"beyond the limit of {LIMITS[limit]:,}")
            try:
                return builder(*args, **kwargs)
            except OverflowError:
                raise SceneError(f"{builder.__name__}: {_largest(given)} is too large: the scene made of it "
                                 "overflows a float") from None

        return checked  # type: ignore[return-value]

    return wrap


def _largest(given: dict[str, Any]) -> str:
    """``name = value`` of the argument of largest magnitude among ``given``'s numbers."""
    numbers = {name: v for name, v in given.items() if real(v) is not None}
    name = max(numbers, key=lambda k: abs(numbers[k]), default=None)
    return "an argument" if name is None else f"{name} = {numbers[name]:g}"


def _check_argument(builder: str, name: str, value: Any, annotation: str, span: tuple[float, float, str] | None) -> None:
    where = f"{builder}: {name}"
    if annotation == "int":
        whole(where, value, error=SceneError)
        return
    pair = annotation.startswith("tuple")
    if pair and (not isinstance(value, (tuple, list, np.ndarray)) or len(value) != annotation.count("float")):
        raise SceneError(f"{where} must be {annotation.count('float')} numbers, got {value!r}")
    optional = annotation == "float | None"
    numbers = list(value) if pair else [value] if annotation == "float" or (optional and value is not None) else []
    for v in numbers:
        if real(v) is None:
            raise SceneError(f"{where} must be a finite number, got {value!r}")
        if span is not None:
            number(where, v, *span, error=SceneError)

#: Aluminium (Pa, -, kg/m³) and the solid circular section diameter (m).
ALUMINIUM = {"E": 70e9, "nu": 0.32, "rho": 2700.0}
DIAMETER = 0.02

STEEL = {"E": 200e9, "nu": 0.3, "rho": 7870.0}
"""Steel (Pa, -, kg/m³), the slider-crank's."""


def _linkage_section(scene: Scene, E: float, nu: float, rho: float, diameter: float) -> str:
    return scene.section("aluminium", E=E, nu=nu, rho=rho, diameter=diameter)


@_checked(lambda nx, ny, split, **_: {"grid_nodes": nx * ny, "split": split})
def robot_arm(*, nx: int = 5, ny: int = 3, length: float = 1.0, height: float = 0.1, split: int = 1,
              tip_mass: float = 5.0, theta_start: float = math.pi / 3, theta_end: float = math.pi / 2,
              acceleration: float = 2.0, speed: float = 0.5, E: float = ALUMINIUM["E"], nu: float = ALUMINIUM["nu"],
              rho: float = ALUMINIUM["rho"], diameter: float = DIAMETER, p: float = 3.0, x_min: float = 0.01,
              t_end: float = 1.3, h: float = 0.02, rho_inf: float = 0.8) -> Scene:
    """Two-link robot arm of paper Section 4, moving in a horizontal plane (no gravity).

    Link 1 is a ground structure at the origin along ``theta_start``; link 2 starts at link
    1's node (L, 0) along ``2 theta_start``. The shoulder pins link 1's middle base node and
    drives θ1, the elbow hinges the two coincident nodes and drives θ2; both follow the same
    trapezoidal law. A ``tip_mass`` (the payload, kg; 0 for none) sits on link 2's node
    (L, 0), the ``tip``. ``ny`` must be
    odd: the joints and the tip sit on the row of nodes along each link's axis.
    """
    if ny % 2 == 0:
        raise SceneError(f"robot_arm: ny must be odd, so that a row of nodes lies on each link's axis for the joints (got {ny})")
    scene = Scene("robot_arm")
    scene.tip = f"link2[{nx - 1},{ny // 2}]"
    section = _linkage_section(scene, E, nu, rho, diameter)
    link1 = scene.ground_structure("link1", nx=nx, ny=ny, length=length, height=height, origin=(0.0, 0.0),
                                   angle=theta_start, section=section, split=split)
    link2 = scene.ground_structure("link2", nx=nx, ny=ny, length=length, height=height,
                                   origin=link1.node(nx - 1, ny // 2), angle=2 * theta_start, section=section,
                                   split=split)
    if tip_mass != 0.0:  # no payload: no point mass
        scene.point_mass(link2.node(nx - 1, ny // 2), tip_mass)
    motion = trapezoidal(theta_start, theta_end, acceleration=acceleration, speed=speed)
    scene.pin("shoulder", link1.node(0, ny // 2), drive=motion)
    scene.hinge("elbow", link1.node(nx - 1, ny // 2), link2.node(0, ny // 2), drive=dict(motion))
    scene.design(interpolation="simp", p=p, x_min=x_min)
    scene.simulation(t_end=t_end, h=h, rho_inf=rho_inf)
    return scene


@_checked(lambda nx, ny, **_: {"elements": 2 * nx * ny})
def continuum_robot_arm(*, nx: int = 60, ny: int = 20, length: float = 1.0, height: float = 0.1, thickness: float = 0.005,
                        tip_mass: float = 5.0, theta_start: float = math.pi / 3, theta_end: float = math.pi / 2,
                        acceleration: float = 2.0, speed: float = 0.5, E: float = ALUMINIUM["E"], nu: float = ALUMINIUM["nu"],
                        rho: float = ALUMINIUM["rho"], p: float = 3.0, x_min: float = 0.01, t_end: float = 1.3,
                        h: float = 0.013, rho_inf: float = 0.8, rings: str = "rigid", cell: str = "enhanced",
                        void: str = "linear_energy", solid_radius: float | None = 0.05) -> Scene:
    """The robot arm of :func:`robot_arm` with continuum links: each link a ``length ×
    height`` member of ``nx × ny`` cells of kind ``cell`` (:meth:`Scene.member`) and
    ``thickness`` (m), a density per cell. The
    shoulder drives a ring (:meth:`Scene.ring`, of kind ``rings``: ``"rigid"`` or
    ``"averaging"``) on link 1's root edge; the elbow drives
    the relative rotation of a ring on link 1's end edge and one on link 2's root edge; the
    payload sits on link 2's end-edge middle node, the ``tip``. The cells the rings hold are
    passive solid (a member's ``solid_at_joints``): those touching a ring and every cell whose
    centre lies within ``solid_radius`` (m) of a ring's node — the default 50 mm is the same
    solid on every mesh where it is a whole number of columns (``nx`` a multiple of 20: 20 × 6
    … 120 × 40 cells), so that those meshes represent one design (with
    ``solid_radius=None``, only the column touching a ring, as wide as the mesh's cells: a
    different design on each mesh). ``void`` is the members' void
    cells' energy (:meth:`Scene.member`). ``ny`` must be even, for a row of nodes on each
    link's axis."""
    if ny % 2:
        raise SceneError(f"continuum_robot_arm: ny must be even, so that a row of nodes lies on each link's axis (got {ny})")
    scene = Scene("continuum_robot_arm")
    links = []
    origin = (0.0, 0.0)
    for k, angle in enumerate((theta_start, 2 * theta_start)):
        links.append(scene.member(f"link{k + 1}", nx=nx, ny=ny, length=length, height=height, thickness=thickness, E=E,
                                  nu=nu, rho=rho, origin=origin, angle=angle, cell=cell, void=void,
                                  solid_radius=solid_radius))
        origin = (origin[0] + length * math.cos(angle), origin[1] + length * math.sin(angle))
    link1, link2 = links
    motion = trapezoidal(theta_start, theta_end, acceleration=acceleration, speed=speed)
    shoulder = scene.ring("shoulder_ring", [link1.node(0, j) for j in range(ny + 1)], kind=rings)
    scene.pin("shoulder", shoulder, drive=motion)
    upper = scene.ring("elbow_ring1", [link1.node(nx, j) for j in range(ny + 1)], kind=rings)
    lower = scene.ring("elbow_ring2", [link2.node(0, j) for j in range(ny + 1)], kind=rings)
    scene.hinge("elbow", upper, lower, drive=dict(motion))
    scene.tip = link2.node(nx, ny // 2)
    if tip_mass != 0.0:
        scene.point_mass(scene.tip, tip_mass)
    scene.design(interpolation="simp", p=p, x_min=x_min)
    # Modified Newton: 1.0–1.3× faster than full with the adjoint at 60 × 20 cells per link
    # on uniform and random designs (up to 2.2× on simplicial factors), the same d
    # (BENCHMARKS.md, "Continuum links").
    scene.simulation(t_end=t_end, h=h, rho_inf=rho_inf, newton="modified")
    return scene


@_checked(lambda nx, ny, split, **_: {"grid_nodes": nx * ny, "split": split})
def static_truss(*, nx: int = 5, ny: int = 3, length: float = 1.0, height: float = 0.1, split: int = 1,
                 force: tuple[float, float] = (0.0, -100.0), E: float = ALUMINIUM["E"], nu: float = ALUMINIUM["nu"],
                 rho: float = ALUMINIUM["rho"], diameter: float = DIAMETER, p: float = 3.0,
                 x_min: float = 0.01, kind: str = "frame") -> Scene:
    """Static truss of paper Section 3.1 (Fig. 4): one linkage, base column's middle node
    clamped, ``force`` (N) on the tip column's middle node. ``kind = "truss"`` makes the same
    ground structure of pin-jointed truss bars; a pin carries no moment, so its base
    column's nodes are each pinned instead of the middle one clamped."""
    if not isinstance(kind, str) or kind not in ("frame", "truss"):
        raise SceneError(f"static_truss: kind must be 'frame' or 'truss', got {kind!r}")
    scene = Scene("static_truss", analysis="static")
    section = _linkage_section(scene, E, nu, rho, diameter)
    truss = scene.ground_structure("truss", nx=nx, ny=ny, length=length, height=height, origin=(0.0, 0.0),
                                   angle=0.0, section=section, split=split, kind=kind)
    if kind == "frame":
        scene.clamp("base", truss.node(0, ny // 2))
    else:
        for j in range(ny):
            scene.pin(f"base{j}", truss.node(0, j))
    scene.load(truss.node(nx - 1, ny // 2), force=force)
    scene.design(interpolation="simp", p=p, x_min=x_min)
    scene.simulation(load_steps=1)
    return scene


@_checked(lambda nx, ny, **_: {"elements": nx * ny}, e_min=(0.0, 1.0, "[)"))
def half_mbb(*, nx: int = 60, ny: int = 20, length: float = 0.6, height: float = 0.2, thickness: float = 0.01,
             force: float = 1e3, E: float = STEEL["E"], nu: float = STEEL["nu"], rho: float = STEEL["rho"], p: float = 3.0,
             x_min: float = 1e-3, e_min: float = 1e-9, analysis: str = "nonlinear") -> Scene:
    """The 88-line code's half-MBB beam (Andreassen et al. 2011): the right half of a
    simply supported beam loaded at mid-span, a ``length × height`` steel member (m) of
    ``nx × ny`` cells and ``thickness``, rollers along its left edge (the symmetry line,
    free to move vertically) and at its bottom-right corner (free to move horizontally),
    ``force`` (N) down at the top-left corner. Every cell is designed
    (``solid_at_joints=False``), SIMP with the void's stiffness ``e_min`` (the code's 1e-9),
    on the code's own element (``cell="plain"``).

    In steel and newtons, not the code's own units (E = 1, a unit load): the member is
    geometrically nonlinear, and a unit load on E = 1 is no small deformation. At the
    defaults the solid beam's strains stay below 1e-4, where the compliance is the linear
    one to well under 1 %; the design the optimality criteria find is the code's, the
    compliance scaled by E and the load squared. ``analysis="linear"`` solves the code's own
    small-displacement problem ``K₀ u = f`` (:func:`half_mbb_unit`, in its units)."""
    if analysis not in ("nonlinear", "linear"):
        raise SceneError(f"half_mbb: analysis must be 'nonlinear' or 'linear', got {analysis!r}")
    scene = Scene("half_mbb", analysis="static")
    member = scene.member("beam", nx=nx, ny=ny, length=length, height=height, thickness=thickness, E=E, nu=nu, rho=rho,
                          solid_at_joints=False, cell="plain")
    for j in range(ny + 1):
        scene.roller(f"symmetry{j}", member.node(0, j), axis=(0.0, 1.0))
    scene.roller("support", member.node(nx, 0), axis=(1.0, 0.0))
    scene.load(member.node(0, ny), force=(0.0, -force))
    scene.design(interpolation="simp", p=p, x_min=x_min, e_min=e_min)
    if analysis == "linear":
        scene.simulation(analysis="linear")
    else:
        scene.simulation(load_steps=1)
    return scene


@_checked(lambda nx, ny, **_: {"elements": nx * ny}, e_min=(0.0, 1.0, "[)"), x_min=(0.0, 1.0, "()"))
def half_mbb_unit(*, nx: int = 60, ny: int = 20, force: float = 1.0, nu: float = 0.3, p: float = 3.0, x_min: float = 1e-9,
                  e_min: float = 1e-9) -> Scene:
    """The 88-line code's half-MBB in the code's own units and analysis: ``nx × ny`` unit
    square cells of unit thickness, E = 1, ``nu``, a ``force`` of 1 (so that the compliance
    is the code's ``c``), the densities from ``x_min`` (the code's 0, as near as a lower
    bound goes) with the void's stiffness ``e_min`` (the code's ``Emin``), and the linear
    analysis: ``K₀ u = f``, the code's own problem, which the geometrically nonlinear
    analysis cannot solve at this load on this stiffness (a unit load on E = 1 bends the
    beam by a multiple of its size)."""
    scene = half_mbb(nx=nx, ny=ny, length=float(nx), height=float(ny), thickness=1.0, force=force, E=1.0, nu=nu, rho=1.0, p=p,
                     x_min=x_min, e_min=e_min, analysis="linear")
    return scene


@_checked(lambda nx, ny, **_: {"elements": nx * ny}, e_min=(0.0, 1.0, "[)"))
def continuum_cantilever(*, nx: int = 40, ny: int = 20, length: float = 0.4, height: float = 0.2, thickness: float = 0.01,
                         force: float = 1e3, E: float = STEEL["E"], nu: float = STEEL["nu"], rho: float = STEEL["rho"],
                         p: float = 3.0, x_min: float = 1e-3, e_min: float = 1e-9) -> Scene:
    """The classic cantilever of topology optimization: a ``length × height`` steel member
    (m) of ``nx × ny`` cells and ``thickness``, every node of its left edge pinned to the
    wall, ``force`` (N) down at the middle of its right edge. Every cell is designed, SIMP
    with the void's stiffness ``e_min``, on the 88-line code's element (``cell="plain"``);
    steel and newtons for small strains, as in
    :func:`half_mbb`. ``ny`` must be even, so that a node sits at the right edge's middle."""
    if ny % 2:
        raise SceneError(f"continuum_cantilever: ny must be even, so that a node sits at the right edge's middle (got {ny})")
    scene = Scene("continuum_cantilever", analysis="static")
    member = scene.member("plate", nx=nx, ny=ny, length=length, height=height, thickness=thickness, E=E, nu=nu, rho=rho,
                          solid_at_joints=False, cell="plain")
    for j in range(ny + 1):
        scene.pin(f"wall{j}", member.node(0, j))
    scene.load(member.node(nx, ny // 2), force=(0.0, -force))
    scene.design(interpolation="simp", p=p, x_min=x_min, e_min=e_min)
    scene.simulation(load_steps=1)
    return scene


_GENERATED = "Generated from flextop.scenes.{}() by `python scripts/write_examples.py`:\nedit that, not this file."

#: The example files: name → (builder, header, comments on table headers). Two Rust unit
#: tests of src/scene/tests.rs add an unknown key to the robot arm's text (after
#: ``speed = 0.5 }`` and ``nx = 5``): a change of its layout must keep those two strings.
@_checked(lambda bars, split, **_: {"nodes": bars + 1, "elements": bars * split, "split": split})
def spun_beam(*, bars: int = 8, length: float = 1.0, split: int = 1, tip_mass: float = 0.2, E: float = ALUMINIUM["E"],
              nu: float = ALUMINIUM["nu"], rho: float = ALUMINIUM["rho"], diameter: float = DIAMETER, angle: float = 1.0,
              acceleration: float = 20.0, speed: float = 2.0, t_end: float = 0.6, h: float = 0.005, rho_inf: float = 0.8) -> Scene:
    """A flexible beam spun up by a driven hub: ``bars`` aluminium bars in a row (one design
    variable each) from a hub pinned at the origin to a ``tip_mass`` (kg); the hub turns
    0 → ``angle`` rad on a trapezoidal law (rad/s², rad/s). Not from the paper: the second
    scene of the work–precision studies, with a different spectrum from the arm's."""
    scene = Scene("spun_beam")
    section = _linkage_section(scene, E, nu, rho, diameter)
    names = [scene.node(f"n{k}", k * length / bars, 0.0) for k in range(bars + 1)]
    for k in range(bars):
        scene.beam(names[k], names[k + 1], section=section, split=split, name=f"bar{k}")
    scene.point_mass(names[-1], tip_mass)
    scene.pin("hub", names[0], drive=trapezoidal(0.0, angle, acceleration=acceleration, speed=speed))
    scene.tip = names[-1]
    scene.simulation(t_end=t_end, h=h, rho_inf=rho_inf)
    return scene


@_checked(lambda columns, **_: {"nodes": 2 * columns + 2})
def stayed_frame(*, columns: int = 25, spacing: float = 0.04, tip_mass: float = 1.0, diameter: float = DIAMETER,
                 E: float = ALUMINIUM["E"], nu: float = ALUMINIUM["nu"], rho: float = ALUMINIUM["rho"],
                 acceleration: float = 20.0, speed: float = 2.0, t_end: float = 0.6, h: float = 0.005,
                 rho_inf: float = 0.8) -> Scene:
    """A frame of short bars — two rows of ``columns + 1`` nodes ``spacing`` apart (m),
    chords ``bottomK``/``topK`` and posts ``postK`` — pinned and spun up by its first bottom
    node as the spun beam is (0 → 1 rad), a ``tip_mass`` (kg) on its last bottom node, and
    one long ``stay`` from the pinned node to the last top node. Not from the paper: with
    the stay thin and the short bars solid, the one bar whose own modes fall in the band is
    the stay, the case for refining bar by bar (``tests/python/test_refinement.py``)."""
    scene = Scene("stayed_frame")
    section = _linkage_section(scene, E, nu, rho, diameter)
    for k in range(columns + 1):
        scene.node(f"b{k}", spacing * k, 0.0)
        scene.node(f"t{k}", spacing * k, spacing)
    for k in range(columns):
        scene.beam(f"b{k}", f"b{k + 1}", section=section, name=f"bottom{k}")
        scene.beam(f"t{k}", f"t{k + 1}", section=section, name=f"top{k}")
    for k in range(columns + 1):
        scene.beam(f"b{k}", f"t{k}", section=section, name=f"post{k}")
    scene.beam("b0", f"t{columns}", section=section, name="stay")
    if tip_mass != 0.0:
        scene.point_mass(f"b{columns}", tip_mass)
    scene.pin("hub", "b0", drive=trapezoidal(0.0, 1.0, acceleration=acceleration, speed=speed))
    scene.tip = f"b{columns}"
    scene.design(interpolation="simp", p=3.0)
    scene.simulation(t_end=t_end, h=h, rho_inf=rho_inf)
    return scene


INCH, KIP, KSI = 0.0254, 4448.2216152605, 6.894757293168e6
"""US customary units in SI (m, N, Pa), for the literature's ten-bar truss."""


@_checked(lambda **_: {})
def ten_bar_truss(*, bay: float = 360 * INCH, load: float = 100 * KIP, E: float = 1e4 * KSI, area: float = 10 * INCH**2,
                  x_min: float = 0.01) -> Scene:
    """The ten-bar truss of the structural optimization literature (Venkayya 1971; Schmit
    and Farshi 1974; Haftka and Gürdal, *Elements of Structural Optimization*, 1992): two
    ``bay``-square bays cantilevered from pinned supports, ``load`` down at the two lower free
    joints. Members are bars hinged at every joint (a truss: no moment at their ends),
    each its own component ``m1``…``m10`` in the literature's numbering, of area ``x · area``
    (linear stiffness law, so ``x`` is the area fraction; ``x_min · area`` the minimum
    gauge). Static, without gravity. SI units; the literature's are inches, kips, ksi."""
    scene = Scene("ten_bar_truss", analysis="static")
    scene.section("member", E=E, nu=0.3, rho=2768.0, A=area, I=area**2 / (4 * math.pi), kappa=0.9,
                  c=math.sqrt(area / math.pi))
    joints = {1: (2, 1), 2: (2, 0), 3: (1, 1), 4: (1, 0), 5: (0, 1), 6: (0, 0)}
    members = [(5, 3), (3, 1), (6, 4), (4, 2), (3, 4), (1, 2), (5, 4), (6, 3), (3, 2), (4, 1)]
    first: dict[int, str] = {}
    for k, (a, b) in enumerate(members, start=1):
        ends = []
        for j in (a, b):
            name = scene.node(f"m{k}@{j}", joints[j][0] * bay, joints[j][1] * bay)
            if j in first:
                scene.hinge(f"joint{j}/m{k}", first[j], name)
            else:
                first[j] = name
            ends.append(name)
        scene.beam(*ends, section="member", name=f"m{k}", component=f"m{k}")
    for j in (5, 6):
        scene.pin(f"support{j}", first[j])
    for j in (2, 4):
        scene.load(first[j], force=(0.0, -load))
    scene.design(interpolation="simp", p=1.0, x_min=x_min)
    return scene



@_checked(lambda **_: {}, angle=(0.0, math.pi, "[)"))
def pendulum(*, length: float = 1.0, mass: float = 1.0, g: float = 9.81, angle: float = math.pi / 2,
             periods: float = 1.0, h: float = 1e-3, rho_inf: float = 0.9) -> Scene:
    """A point ``mass`` (kg) on a rigid massless link of ``length`` (m), pinned at the
    origin and released from rest at ``angle`` from the downward vertical under gravity
    ``g``: a rigid body with no rotary inertia about its centre, pinned at its point
    ``bob.pivot``. Runs ``periods`` of the exact period ``4 K(sin(angle/2)) / √(g/L)``."""
    scene = Scene("pendulum", gravity=(0.0, -g))
    x, y = length * math.sin(angle), -length * math.cos(angle)
    scene.rigid_body("bob", mass=mass, position=(x, y), points={"pivot": (-x, -y)})
    scene.pin("pivot", "bob.pivot")
    scene.simulation(t_end=periods * pendulum_period(length, g, angle), h=h, rho_inf=rho_inf)
    return scene


def pendulum_period(length: float, g: float, angle: float) -> float:
    """The exact period (s) of a pendulum of ``length`` released at rest from ``angle``."""
    from scipy.special import ellipk

    return 4.0 * float(ellipk(math.sin(angle / 2) ** 2)) / math.sqrt(g / length)


def _crank_drive(speed: float, time_constant: float, t_end: float) -> dict:
    """The slider-cranks' drive: from rest to ``speed`` rad/s as ``ω(t) = speed (1 −
    exp(−t/time_constant))``, a cubic spline through samples of its angle up to ``t_end``."""
    t = [k * t_end / 200 for k in range(202)]
    angle = [speed * (ti + time_constant * (math.exp(-ti / time_constant) - 1.0)) for ti in t]
    return motion_table(t, angle, end_velocity=speed * (1.0 - math.exp(-t[-1] / time_constant)))


@_checked(lambda bars, split, **_: {"nodes": bars + 1, "elements": bars * split, "split": split})
def slider_crank(*, crank: float = 0.15, rod: float = 0.30, bars: int = 4, split: int = 2, diameter: float = 0.006,
                 E: float = STEEL["E"], nu: float = STEEL["nu"], rho: float = STEEL["rho"], speed: float = 150.0,
                 time_constant: float = 0.167, t_end: float = 0.1, h: float = 2.5e-4, rho_inf: float = 0.8,
                 p: float = 3.0, x_min: float = 0.01) -> Scene:
    """The flexible slider-crank of Song & Haug (1980) and Jonker (1989): a rigid ``crank``
    (m) driven from rest to ``speed`` rad/s as ``ω(t) = speed (1 − exp(−t/time_constant))``
    (a cubic spline through samples of its angle), a flexible steel connecting ``rod`` (m,
    solid circle of ``diameter``) of ``bars`` bars in a row (one design variable each, split
    into ``split`` elements), and a slider of half the rod's mass on a horizontal axis.
    The crank is a uniform bar of the rod's section; it starts along the axis (θ = 0). The
    ``tip`` is the rod's middle node: its deflection is the rod's mid-span deflection."""
    if bars % 2:
        raise SceneError(f"slider_crank: bars must be even, so that a node sits at the rod's middle (got {bars})")
    scene = Scene("slider_crank")
    section = scene.section("steel", E=E, nu=nu, rho=rho, diameter=diameter)
    area = math.pi * diameter**2 / 4
    m_crank, m_rod = rho * area * crank, rho * area * rod
    scene.rigid_body("crank", mass=m_crank, inertia=m_crank * crank**2 / 12, position=(crank / 2, 0.0),
                     points={"pivot": (-crank / 2, 0.0), "pin": (crank / 2, 0.0)})
    nodes = [scene.node(f"rod{k}", crank + k * rod / bars, 0.0) for k in range(bars + 1)]
    for k in range(bars):
        scene.beam(nodes[k], nodes[k + 1], section=section, split=split, name=f"rod/bar{k}", component="rod")
    scene.rigid_body("slider", mass=m_rod / 2, position=(crank + rod, 0.0))
    scene.pin("crank", "crank.pivot", drive=_crank_drive(speed, time_constant, t_end))
    scene.hinge("A", "crank.pin", nodes[0])
    scene.hinge("B", nodes[-1], "slider")
    scene.prismatic("slide", "slider", axis=(1.0, 0.0))
    scene.tip = nodes[bars // 2]
    scene.design(interpolation="simp", p=p, x_min=x_min)
    scene.simulation(t_end=t_end, h=h, rho_inf=rho_inf)
    return scene


@_checked(lambda nx, ny, **_: {"elements": nx * ny})
def continuum_slider_crank(*, crank: float = 0.15, rod: float = 0.30, height: float = 0.01, thickness: float = 0.005,
                           nx: int = 30, ny: int = 2, E: float = STEEL["E"], nu: float = STEEL["nu"],
                           rho: float = STEEL["rho"], speed: float = 150.0, time_constant: float = 0.167,
                           t_end: float = 0.1, h: float = 2.5e-4, rho_inf: float = 0.8, p: float = 3.0,
                           x_min: float = 0.01, cell: str = "enhanced") -> Scene:
    """The slider-crank of :func:`slider_crank` with a continuum connecting rod: a ``rod ×
    height`` steel member of ``thickness`` meshed by ``nx × ny`` cells of kind ``cell``
    (:meth:`Scene.member`; a density each),
    joined to the crank and the slider through rigid rings (:meth:`Scene.ring`) on its end
    edges. Crank, drive and slider as there (the crank a uniform bar of the rod's section, the
    slider half the rod's mass). The ``tip`` is the rod's middle node. ``nx`` and ``ny`` must
    be even."""
    if nx % 2 or ny % 2:
        raise SceneError(f"continuum_slider_crank: nx and ny must be even, so that a node sits at the rod's middle (got {nx} × {ny})")
    scene = Scene("continuum_slider_crank")
    area = height * thickness
    m_crank, m_rod = rho * area * crank, rho * area * rod
    scene.rigid_body("crank", mass=m_crank, inertia=m_crank * crank**2 / 12, position=(crank / 2, 0.0),
                     points={"pivot": (-crank / 2, 0.0), "pin": (crank / 2, 0.0)})
    member = scene.member("rod", nx=nx, ny=ny, length=rod, height=height, thickness=thickness, E=E, nu=nu, rho=rho,
                          origin=(crank, 0.0), cell=cell)
    left = scene.ring("ring_A", [member.node(0, j) for j in range(ny + 1)])
    right = scene.ring("ring_B", [member.node(nx, j) for j in range(ny + 1)])
    scene.rigid_body("slider", mass=m_rod / 2, position=(crank + rod, 0.0))
    scene.pin("crank", "crank.pivot", drive=_crank_drive(speed, time_constant, t_end))
    scene.hinge("A", "crank.pin", left)
    scene.hinge("B", right, "slider")
    scene.prismatic("slide", "slider", axis=(1.0, 0.0))
    scene.tip = member.node(nx // 2, ny // 2)
    scene.design(interpolation="simp", p=p, x_min=x_min)
    scene.simulation(t_end=t_end, h=h, rho_inf=rho_inf, newton="modified")
    return scene


@_checked(lambda nx, split, **_: {"grid_nodes": 3 * nx, "split": split})
def four_bar(*, crank: float = 0.1, coupler: float = 0.3, rocker: float = 0.25, ground: float = 0.3, nx: int = 5,
             height: float = 0.04, split: int = 1, mass: float = 0.5, E: float = ALUMINIUM["E"],
             nu: float = ALUMINIUM["nu"], rho: float = ALUMINIUM["rho"], diameter: float = 0.01,
             turn: float = math.pi, acceleration: float = 100.0, speed: float = 10.0, t_end: float = 0.5,
             h: float = 2e-3, rho_inf: float = 0.8, p: float = 3.0, x_min: float = 0.01) -> Scene:
    """A crank-rocker four-bar with a flexible coupler: a rigid ``crank`` pinned at the
    origin and driven through ``turn`` rad (trapezoidal law), a ground structure of
    ``nx × 3`` nodes along the ``coupler`` (one design variable per bar), a rigid ``rocker``
    pinned at (``ground``, 0). Crank and rocker are uniform bars of ``mass`` kg each. The
    crank starts upright; the coupler's middle node is the ``tip`` (``nx`` odd)."""
    if nx % 2 == 0:
        raise SceneError(f"four_bar: nx must be odd, so that a node sits at the coupler's middle (got {nx})")
    b = (0.0, crank)
    dx, dy = ground - b[0], -b[1]
    dist = math.hypot(dx, dy)
    if not abs(coupler - rocker) < dist < coupler + rocker:
        raise SceneError("four_bar: the coupler and rocker cannot close the loop with the crank upright")
    along = (coupler**2 - rocker**2 + dist**2) / (2 * dist)
    up = math.sqrt(coupler**2 - along**2)
    c = (b[0] + (along * dx - up * dy) / dist, b[1] + (along * dy + up * dx) / dist)
    scene = Scene("four_bar")
    section = scene.section("aluminium", E=E, nu=nu, rho=rho, diameter=diameter)
    scene.rigid_body("crank", mass=mass, inertia=mass * crank**2 / 12, position=(b[0] / 2, b[1] / 2),
                     points={"pivot": (-b[0] / 2, -b[1] / 2), "pin": (b[0] / 2, b[1] / 2)})
    link = scene.ground_structure("coupler", nx=nx, ny=3, length=coupler, height=height, origin=b,
                                  angle=math.atan2(c[1] - b[1], c[0] - b[0]), section=section, split=split)
    mid = ((c[0] + ground) / 2, c[1] / 2)
    scene.rigid_body("rocker", mass=mass, inertia=mass * rocker**2 / 12, position=mid,
                     points={"pivot": (ground - mid[0], -mid[1]), "pin": (c[0] - mid[0], c[1] - mid[1])})
    scene.pin("crank", "crank.pivot", drive=trapezoidal(0.0, turn, acceleration=acceleration, speed=speed))
    scene.hinge("B", "crank.pin", link.node(0, 1))
    scene.hinge("C", link.node(nx - 1, 1), "rocker.pin")
    scene.pin("D", "rocker.pivot")
    scene.tip = link.node(nx // 2, 1)
    scene.design(interpolation="simp", p=p, x_min=x_min)
    scene.simulation(t_end=t_end, h=h, rho_inf=rho_inf)
    return scene


BUILT_IN = {"robot_arm": robot_arm, "static_truss": static_truss, "spun_beam": spun_beam, "ten_bar_truss": ten_bar_truss,
            "pendulum": pendulum, "slider_crank": slider_crank, "four_bar": four_bar,
            "continuum_robot_arm": continuum_robot_arm, "continuum_slider_crank": continuum_slider_crank,
            "half_mbb": half_mbb, "continuum_cantilever": continuum_cantilever}
"""The scenes the command line knows by name."""


EXAMPLES = {
    "robot_arm.toml": (
        robot_arm,
        "Two-link robot arm of Brüls, Lemaire, Duysinx & Eberhard, Section 4, with the fixed\n"
        "dimensions of docs/reference-scenes.md. SI units (m, kg, s, N, Pa, rad).\n" + _GENERATED.format("robot_arm"),
        {
            "sections.aluminium": "solid circle d = 20 mm; G from nu, Cowper's kappa",
            "ground_structures[0]": "link 1: local frame at the origin, axis at theta1(0) = pi/3",
            "ground_structures[1]": "link 2: origin at link 1's node (L, 0), axis at theta1 + theta2",
            "point_masses[0]": "5 kg at the tip, no rotary inertia",
            "joints[0]": "shoulder: pinned to the ground, drives theta1(t) - theta1(0)",
            "joints[1]": "elbow: two coincident nodes, drives theta2(t) - theta2(0)",
        },
    ),
    "static_truss.toml": (
        static_truss,
        "Static truss of Brüls et al., Section 3.1 (Fig. 4), with the fixed dimensions of\n"
        "docs/reference-scenes.md. SI units.\n" + _GENERATED.format("static_truss"),
        {
            "joints[0]": "base column's middle node clamped",
            "loads[0]": "tip load F = (0, -100) N on the tip column's middle node",
        },
    ),
    "pendulum.toml": (
        pendulum,
        "A point mass on a rigid massless link, released horizontally under gravity: one\n"
        "period of the exact elliptic-integral solution. SI units.\n" + _GENERATED.format("pendulum"),
        {
            "rigid_bodies[0]": "the bob: 1 kg, no rotary inertia, its point 'pivot' 1 m away",
            "joints[0]": "the pivot pinned to the ground, free to turn",
        },
    ),
    "slider_crank.toml": (
        slider_crank,
        "Flexible slider-crank of Song & Haug (1980) and Jonker (1989): rigid crank 0.15 m\n"
        "spun up to 150 rad/s, flexible steel rod 0.30 m (d = 6 mm), slider of half the rod's\n"
        "mass. SI units.\n" + _GENERATED.format("slider_crank"),
        {
            "rigid_bodies[0]": "crank: a uniform bar of the rod's section, points at its ends",
            "rigid_bodies[1]": "slider: half the rod's mass",
            "joints[0]": "crank pinned at the origin, angle 150 (t + 0.167 (exp(-t/0.167) - 1)) rad",
            "joints[3]": "slider on a horizontal axis fixed on the ground",
        },
    ),
    "four_bar.toml": (
        four_bar,
        "Crank-rocker four-bar with a flexible coupler (a ground structure to design) between\n"
        "a rigid crank and a rigid rocker. SI units.\n" + _GENERATED.format("four_bar"),
        {
            "joints[0]": "crank pinned at the origin and driven half a turn",
            "joints[3]": "rocker pinned to the ground",
        },
    ),
    "half_mbb.toml": (
        half_mbb,
        "The 88-line code's half-MBB beam (Andreassen et al. 2011) in steel: 60 x 20 cells,\n"
        "every one designed. SI units; small strains, as a linear analysis would assume.\n"
        "  flextop optimize examples/half_mbb.toml --global-volume --volume-fraction 0.5 --filter-cells 2.4 --method oc --xtol 0.01\n"
        + _GENERATED.format("half_mbb"),
        {
            "members[0]": "the right half of the beam, 0.6 m x 0.2 m, 10 mm thick",
            "joints[0]": "rollers along the symmetry line (the left edge): free to move vertically",
            "joints[21]": "roller at the bottom-right corner: free to move horizontally",
            "loads[0]": "1 kN down at the top-left corner (half the mid-span load)",
        },
    ),
    "half_mbb_unit.toml": (
        half_mbb_unit,
        "The 88-line code's half-MBB beam (Andreassen et al. 2011) in the code's own units and\n"
        "analysis: 60 x 20 unit cells of unit thickness, E = 1, nu = 0.3, a unit load, the linear\n"
        "analysis K0 u = f (the nonlinear one cannot carry a unit load on E = 1). The compliance\n"
        "is the code's c: 1007.02 at x = 0.5, 233.71 optimized with its density filter.\n"
        "  flextop optimize examples/half_mbb_unit.toml --global-volume --volume-fraction 0.5 --x0 0.5 --filter-cells 2.4 --method oc --xtol 0.01 --max-iter 200\n"
        + _GENERATED.format("half_mbb_unit"),
        {
            "members[0]": "the right half of the beam, 60 x 20 unit cells, unit thickness, E = 1",
            "joints[0]": "rollers along the symmetry line (the left edge): free to move vertically",
            "joints[21]": "roller at the bottom-right corner: free to move horizontally",
            "loads[0]": "a unit load down at the top-left corner",
        },
    ),
    "continuum_cantilever.toml": (
        continuum_cantilever,
        "A cantilever plate: 40 x 20 steel cells pinned along the left edge, loaded at the\n"
        "right edge's middle. SI units.\n"
        "  flextop optimize examples/continuum_cantilever.toml --global-volume --volume-fraction 0.4 --filter-cells 1.5\n"
        + _GENERATED.format("continuum_cantilever"),
        {
            "members[0]": "0.4 m x 0.2 m, 10 mm thick, every cell designed",
            "joints[0]": "the left edge's nodes pinned to the wall",
            "loads[0]": "1 kN down at the middle of the right edge",
        },
    ),
    "continuum_slider_crank.toml": (
        continuum_slider_crank,
        "The flexible slider-crank with a continuum connecting rod (30 x 2 cells) joined to the\n"
        "crank and the slider through rigid interface rings on its end edges. SI units.\n"
        + _GENERATED.format("continuum_slider_crank"),
        {
            "members[0]": "the rod: 0.30 m x 10 mm of steel, 5 mm thick, a density per cell",
            "rings[0]": "rigid ring on the rod's left edge: where the crank's pin attaches",
            "rings[1]": "rigid ring on the rod's right edge: where the slider attaches",
        },
    ),
    "heavy_top.toml": (
        heavy_top,
        "The heavy symmetric top of Bruls, Cardona & Arnold (2012): a spatial scene (dimension 3),\n"
        "run by flextop.SpatialSimulation. SI units.\n" + _GENERATED.format("heavy_top"),
        {
            "rigid_bodies[0]": "centre of mass 1 m from the pivot along its symmetry axis y; spun at 150 rad/s",
            "joints[0]": "ball joint at the body's tip, the ground where it is",
        },
    ),
    "spatial_slider_crank.toml": (
        spatial_slider_crank,
        "A slider-crank in space: the crank turns about an axis tilted 30 degrees from z, the rod\n"
        "moves through space on a ball joint and a Cardan joint. SI units.\n" + _GENERATED.format("spatial_slider_crank"),
        {
            "joints[0]": "crank: revolute about the tilted axis, driven one turn",
            "joints[2]": "Cardan joint: about y on the rod, about z on the slider",
            "joints[3]": "the slider along x, from a point of the ground",
        },
    ),
    "spatial_robot_arm.toml": (
        spatial_robot_arm,
        "A robot arm in space: a base turning about z, a shoulder and an elbow pitching, two lattice\n"
        "links of 5 x 2 x 2 nodes (188 aluminium tubes, a density each) welded to the joints' hubs,\n"
        "a 2 kg payload. SI units.\n" + _GENERATED.format("spatial_robot_arm"),
        {
            "ground_structures[0]": "the upper arm: 0.6 m, edges, face and body diagonals",
            "ground_structures[1]": "the forearm: 0.5 m",
            "joints[0]": "the base turns 1 rad about the vertical",
        },
    ),
    "spatial_paper_arm.toml": (
        spatial_paper_arm,
        "The paper's two-link arm as 3D lattices of 5 x 3 x 2 nodes (746 solid aluminium bars, a\n"
        "density each) in the horizontal plane, its 5 kg payload 5 cm out of the links' mid-plane.\n"
        "SI units.\n" + _GENERATED.format("spatial_paper_arm"),
        {
            "ground_structures[0]": "link 1: 1 m by 0.1 m by 0.1 m deep, every bar no third node lies on",
            "joints[6]": "the shoulder: theta1 from pi/3 to pi/2 on a trapezoidal law",
        },
    ),
}


def example_toml(name: str) -> str:
    """Text of the example file ``name`` (a key of :data:`EXAMPLES`): its builder's scene at
    the defaults, as TOML."""
    builder, header, comments = EXAMPLES[name]
    return builder().to_toml(header=header, comments=comments)
