"""The paper's two examples with the fixed dimensions of the project's reference scenes
(``docs/reference-scenes.md``), every number a parameter.

These builders are the one definition of the reference scenes: ``examples/robot_arm.toml``
and ``examples/static_truss.toml`` are their output at the defaults (:func:`example_toml`),
written by ``python scripts/write_examples.py``; a test checks the committed files are
up to date."""

from __future__ import annotations

import math

from .errors import SceneError
from .scene import Scene, trapezoidal

#: Aluminium (Pa, -, kg/m³) and the solid circular section diameter (m).
ALUMINIUM = {"E": 70e9, "nu": 0.32, "rho": 2700.0}
DIAMETER = 0.02


def _linkage_section(scene: Scene, E: float, nu: float, rho: float, diameter: float) -> str:
    return scene.section("aluminium", E=E, nu=nu, rho=rho, diameter=diameter)


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


def static_truss(*, nx: int = 5, ny: int = 3, length: float = 1.0, height: float = 0.1, split: int = 1,
                 force: tuple[float, float] = (0.0, -100.0), E: float = ALUMINIUM["E"], nu: float = ALUMINIUM["nu"],
                 rho: float = ALUMINIUM["rho"], diameter: float = DIAMETER, p: float = 3.0,
                 x_min: float = 0.01) -> Scene:
    """Static truss of paper Section 3.1 (Fig. 4): one linkage, base column's middle node
    clamped, ``force`` (N) on the tip column's middle node."""
    scene = Scene("static_truss", analysis="static")
    section = _linkage_section(scene, E, nu, rho, diameter)
    truss = scene.ground_structure("truss", nx=nx, ny=ny, length=length, height=height, origin=(0.0, 0.0),
                                   angle=0.0, section=section, split=split)
    scene.clamp("base", truss.node(0, ny // 2))
    scene.load(truss.node(nx - 1, ny // 2), force=force)
    scene.design(interpolation="simp", p=p, x_min=x_min)
    scene.simulation(load_steps=1)
    return scene


_GENERATED = "Generated from flextop.scenes.{}() by `python scripts/write_examples.py`:\nedit that, not this file."

#: The example files: name → (builder, header, comments on table headers). Two Rust unit
#: tests of src/scene/tests.rs add an unknown key to the robot arm's text (after
#: ``speed = 0.5 }`` and ``nx = 5``): a change of its layout must keep those two strings.
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


INCH, KIP, KSI = 0.0254, 4448.2216152605, 6.894757293168e6
"""US customary units in SI (m, N, Pa), for the literature's ten-bar truss."""


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


BUILT_IN = {"robot_arm": robot_arm, "static_truss": static_truss, "spun_beam": spun_beam, "ten_bar_truss": ten_bar_truss}
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
}


def example_toml(name: str) -> str:
    """Text of the example file ``name`` (a key of :data:`EXAMPLES`): its builder's scene at
    the defaults, as TOML."""
    builder, header, comments = EXAMPLES[name]
    return builder().to_toml(header=header, comments=comments)
