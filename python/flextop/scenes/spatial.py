"""Spatial scenes: a mechanism in space described in Python or loaded from a TOML file with
``dimension = 3`` (the same keys; see ``examples/spatial_*.toml``).

Anchors name where a joint, spring or load acts: ``"BODY"`` (its centre of mass),
``"BODY.POINT"`` (a named point of the body), ``"NODE"`` (a node's origin), ``"ground"``
(the ground where the other anchor is) or a point of the ground ``[x, y, z]``. Frames are
given by :func:`axis_angle` or a rotation matrix whose columns are the frame's axes. Units
are SI: m, kg, s, N, Pa, rad; vectors in the inertial frame unless said otherwise.

Example (a bar hinged at the origin about y, swinging under gravity)::

    scene = SpatialScene("hinged bar", gravity=(0.0, 0.0, -9.81))
    scene.rigid_body("bar", mass=1.0, inertia=(1e-3, 0.0833, 0.0833), position=(0.5, 0.0, 0.0),
                     points={"pivot": (-0.5, 0.0, 0.0)})
    scene.revolute("hinge", "bar.pivot", axis=(0.0, 1.0, 0.0))
    scene.simulation(t_end=1.0, h=1e-3)
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence, Union

from ..errors import SceneError
from .builder import SceneDict, _listed, _name, _scale_table

Anchor = Union[str, Sequence[float]]
"""Where an entry acts (module docs)."""


def axis_angle(axis: Sequence[float], angle: float) -> dict:
    """A rotation by ``angle`` (rad) about ``axis`` (any length but zero), as a scene holds it."""
    return {"axis": _listed(axis), "angle": angle}


def _orientation(orientation: Any) -> Any:
    """An orientation as the scene holds it: a dict (:func:`axis_angle`, or ``{"matrix": R}``)
    as given, a 3 × 3 sequence or array as a matrix."""
    if orientation is None or isinstance(orientation, Mapping):
        return None if orientation is None else dict(orientation)
    return {"matrix": [_listed(row) for row in _listed(orientation)]}


def _anchor(anchor: Anchor) -> Any:
    return anchor if isinstance(anchor, str) else _listed(anchor)


class SpatialScene(SceneDict):
    """Builder of a spatial scene dict; each method appends one entry and returns its name."""

    def __init__(self, name: str = "", *, analysis: str = "dynamic", gravity: Sequence[float] | None = None) -> None:
        self._spec: dict[str, Any] = {"name": name, "dimension": 3, "analysis": analysis}
        if gravity is not None:
            self._spec["gravity"] = _listed(gravity)

    def section(self, name: str, *, E: float, rho: float, nu: float, shape: str = "circle", diameter: float | None = None,
                outer: float | None = None, inner: float | None = None, width: float | None = None,
                height: float | None = None, rayleigh: Sequence[float] | None = None) -> str:
        """A beam section: material (``E`` in Pa, ``rho`` in kg/m³, Poisson's ``nu``) and shape:
        ``"circle"`` (``diameter``), ``"tube"`` (``outer``, ``inner`` diameters) or
        ``"rectangle"`` (``width`` along the section's e₂, ``height`` along e₃), in m;
        ``rayleigh = (alpha, beta)`` damps its beams by ``C = αM + βK`` (1/s, s)."""
        sections = self._spec.setdefault("sections", {})
        if _name("section", name) in sections:
            raise SceneError(f"section {name!r}: given twice; give each its own name, once")
        entry = {"E": E, "rho": rho, "nu": nu, "shape": shape, "diameter": diameter, "outer": outer, "inner": inner,
                 "width": width, "height": height, "rayleigh": None if rayleigh is None else _listed(rayleigh)}
        sections[name] = {k: v for k, v in entry.items() if v is not None}
        return name

    def rigid_body(self, name: str, *, mass: float, inertia: Sequence[float], position: Sequence[float],
                   products: Sequence[float] | None = None, orientation: Any = None,
                   points: Mapping[str, Sequence[float]] | None = None, velocity: Sequence[float] | None = None,
                   angular_velocity: Sequence[float] | None = None) -> str:
        """A rigid body of ``mass`` (kg), principal moments ``inertia = (I11, I22, I33)`` and
        ``products = (I12, I13, I23)`` about its centre of mass in its axes (kg m²), its
        centre at ``position``, its axes at ``orientation``, named ``points`` in its axes
        from its centre; initial ``velocity`` (m/s) and ``angular_velocity`` (rad/s, in
        space)."""
        pts = None if points is None else {str(k): _listed(v) for k, v in points.items()}
        return self._entry("rigid_bodies", name, mass=mass, inertia=_listed(inertia), products=_maybe(products),
                           position=_listed(position), orientation=_orientation(orientation), points=pts,
                           velocity=_maybe(velocity), angular_velocity=_maybe(angular_velocity))

    def node(self, name: str, position: Sequence[float], *, orientation: Any = None, velocity: Sequence[float] | None = None,
             angular_velocity: Sequence[float] | None = None) -> str:
        """A node (a beam's end) at ``position`` with axes at ``orientation`` and initial rates."""
        return self._entry("nodes", name, position=_listed(position), orientation=_orientation(orientation),
                           velocity=_maybe(velocity), angular_velocity=_maybe(angular_velocity))

    def beam(self, name: str, a: str, b: str, *, section: str, split: int = 1, up: Sequence[float] | None = None,
             kind: str = "frame", group: str | None = None, fixed: bool = False) -> str:
        """A beam from node ``a`` to ``b`` in ``split`` elements (inner nodes ``NAME[k]``), its
        section's e₂ axis the part of ``up`` across it (default: z, or y for a beam along z);
        ``kind = "truss"``: one pin-ended bar. Its density is a design variable of its own, or
        its design ``group``'s, or none where it is ``fixed`` at full density (:meth:`design`
        sets the laws)."""
        return self._entry("beams", name, nodes=[a, b], section=section, split=None if split == 1 else split,
                           up=_maybe(up), kind=None if kind == "frame" else kind, group=group, fixed=fixed or None)

    def ground_structure(self, name: str, *, nx: int, ny: int, nz: int = 1, length: float, height: float,
                         width: float = 0.0, section: str, connectivity: str = "full", origin: Sequence[float] | None = None,
                         orientation: Any = None, kind: str = "frame", split: int = 1, fixed: bool = False) -> str:
        """A box lattice of ``nx × ny × nz`` nodes (``NAME[i,j,k]``) over a link of ``length ×
        height × width`` (m), its ``x = 0`` face centred at ``origin`` with axes at
        ``orientation``, and the bars ``NAME/bar{m}`` its ``connectivity`` joins: ``"full"``
        (every bar no third node lies on), ``"diagonals"``, ``"faces"`` or ``"edges"``; each
        a beam of ``section`` (or a truss bar) with a density of its own unless ``fixed``."""
        return self._entry("ground_structures", name, nx=nx, ny=ny, nz=None if nz == 1 else nz, length=length,
                           height=height, width=width or None, section=section,
                           connectivity=None if connectivity == "full" else connectivity, origin=_maybe(origin),
                           orientation=_orientation(orientation), kind=None if kind == "frame" else kind,
                           split=None if split == 1 else split, fixed=fixed or None)

    def point_mass(self, name: str, node: str, mass: float) -> str:
        """A point mass (kg) at ``node``'s origin."""
        return self._entry("point_masses", name, node=node, mass=mass)

    def spherical(self, name: str, a: Anchor, b: Anchor = "ground") -> str:
        """A ball joint: the anchors' points coincide."""
        return self._joint(name, "spherical", a, b)

    def revolute(self, name: str, a: Anchor, b: Anchor = "ground", *, axis: Sequence[float], drive: dict | None = None) -> str:
        """A hinge about ``axis``; ``drive``, a motion law of its angle (rad) from where it starts."""
        return self._joint(name, "revolute", a, b, axis=_listed(axis), drive=drive)

    def universal(self, name: str, a: Anchor, b: Anchor = "ground", *, axes: Sequence[Sequence[float]]) -> str:
        """A Cardan joint: turns about ``axes[0]`` carried by ``a`` and ``axes[1]`` by ``b``, at right angles."""
        return self._joint(name, "universal", a, b, axes=[_listed(axes[0]), _listed(axes[1])])

    def cylindrical(self, name: str, a: Anchor, b: Anchor = "ground", *, axis: Sequence[float]) -> str:
        """``b`` slides along and turns about ``a``'s ``axis`` through ``a``'s point."""
        return self._joint(name, "cylindrical", a, b, axis=_listed(axis))

    def prismatic(self, name: str, a: Anchor, b: Anchor = "ground", *, axis: Sequence[float], drive: dict | None = None) -> str:
        """``b`` slides along ``a``'s ``axis`` without turning; ``drive``, a law of its travel (m)."""
        return self._joint(name, "prismatic", a, b, axis=_listed(axis), drive=drive)

    def weld(self, name: str, a: Anchor, b: Anchor = "ground") -> str:
        """Holds ``b`` to ``a`` (or to the ground): no relative motion."""
        return self._joint(name, "weld", a, b)

    def spring(self, name: str, a: Anchor, b: Anchor, *, k: float = 0.0, c: float = 0.0, length: float | None = None) -> str:
        """A spring-damper (N/m, N s/m) between two anchors, at rest at ``length`` (m; their
        initial distance by default)."""
        return self._entry("springs", name, a=_anchor(a), b=_anchor(b), k=k, c=c, length=length)

    def torsion(self, name: str, joint: str, *, k: float = 0.0, c: float = 0.0, rest: float | None = None) -> str:
        """A torsion spring-damper (N m/rad, N m s/rad) on a revolute or cylindrical ``joint``'s
        angle (its ``b``'s turn from its ``a``'s about the axis), at rest ``rest`` rad from where
        the joint is built (0 by default); the angle is read within half a turn either way."""
        return self._entry("springs", name, joint=joint, k=k, c=c, rest=rest)

    def motor(self, name: str, joint: str, *, torque: float, table: tuple | None = None) -> str:
        """A torque (N m) about the revolute ``joint``'s axis on its ``b``, scaled in time by
        ``table = (t, scale)`` (piecewise linear) if given."""
        return self._entry("motors", name, joint=joint, torque=torque, table=None if table is None else _scale_table(table))

    def load(self, name: str, at: Anchor, *, force: Sequence[float] = (0.0, 0.0, 0.0),
             moment: Sequence[float] = (0.0, 0.0, 0.0), follower: bool = False, table: tuple | None = None) -> str:
        """A force (N) and moment (N m) at an anchor, fixed in space or, as a ``follower``,
        in the axes of what it acts on; scaled in time by ``table = (t, scale)``."""
        return self._entry("loads", name, at=_anchor(at), force=_listed(force), moment=_listed(moment),
                           follower=follower or None, table=None if table is None else _scale_table(table))

    def simulation(self, **defaults: Any) -> None:
        """Default run settings: ``t_end``, ``h``, ``rho_inf``, ``tol``, ``max_iter``, ``load_steps``."""
        self._spec["simulation"] = dict(defaults)

    def _joint(self, name: str, kind: str, a: Anchor, b: Anchor, **keys: Any) -> str:
        return self._entry("joints", name, kind=kind, a=_anchor(a), b=None if b == "ground" else _anchor(b), **keys)

    def _entry(self, list_: str, name: str, **keys: Any) -> str:
        entries = self._spec.setdefault(list_, [])
        entries.append({"name": _name(list_.rstrip("s").replace("_", " "), name),
                        **{k: v for k, v in keys.items() if v is not None}})
        return name


def _maybe(vector: Sequence[float] | None) -> list | None:
    return None if vector is None else _listed(vector)


def is_spatial(spec: Mapping[str, Any]) -> bool:
    """Whether a scene dict describes a spatial scene (``dimension = 3``)."""
    return spec.get("dimension") == 3

