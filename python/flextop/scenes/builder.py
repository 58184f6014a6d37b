"""Scenes: a mechanism described in Python or loaded from a TOML file.

A scene is plain data — the same keys in a Python dict and in a TOML file (see
``examples/*.toml``). The :class:`Scene` builder fills that dict; the engine validates it
when a :class:`~flextop.Simulation` is made, raising :class:`~flextop.errors.SceneError`
with the path of the culprit (``ground_structures[0] (link1).height``, ``joints[1]``,
unknown keys included). Units are SI: m, kg, s, N, Pa, rad.

Example::

    scene = Scene("pendulum")
    scene.section("al", E=70e9, nu=0.32, rho=2700.0, diameter=0.02)
    scene.node("o", 0.0, 0.0)
    scene.node("tip", 1.0, 0.0)
    scene.beam("o", "tip", section="al", split=4)
    scene.pin("ground", "o", drive=trapezoidal(0.0, 1.0, acceleration=2.0, speed=0.5))
"""

from __future__ import annotations

import copy
import math
import re
import sys
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence, TypeVar

import numpy as np

from ..errors import SceneError, SceneFileError

if sys.version_info >= (3, 11):
    import tomllib
else:  # Python 3.10: the same parser, as the tomli package
    import tomli as tomllib


def _listed(value: Any) -> Any:
    """A sequence (tuple, list, array) as a list, anything else as it is: the engine reads
    the scene with the types given and names an entry of the wrong type."""
    if isinstance(value, (tuple, list)) or hasattr(value, "tolist"):
        return list(value.tolist() if hasattr(value, "tolist") else value)
    return value


def _name(what: str, value: Any) -> str:
    """``value`` if it is a name (non-empty text), or a ``SceneError``."""
    if not isinstance(value, str) or not value:
        raise SceneError(f"{what}: a name must be non-empty text, got {value!r}")
    return value


def _rectangles(path: str, rectangles: Any) -> list[list[int]]:
    """Rectangles of cells ``(i0, j0, i1, j1)`` as the scene holds them: each four whole
    numbers (a float, a string or NaN refused, as in a TOML file), else a ``SceneError``
    naming the entry; whether they fit the member the engine checks."""
    entries = _listed(rectangles)
    if not isinstance(entries, list):
        raise SceneError(f"{path}: expected a list of rectangles [i0, j0, i1, j1], got {rectangles!r}")
    out = []
    for k, entry in enumerate(entries):
        rectangle = _listed(entry)
        if not (isinstance(rectangle, list) and len(rectangle) == 4
                and all(isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_)) for v in rectangle)):
            raise SceneError(f"{path}[{k}]: a rectangle of cells is four whole numbers [i0, j0, i1, j1], got {entry!r}")
        out.append([int(v) for v in rectangle])
    return out


def _scale_table(table: Any) -> dict[str, Any]:
    """A piecewise-linear scale in time given as ``(t, scale)``, as the scene holds it."""
    if not isinstance(table, (tuple, list)) or len(table) != 2:
        raise SceneError(f"table: expected a pair (t, scale) of sequences, got {table!r}")
    return {"t": _listed(table[0]), "scale": _listed(table[1])}


def trapezoidal(start: float, end: float, *, acceleration: float, speed: float, t_start: float = 0.0) -> dict:
    """Point-to-point motion law from ``start`` to ``end`` (rad): constant ``acceleration``
    (rad/s²) up to ``speed`` (rad/s), cruise, then deceleration to rest (triangular when
    the move is too short to reach ``speed``), beginning at ``t_start`` (s; kept in the dict
    only when not 0, its default)."""
    law = {"kind": "trapezoidal", "start": start, "end": end, "acceleration": acceleration, "speed": speed}
    if t_start != 0.0:
        law["t_start"] = t_start
    return law


def motion_table(t: Sequence[float], theta: Sequence[float], *, start_velocity: float = 0.0, end_velocity: float = 0.0) -> dict:
    """Motion law through samples ``(t, theta)``, joined by a clamped cubic spline so that
    velocity and acceleration are continuous; before and after the table the motion goes on
    with ``start_velocity`` / ``end_velocity`` (rad/s)."""
    return {"kind": "table", "t": _listed(t), "theta": _listed(theta), "start_velocity": start_velocity, "end_velocity": end_velocity}


@dataclass(frozen=True)
class GroundStructure:
    """Handle on a ground structure of a scene: its name and grid size."""

    name: str
    nx: int
    ny: int

    def node(self, column: int, row: int) -> str:
        """Name of grid node (``column``, ``row``), row 0 at the bottom."""
        if not (0 <= column < self.nx and 0 <= row < self.ny):
            raise SceneError(f"{self.name} has {self.nx} × {self.ny} nodes; ({column}, {row}) is outside")
        return f"{self.name}[{column},{row}]"


@dataclass(frozen=True)
class Member:
    """Handle on a continuum member of a scene: its name, its cells along and across and its
    holes (rectangles ``(i0, j0, i1, j1)`` of cells left out)."""

    name: str
    nx: int
    ny: int
    holes: tuple[tuple[int, int, int, int], ...] = ()

    def node(self, column: int, row: int) -> str:
        """Name of mesh node (``column``, ``row``), ``0 ≤ column ≤ nx``, row 0 at the bottom;
        a node only cells of holes touch is left out of the mesh, and refused here."""
        if not (0 <= column <= self.nx and 0 <= row <= self.ny):
            raise SceneError(f"{self.name} has {self.nx + 1} × {self.ny + 1} nodes; ({column}, {row}) is outside")
        if not any(self._kept(i, j) for i in (column - 1, column) for j in (row - 1, row)):
            raise SceneError(f"{self.name}: node ({column}, {row}) touches only cells of its holes, and is left out with them")
        return f"{self.name}[{column},{row}]"

    def cell(self, column: int, row: int) -> str:
        """Name of cell (``column``, ``row``): its design variable."""
        if not (0 <= column < self.nx and 0 <= row < self.ny):
            raise SceneError(f"{self.name} has {self.nx} × {self.ny} cells; ({column}, {row}) is outside")
        if not self._kept(column, row):
            raise SceneError(f"{self.name}: cell ({column}, {row}) lies in a hole")
        return f"{self.name}/cell[{column},{row}]"

    def _kept(self, column: int, row: int) -> bool:
        """Whether cell (``column``, ``row``) is in the member and in none of its holes."""
        inside = 0 <= column < self.nx and 0 <= row < self.ny
        return inside and not any(i0 <= column < i1 and j0 <= row < j1 for i0, j0, i1, j1 in self.holes)


_S = TypeVar("_S", bound="SceneDict")


class SceneDict:
    """What the planar and the spatial builders share: the scene dict, its design laws, its
    default tip, and its conversions to and from dicts and TOML."""

    _spec: dict[str, Any]

    def design(self, *, interpolation: str = "simp", p: float | None = None, q: float | None = None,
               x_min: float = 0.01, mass: str | None = None, mass_threshold: float | None = None,
               mass_floor: float | None = None, e_min: float | None = None) -> None:
        """Design parametrization: SIMP exponent ``p`` (default 3) with the stiffness of
        void ``e_min`` = E_min/E in ``E_min + (E − E_min) xᵖ`` (default 0; the 88-line
        code's 1e-9), or RAMP parameter ``q`` (default 8), the lower bound ``x_min`` on
        densities, and the inertia law ``mass``:
        ``"du_olhoff"`` (default of dynamic scenes: below ``mass_threshold``, 0.1, the mass
        falls like ``x⁶`` down to ``mass_floor · x``, 1e-3, so that thin bars have no
        spurious low modes) or ``"linear"`` (the paper's law, valid at one element per bar;
        default of static scenes)."""
        entry = {"interpolation": interpolation, "p": p, "q": q, "x_min": x_min, "mass": mass,
                 "mass_threshold": mass_threshold, "mass_floor": mass_floor, "e_min": e_min}
        self._spec["design"] = {k: v for k, v in entry.items() if v is not None}

    @property
    def tip(self) -> str | None:
        """The node (or body) of the default response: the tip deflection's, or the final
        position's of a spatial scene."""
        return self._spec.get("tip")

    @tip.setter
    def tip(self, name: str) -> None:
        self._spec["tip"] = name

    # -- conversion ---------------------------------------------------------------------

    def to_dict(self) -> dict:
        """A deep copy of the scene dict."""
        return copy.deepcopy(self._spec)

    @classmethod
    def from_dict(cls: type[_S], spec: Mapping[str, Any]) -> _S:
        """A scene from a dict (copied)."""
        scene = cls()
        try:
            scene._spec = copy.deepcopy(dict(spec))
        except RecursionError:
            raise SceneError("scene: nested too deeply to be a scene") from None
        return scene

    @classmethod
    def from_toml(cls: type[_S], path: str | Path) -> _S:
        """A scene from a TOML file (UTF-8, a byte-order mark allowed).

        Raises :class:`~flextop.errors.SceneFileError` naming the file when it cannot be
        read or parsed (with the line and column of a syntax error)."""
        return cls.from_dict(read_toml(path))

    def to_toml(self, *, header: str = "", comments: Mapping[str, str] | None = None) -> str:
        """The scene as TOML text, which :meth:`from_toml` reads back into the same dict
        (``None`` values are left out). ``header`` becomes the opening comment lines;
        ``comments`` maps a table (``"sections.aluminium"``, ``"joints[1]"``) to a comment
        on its header line."""
        lines = [f"# {line}".rstrip() for line in header.splitlines()]
        _toml_table(lines, [], self._spec, comments or {})
        return "\n".join(lines).strip("\n") + "\n"

    def __repr__(self) -> str:
        counts = {k: len(v) for k, v in self._spec.items() if isinstance(v, (list, dict)) and k != "design"}
        return f"{type(self).__name__}({self._spec.get('name', '')!r}, {counts})"


class Scene(SceneDict):
    """Builder of a scene dict; every method appends one entry and returns a handle."""

    def __init__(self, name: str = "", *, analysis: str = "dynamic", gravity: Sequence[float] | None = None,
                 initial: str = "rest") -> None:
        """``initial = "equilibrium"`` starts a dynamic run at rest in the static equilibrium
        under gravity and the loads at t = 0, the drives held; ``"rest"`` undeformed."""
        self._spec: dict[str, Any] = {"name": name, "analysis": analysis}
        if initial != "rest":
            self._spec["initial"] = initial
        if gravity is not None:
            self._spec["gravity"] = _listed(gravity)

    # -- construction -------------------------------------------------------------------

    def section(self, name: str, *, E: float, rho: float, nu: float | None = None, G: float | None = None,
                diameter: float | None = None, A: float | None = None, I: float | None = None,
                kappa: float | None = None, c: float | None = None, shear_factor: float | None = None,
                rayleigh: Sequence[float] | None = None) -> str:
        """A beam section: material (``E``, ``rho``, one of ``nu``/``G``) and either a solid
        circle ``diameter`` (Cowper's shear coefficient) or ``A``, ``I``, ``kappa``, with the
        outer-fibre distance ``c`` if bending stresses ``M c / I`` are wanted (m) and the
        ``shear_factor`` k of the largest shear stress ``k V/A`` if shear stresses are;
        ``rayleigh = (alpha, beta)`` damps its beams by ``C = αM + βK`` (1/s, s)."""
        entry = {"E": E, "rho": rho, "nu": nu, "G": G, "diameter": diameter, "A": A, "I": I, "kappa": kappa, "c": c,
                 "shear_factor": shear_factor, "rayleigh": None if rayleigh is None else _listed(rayleigh)}
        self._spec.setdefault("sections", {})[self._new_key("sections", "section", name)] = {
            k: v for k, v in entry.items() if v is not None}
        return name

    def node(self, name: str, x: float, y: float) -> str:
        """A free-standing node at ``(x, y)``."""
        self._spec.setdefault("nodes", []).append({"name": name, "x": x, "y": y})
        return name

    def ground_structure(self, name: str, *, nx: int, ny: int, length: float, height: float, section: str,
                         origin: Sequence[float] | str = (0.0, 0.0), angle: float = 0.0, split: int = 1,
                         fixed: bool = False, rigid: bool = False, kind: str = "frame") -> GroundStructure:
        """An ``nx × ny`` ground structure over ``length × height`` in a frame at ``origin``
        (coordinates or a node name) rotated by ``angle``: bars between every pair of grid
        nodes whose segment holds no third node, each split into ``split`` elements, one
        design variable per bar unless ``fixed``. ``kind = "truss"`` makes each bar one
        pin-jointed truss bar (axial force only; a node only truss bars meet has no rotation)
        instead of the frame's Timoshenko beams. ``rigid`` makes it one rigid body with the
        frame's mass and inertia (a link not being designed, three unknowns), its grid
        nodes the body's points."""
        origin = _listed(origin)
        entry = {"name": name, "nx": nx, "ny": ny, "length": length, "height": height, "origin": origin,
                 "angle": angle, "section": section, "split": split, "fixed": fixed}
        if rigid:
            entry["rigid"] = True
        if kind != "frame":
            entry["kind"] = kind
        self._spec.setdefault("ground_structures", []).append(entry)
        return GroundStructure(name, nx, ny)

    def member(self, name: str, *, nx: int, ny: int, length: float, height: float, thickness: float, E: float,
               nu: float, rho: float, origin: Sequence[float] | str = (0.0, 0.0), angle: float = 0.0,
               fixed: bool = False, holes: Sequence[Sequence[int]] = (), solid: Sequence[Sequence[int]] = (),
               solid_at_joints: bool = True, solid_radius: float | None = None,
               rayleigh: Sequence[float] | None = None,
               cell: str = "enhanced", void: str = "linear_energy",
               void_threshold: float | None = None, split: int = 1) -> Member:
        """A plane-stress continuum member: the ``length × height`` rectangle (m) in a frame
        at ``origin`` (coordinates or a node name) rotated by ``angle`` (rad), from ``x = 0``
        to ``length`` and centred on the local x axis, meshed by ``nx × ny`` four-node
        quadrilaterals (total Lagrangian, St. Venant–Kirchhoff) of ``thickness`` (m), Young's
        modulus ``E`` (Pa), Poisson's ratio ``nu`` and density ``rho`` (kg/m³); one design
        variable per cell unless ``fixed``. ``holes`` and ``solid`` are rectangles of cells
        ``(i0, j0, i1, j1)``, four whole numbers, half-open: columns ``i0 ≤ i < i1`` and rows
        ``j0 ≤ j < j1`` from the bottom left (``(0, 0, 1, 1)`` is the corner cell alone), left
        out — with the nodes only they touch — or kept at full density and not designed. Its
        nodes have no rotation: joints on them pin. With ``solid_at_joints`` (default) the cells touching a node that a joint or a
        beam attaches to are kept solid too, so that an optimizer cannot detach the joint, and
        with ``solid_radius`` (m) those whose centre lies within that distance of such a node:
        the same region on every mesh, where the cells touching it are one cell wide.
        ``rayleigh = (α, β)`` (1/s, s) damps the cells by ``C = αM + βK``, the stiffness part
        as a Kelvin–Voigt material on the Green–Lagrange strain rate (no damping of a rigid
        motion). ``cell = "enhanced"`` (default) enhances each cell's strain by four
        incompatible modes condensed in the cell (Simo & Rifai): no locking in bending, exact
        in pure bending on rectangular cells; ``cell = "plain"`` is the compatible four-node
        cell, the 88-line code's element (too stiff in bending on coarse meshes).
        ``void = "linear_energy"`` (default) blends each cell's energy between its nonlinear
        and its linear (small-strain) form by its density (Wang, Lazarov & Sigmund 2014:
        ``γ(x)`` a smoothed step at ``void_threshold``, 0.05 if not given, sharpness 500), on
        the cell's co-rotated displacement so that a turning link's void cells store no
        energy, so that void cells cannot turn inside out and stop a run; cells above about
        0.12 are fully nonlinear. ``void = "nonlinear"`` keeps every cell nonlinear.
        ``split`` meshes each cell, one density, by ``split × split`` elements: the cells'
        corners keep their names ``NAME[i,j]``, the nodes between them are named by their
        place in cells (``NAME[7/2,2]``: column 3½, row 2)."""
        entry = {"name": name, "nx": nx, "ny": ny, "length": length, "height": height, "thickness": thickness,
                 "E": E, "nu": nu, "rho": rho, "origin": _listed(origin), "angle": angle, "fixed": fixed}
        path = f"members[{len(self._spec.get('members', []))}] ({name})"
        for key, rectangles in (("holes", holes), ("solid", solid)):
            if listed := _rectangles(f"{path}.{key}", rectangles):
                entry[key] = listed
        if not solid_at_joints:
            entry["solid_at_joints"] = False
        if solid_radius is not None:
            entry["solid_radius"] = solid_radius
        if rayleigh is not None:
            entry["rayleigh"] = _listed(rayleigh)
        if cell != "enhanced":
            entry["cell"] = cell
        if void != "linear_energy":
            entry["void"] = void
        if void_threshold is not None:
            entry["void_threshold"] = void_threshold
        if split != 1:
            entry["split"] = split
        self._spec.setdefault("members", []).append(entry)
        return Member(name, nx, ny, tuple(map(tuple, entry.get("holes", []))))

    def beam(self, a: str, b: str, *, section: str, split: int = 1, name: str | None = None,
             component: str | None = None, group: str | None = None, fixed: bool = False,
             kind: str = "frame") -> None:
        """A bar from node ``a`` to ``b``; ``group`` shares one design variable between bars,
        ``fixed`` keeps it at full density; ``kind = "truss"`` makes it one pin-jointed truss
        bar instead of ``split`` Timoshenko beams."""
        entry = {"nodes": [a, b], "section": section, "split": split, "name": name, "component": component,
                 "group": group, "fixed": fixed, "kind": None if kind == "frame" else kind}
        self._spec.setdefault("beams", []).append({k: v for k, v in entry.items() if v is not None})

    def rigid_body(self, name: str, *, mass: float, position: Sequence[float], inertia: float = 0.0,
                   angle: float = 0.0, points: Mapping[str, Sequence[float]] | None = None) -> str:
        """A planar rigid body of ``mass`` (kg) and rotary ``inertia`` about its centre of
        mass (kg m²) at ``position``, its frame turned by ``angle``; ``points`` are named
        ``[x, y]`` in that frame from the centre. Joints attach to the body (``name``, its
        centre) or its points (``"name.point"``)."""
        entry = {"name": name, "mass": mass, "inertia": inertia, "position": _listed(position),
                 "angle": angle, "points": {k: _listed(p) for k, p in (points or {}).items()} if isinstance(points, Mapping | None) else points}
        self._spec.setdefault("rigid_bodies", []).append(entry)
        return name

    def ring(self, name: str, nodes: Sequence[str], *, centre: Sequence[float] | None = None,
             kind: str = "rigid", weights: Sequence[float] | None = None) -> str:
        """An interface ring on ``nodes`` (two or more: a member's hole, boss or edge) whose
        centre ``name`` is where joints, springs, loads and point masses attach as to a
        rigid body's; a member's cells at its nodes are passive solid by default. Built as
        a light rigid body (1e-6 kg and kg m²): the ring carries the joints, not inertia.

        ``kind="rigid"`` (RBE2-type): the nodes move as one rigid frame centred at
        ``centre`` (the nodes' mean if not given), through hinges ``name.0``, ``name.1``, ….

        ``kind="averaging"`` (RBE3-type): the centre, at the nodes' weighted mean, follows
        their weighted mean displacement and least-squares rotation; the nodes stay free,
        so the ring adds no stiffness. ``weights``: one positive number per node (all
        equal if not given)."""
        entry: dict[str, Any] = {"name": name, "nodes": list(nodes)}
        if centre is not None:
            entry["centre"] = _listed(centre)
        if kind != "rigid":
            entry["kind"] = kind
        if weights is not None:
            entry["weights"] = _listed(weights)
        self._spec.setdefault("rings", []).append(entry)
        return name

    def point_mass(self, node: str, mass: float, inertia: float = 0.0) -> None:
        """A point mass (kg) with rotary inertia (kg m²) on ``node``."""
        self._spec.setdefault("point_masses", []).append({"node": node, "mass": mass, "inertia": inertia})

    def load(self, node: str, *, force: Sequence[float] = (0.0, 0.0), moment: float = 0.0,
             table: tuple[Sequence[float], Sequence[float]] | None = None) -> None:
        """A force (N) and moment (N m) on ``node``, scaled in time by the piecewise-linear
        ``table = (t, scale)`` if given."""
        entry: dict[str, Any] = {"node": node, "force": _listed(force), "moment": moment}
        if table is not None:
            entry["table"] = _scale_table(table)
        self._spec.setdefault("loads", []).append(entry)

    def clamp(self, name: str, node: str) -> None:
        """Fixes ``node`` (or a rigid-body point) in position and rotation."""
        self._joint({"kind": "clamp", "name": name, "node": node})

    def pin(self, name: str, node: str, *, drive: dict | None = None) -> None:
        """Pins ``node`` (or a rigid-body point) to the ground; ``drive`` (a motion law)
        prescribes its rotation."""
        self._joint({"kind": "pin", "name": name, "node": node, "drive": drive})

    def hinge(self, name: str, a: str, b: str, *, drive: dict | None = None) -> None:
        """Keeps coincident ``a`` and ``b`` (nodes or rigid-body points) together; ``drive``
        prescribes the relative rotation ``φ_b − φ_a``."""
        self._joint({"kind": "hinge", "name": name, "nodes": [a, b], "drive": drive})

    def weld(self, name: str, a: str, b: str) -> None:
        """Joins coincident ``a`` and ``b`` (nodes or rigid-body points) rigidly."""
        self._joint({"kind": "weld", "name": name, "nodes": [a, b]})

    def prismatic(self, name: str, slider: str, *, axis: Sequence[float], carrier: str | None = None,
                  drive: dict | None = None) -> None:
        """A slider: ``slider`` (a node or rigid-body point) moves along ``axis`` through its
        position, the axis fixed on the ground or carried by ``carrier``, their relative
        rotation locked; ``drive`` (a motion law, in m) prescribes the travel."""
        entry: dict[str, Any] = {"kind": "prismatic", "name": name, "axis": _listed(axis), "drive": drive}
        if carrier is None:
            entry["node"] = slider
        else:
            entry["nodes"] = [carrier, slider]
        self._joint(entry)

    def roller(self, name: str, node: str, *, axis: Sequence[float], drive: dict | None = None) -> None:
        """A roller support: ``node`` (or a rigid-body point) moves along ``axis`` on the
        ground through its position, its rotation free; ``drive`` (a motion law, in m)
        prescribes the travel."""
        self._joint({"kind": "roller", "name": name, "node": node, "axis": _listed(axis), "drive": drive})

    def spring(self, name: str, a: str, b: str, *, k: float = 0.0, c: float = 0.0, length: float | None = None) -> None:
        """A linear spring of stiffness ``k`` (N/m) and damper ``c`` (N s/m, on the rate of
        the distance) between nodes or rigid-body points ``a`` and ``b``, unloaded at
        ``length`` (m; their distance in the scene if not given)."""
        entry = {"name": name, "nodes": [a, b], "k": k, "c": c or None, "length": length}
        self._spec.setdefault("springs", []).append({key: v for key, v in entry.items() if v is not None})

    def joint_spring(self, name: str, joint: str, *, k: float = 0.0, c: float = 0.0, rest: float = 0.0) -> None:
        """A linear spring and damper on ``joint``'s own coordinate: at a pin or hinge a
        torsion spring ``k`` (N m/rad) and damper ``c`` (N m s/rad), along a slider's travel
        N/m and N s/m (a damper only on a ground axis); the spring unloaded at ``rest`` (rad
        or m from the scene's configuration)."""
        self._spec.setdefault("springs", []).append({"name": name, "joint": joint, "k": k, "c": c, "rest": rest})

    def motor(self, name: str, joint: str, *, torque: float,
              table: tuple[Sequence[float], Sequence[float]] | None = None) -> None:
        """A motor applying ``torque`` (N m; N on a slider) on the undriven ``joint``'s own
        coordinate, scaled in time by the piecewise-linear ``table = (t, scale)`` if given."""
        entry: dict[str, Any] = {"name": name, "joint": joint, "torque": torque}
        if table is not None:
            entry["table"] = _scale_table(table)
        self._spec.setdefault("motors", []).append(entry)

    def servo(self, name: str, joint: str, *, kp: float, kd: float = 0.0, motion: dict) -> None:
        """A PD servo on the undriven ``joint``: ``τ = kp (θ_r − θ) + kd (θ̇_r − θ̇)`` following
        the motion law ``motion`` (from the scene's configuration)."""
        self._spec.setdefault("motors", []).append(
            {"name": name, "joint": joint, "servo": {"kp": kp, "kd": kd, "motion": motion}})

    def split(self, bar: str, elements: int) -> None:
        """Gives the bar called ``bar`` (``LINK/barK`` of a ground structure, a beam's name)
        ``elements`` elements, whatever the ``split`` of its ground structure or beam: a
        discretization chosen bar by bar (the scene's ``[splits]`` table)."""
        self._spec.setdefault("splits", {})[self._new_key("splits", "split", bar)] = elements

    def initial_rate(self, joint: str, rate: float) -> None:
        """Starts the undriven ``joint``'s coordinate moving at ``rate`` (rad/s; m/s on a
        slider): the mechanism starts in the rigid motion its initial rates determine."""
        self._spec.setdefault("initial_rates", {})[self._new_key("initial_rates", "initial_rate", joint)] = rate

    def _new_key(self, table: str, what: str, name: Any) -> str:
        """``name`` as a new key of the scene's ``table``: a second entry of one name would
        replace the first without a word."""
        if _name(what, name) in self._spec.get(table, {}):
            raise SceneError(f"{what} {name!r}: given twice; give each its own name, once")
        return name

    def _joint(self, entry: dict) -> None:
        self._spec.setdefault("joints", []).append({k: v for k, v in entry.items() if v is not None})

    def simulation(self, **defaults: Any) -> None:
        """Default run settings: ``t_end``, ``h``, ``rho_inf``, ``mass``, ``load_steps``, and for a
        static scene ``analysis``, ``"nonlinear"`` (the default) or ``"linear"`` (``K₀ u = f``
        about the reference, the 88-line code's analysis)."""
        self._spec["simulation"] = dict(defaults)

    @property
    def tip(self) -> str | None:
        """Default node of the tip-deflection response."""
        return self._spec.get("tip")

    @tip.setter
    def tip(self, node: str) -> None:
        self._spec["tip"] = node

# -- TOML writing -----------------------------------------------------------------------

_BARE_KEY = re.compile(r"[A-Za-z0-9_-]+")
_ESCAPES = {'"': '\\"', "\\": "\\\\", "\b": "\\b", "\t": "\\t", "\n": "\\n", "\f": "\\f", "\r": "\\r"}
#: Column of the ``#`` of a table header's comment.
_COMMENT_COLUMN = 26


def read_toml(path: str | Path) -> dict:
    """The dict of a TOML file, or a :class:`SceneFileError` that names the file."""
    if not str(path):
        raise SceneFileError("no scene file given (empty path)")
    try:
        text = Path(path).read_bytes().decode("utf-8-sig")
    except UnicodeDecodeError as error:
        raise SceneFileError(f"{path}: not UTF-8 text (byte {error.start})") from None
    except OSError as error:
        raise SceneFileError(f"{path}: cannot read: {error.strerror or error}") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise SceneFileError(f"{path}: not valid TOML: {error}") from None
    except RecursionError:
        raise SceneFileError(f"{path}: nested too deeply to be a scene") from None


def _toml_table(lines: list[str], path: list[str], table: Mapping[str, Any], comments: Mapping[str, str]) -> None:
    """Appends the contents of ``table`` at ``path``: its plain values, then its sub-tables
    ``[a.b]`` and arrays of tables ``[[a.b]]``, whose entries hold their dicts inline."""
    items = {k: v for k, v in table.items() if v is not None}
    nested = {k: v for k, v in items.items() if _is_table(v) or _is_array_of_tables(v)}
    lines.extend(f"{_toml_key(k)} = {_toml_value(v)}" for k, v in items.items() if k not in nested)
    for key, value in nested.items():
        name, header = ".".join([*path, key]), ".".join(_toml_key(k) for k in [*path, key])
        if _is_table(value):
            children = [v for v in value.values() if v is not None]
            if not children or not all(_is_table(v) or _is_array_of_tables(v) for v in children):
                _toml_header(lines, f"[{header}]", comments.get(name))
            _toml_table(lines, [*path, key], value, comments)
        else:
            for i, entry in enumerate(value):
                _toml_header(lines, f"[[{header}]]", comments.get(f"{name}[{i}]"))
                lines.extend(f"{_toml_key(k)} = {_toml_value(v)}" for k, v in entry.items() if v is not None)


def _toml_header(lines: list[str], header: str, comment: str | None) -> None:
    lines.append("")
    lines.append(header if comment is None else f"{header:<{_COMMENT_COLUMN - 1}} # {comment}")


def _is_table(value: Any) -> bool:
    return isinstance(value, Mapping)


def _is_array_of_tables(value: Any) -> bool:
    return isinstance(value, (list, tuple)) and len(value) > 0 and all(isinstance(v, Mapping) for v in value)


def _toml_key(key: str) -> str:
    return key if _BARE_KEY.fullmatch(key) else _toml_string(key)


def _toml_string(text: str) -> str:
    return '"' + "".join(_ESCAPES.get(c, f"\\u{ord(c):04X}" if ord(c) < 0x20 or ord(c) == 0x7F else c)
                         for c in text) + '"'


def _toml_value(value: Any) -> str:
    if hasattr(value, "tolist"):  # numpy scalars and arrays
        value = value.tolist()
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return _toml_float(value)
    if isinstance(value, str):
        return _toml_string(value)
    if isinstance(value, Mapping):
        entries = [f"{_toml_key(k)} = {_toml_value(v)}" for k, v in value.items() if v is not None]
        return "{ " + ", ".join(entries) + " }" if entries else "{}"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    raise TypeError(f"cannot write {type(value).__name__} {value!r} as TOML")


def _toml_float(value: float) -> str:
    """Shortest round-trip form; large whole numbers in engineering notation (``70e9``)."""
    if math.isnan(value):
        return "nan"
    if math.isinf(value):
        return "inf" if value > 0 else "-inf"
    if value.is_integer() and 1e6 <= abs(value) < 1e16:
        mantissa, exponent = int(value), 0
        while mantissa % 1000 == 0:
            mantissa, exponent = mantissa // 1000, exponent + 3
        if exponent:
            return f"{mantissa}e{exponent}"
    return repr(value)
