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
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence


def trapezoidal(start: float, end: float, *, acceleration: float, speed: float, t_start: float = 0.0) -> dict:
    """Point-to-point motion law from ``start`` to ``end`` (rad): constant ``acceleration``
    (rad/s²) up to ``speed`` (rad/s), cruise, then deceleration to rest (triangular when
    the move is too short to reach ``speed``), beginning at ``t_start`` (s)."""
    return {"kind": "trapezoidal", "start": start, "end": end, "acceleration": acceleration, "speed": speed, "t_start": t_start}


def motion_table(t: Sequence[float], theta: Sequence[float], *, start_velocity: float = 0.0, end_velocity: float = 0.0) -> dict:
    """Motion law through samples ``(t, theta)``, joined by a clamped cubic spline so that
    velocity and acceleration are continuous; before and after the table the motion goes on
    with ``start_velocity`` / ``end_velocity`` (rad/s)."""
    return {"kind": "table", "t": list(map(float, t)), "theta": list(map(float, theta)), "start_velocity": start_velocity, "end_velocity": end_velocity}


@dataclass(frozen=True)
class GroundStructure:
    """Handle on a ground structure of a scene: its name and grid size."""

    name: str
    nx: int
    ny: int

    def node(self, column: int, row: int) -> str:
        """Name of grid node (``column``, ``row``), row 0 at the bottom."""
        if not (0 <= column < self.nx and 0 <= row < self.ny):
            raise IndexError(f"{self.name} has {self.nx} × {self.ny} nodes; ({column}, {row}) is outside")
        return f"{self.name}[{column},{row}]"


class Scene:
    """Builder of a scene dict; every method appends one entry and returns a handle."""

    def __init__(self, name: str = "", *, analysis: str = "dynamic", gravity: Sequence[float] | None = None) -> None:
        self._spec: dict[str, Any] = {"name": name, "analysis": analysis}
        if gravity is not None:
            self._spec["gravity"] = [float(g) for g in gravity]

    # -- construction -------------------------------------------------------------------

    def section(self, name: str, *, E: float, rho: float, nu: float | None = None, G: float | None = None,
                diameter: float | None = None, A: float | None = None, I: float | None = None,
                kappa: float | None = None) -> str:
        """A beam section: material (``E``, ``rho``, one of ``nu``/``G``) and either a solid
        circle ``diameter`` (Cowper's shear coefficient) or ``A``, ``I``, ``kappa``."""
        entry = {"E": E, "rho": rho, "nu": nu, "G": G, "diameter": diameter, "A": A, "I": I, "kappa": kappa}
        self._spec.setdefault("sections", {})[name] = {k: v for k, v in entry.items() if v is not None}
        return name

    def node(self, name: str, x: float, y: float) -> str:
        """A free-standing node at ``(x, y)``."""
        self._spec.setdefault("nodes", []).append({"name": name, "x": x, "y": y})
        return name

    def ground_structure(self, name: str, *, nx: int, ny: int, length: float, height: float, section: str,
                         origin: Sequence[float] | str = (0.0, 0.0), angle: float = 0.0, split: int = 1,
                         fixed: bool = False) -> GroundStructure:
        """An ``nx × ny`` ground structure over ``length × height`` in a frame at ``origin``
        (coordinates or a node name) rotated by ``angle``: bars between every pair of grid
        nodes whose segment holds no third node, each split into ``split`` elements, one
        design variable per bar unless ``fixed``."""
        origin = origin if isinstance(origin, str) else [float(o) for o in origin]
        self._spec.setdefault("ground_structures", []).append(
            {"name": name, "nx": nx, "ny": ny, "length": length, "height": height, "origin": origin,
             "angle": angle, "section": section, "split": split, "fixed": fixed})
        return GroundStructure(name, nx, ny)

    def beam(self, a: str, b: str, *, section: str, split: int = 1, name: str | None = None,
             component: str | None = None, group: str | None = None, fixed: bool = False) -> None:
        """A bar from node ``a`` to ``b``; ``group`` shares one design variable between bars,
        ``fixed`` keeps it at full density."""
        entry = {"nodes": [a, b], "section": section, "split": split, "name": name, "component": component,
                 "group": group, "fixed": fixed}
        self._spec.setdefault("beams", []).append({k: v for k, v in entry.items() if v is not None})

    def point_mass(self, node: str, mass: float, inertia: float = 0.0) -> None:
        """A point mass (kg) with rotary inertia (kg m²) on ``node``."""
        self._spec.setdefault("point_masses", []).append({"node": node, "mass": mass, "inertia": inertia})

    def load(self, node: str, *, force: Sequence[float] = (0.0, 0.0), moment: float = 0.0,
             table: tuple[Sequence[float], Sequence[float]] | None = None) -> None:
        """A force (N) and moment (N m) on ``node``, scaled in time by the piecewise-linear
        ``table = (t, scale)`` if given."""
        entry: dict[str, Any] = {"node": node, "force": [float(f) for f in force], "moment": moment}
        if table is not None:
            entry["table"] = {"t": list(map(float, table[0])), "scale": list(map(float, table[1]))}
        self._spec.setdefault("loads", []).append(entry)

    def clamp(self, name: str, node: str) -> None:
        """Fixes ``node`` in position and rotation."""
        self._joint({"kind": "clamp", "name": name, "node": node})

    def pin(self, name: str, node: str, *, drive: dict | None = None) -> None:
        """Pins ``node`` to the ground; ``drive`` (a motion law) prescribes its rotation."""
        self._joint({"kind": "pin", "name": name, "node": node, "drive": drive})

    def hinge(self, name: str, a: str, b: str, *, drive: dict | None = None) -> None:
        """Keeps coincident nodes ``a`` and ``b`` together; ``drive`` prescribes the relative
        rotation ``φ_b − φ_a``."""
        self._joint({"kind": "hinge", "name": name, "nodes": [a, b], "drive": drive})

    def _joint(self, entry: dict) -> None:
        self._spec.setdefault("joints", []).append({k: v for k, v in entry.items() if v is not None})

    def design(self, *, interpolation: str = "simp", p: float | None = None, q: float | None = None,
               x_min: float = 0.01, mass: str | None = None, mass_threshold: float | None = None) -> None:
        """Design parametrization: SIMP exponent ``p`` (default 3) or RAMP parameter ``q``
        (default 8), the lower bound ``x_min`` on densities, and the inertia law ``mass``:
        ``"du_olhoff"`` (default of dynamic scenes: below ``mass_threshold``, 0.1, the mass
        falls like ``x⁶`` so that thin bars have no spurious low modes) or ``"linear"`` (the
        paper's law, valid at one element per bar; default of static scenes)."""
        entry = {"interpolation": interpolation, "p": p, "q": q, "x_min": x_min, "mass": mass,
                 "mass_threshold": mass_threshold}
        self._spec["design"] = {k: v for k, v in entry.items() if v is not None}

    def simulation(self, **defaults: Any) -> None:
        """Default run settings: ``t_end``, ``h``, ``rho_inf``, ``mass``, ``load_steps``."""
        self._spec["simulation"] = dict(defaults)

    @property
    def tip(self) -> str | None:
        """Default node of the tip-deflection response."""
        return self._spec.get("tip")

    @tip.setter
    def tip(self, node: str) -> None:
        self._spec["tip"] = node

    # -- conversion ---------------------------------------------------------------------

    def to_dict(self) -> dict:
        """A deep copy of the scene dict."""
        return copy.deepcopy(self._spec)

    @classmethod
    def from_dict(cls, spec: dict) -> Scene:
        """A scene from a dict (copied)."""
        scene = cls()
        scene._spec = copy.deepcopy(dict(spec))
        return scene

    @classmethod
    def from_toml(cls, path: str | Path) -> Scene:
        """A scene from a TOML file."""
        with open(path, "rb") as f:
            return cls.from_dict(tomllib.load(f))

    def __repr__(self) -> str:
        counts = {k: len(v) for k, v in self._spec.items() if isinstance(v, (list, dict)) and k != "design"}
        return f"Scene({self._spec.get('name', '')!r}, {counts})"
