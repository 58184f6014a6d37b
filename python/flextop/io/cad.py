"""A continuum member's optimized shape for CAD: its outline at a density threshold as DXF
and SVG, and the part extruded by the member's thickness as STL.

The shape is drawn from the physical densities the simulation runs with (a density
filter's :meth:`~flextop.problems.DensityFilter.physical` densities, its projection
included; the design itself without a filter), in the member's own frame: ``x`` from its
origin along its length, ``y`` across it from its axis (m), as :meth:`Scene.member` lays
it out before it is placed and turned.

How it is drawn, member by member:

1. Each mesh node takes the mean density of the member's cells around it (holes left out,
   the cells at the rings' nodes taken as solid).
2. That nodal field is interpolated by a cubic spline (linear along a direction of one or
   two cells) onto a grid :data:`SMOOTHING` times finer than the mesh, and the region where
   it reaches a level is traced by contourpy's filled contours: a smooth outline, closed,
   its holes as interior rings, whatever is solid along the member's edges kept on the
   edges.
3. shapely makes the polygons valid and joins them; the member's own holes are cut out and
   the cells at every interface ring's nodes (the rings joints attach to) added as solid,
   so the part always carries its joints; collinear points within 1 % of a cell are dropped.
4. The level is the one whose outline holds the thresholded design's area — the cells whose
   density reaches ``threshold`` and the rings' cells, holes left out — to
   :data:`AREA_TOLERANCE` of a cell (bisection, from ``threshold`` itself): the smoothing
   moves a level set where the field curves (the nodes' mean shifts it by about ``h²/8``
   of the field's curvature, and the spline rounds its corners), so the outline at
   ``threshold`` itself can hold several cells more or less material than the design; at
   the level found it holds the same (where no level does, the closest is drawn and a
   :class:`~flextop.errors.PlausibilityWarning` says by how much).

Files: ``NAME.dxf`` (ezdxf: one closed polyline per ring of the outline, the outer ones on
layer ``OUTLINE``, the holes on ``HOLES``, drawing units set), ``NAME.svg`` (the DXF drawn
by ezdxf's SVG backend, black on white, at 1:1 in the unit chosen), ``NAME.stl`` (the
outline extruded by the member's thickness: shapely's constrained Delaunay triangulation of
the polygons with their holes, extruded by trimesh, a closed solid). Lengths are written in
millimetres (a workshop's and a slicer's unit; ``unit="m"`` for metres).

Needs the ``cad`` extra: ``pip install "flextop[cad]"`` (contourpy, shapely, ezdxf, trimesh).
"""

from __future__ import annotations

import importlib.util
import os
import re
import warnings
from dataclasses import dataclass, replace
from itertools import pairwise
from pathlib import Path
from typing import Any, cast

import numpy as np

from ..checks import number
from ..errors import DesignError, PlausibilityWarning, SceneError, SettingsError

SMOOTHING = 4
"""Points of the interpolated density field per cell and direction on which the outline is
traced."""

AREA_TOLERANCE = 1e-3
"""How far, in cells, the outline's area may be from the thresholded design's (step 4 of the
module's)."""

_BISECTIONS = 60
"""The most levels tried to meet :data:`AREA_TOLERANCE`: the level interval halved as many
times, far below any density's round-off."""

UNITS = {"mm": 1e3, "m": 1.0}
"""The length units the files may be written in, and their number per metre."""

LIBRARIES = ("contourpy", "shapely", "ezdxf", "trimesh")
"""What the shape is drawn and written with: the ``cad`` extra."""

_NODE = re.compile(r"^(?P<member>.+)\[(?P<i>\d+),(?P<j>\d+)\]$")


def missing() -> list[str]:
    """The :data:`LIBRARIES` that cannot be imported here (none: CAD files can be written)."""
    return [name for name in LIBRARIES if importlib.util.find_spec(name) is None]


def _require() -> None:
    """A SettingsError naming the :data:`LIBRARIES` missing, if any."""
    if absent := missing():
        raise SettingsError(f"drawing a member's shape needs {', '.join(absent)}: pip install \"flextop[cad]\"")


@dataclass(frozen=True)
class MemberField:
    """One member's physical densities on its grid of cells: ``density[i, j]`` of cell
    column ``i``, row ``j`` (NaN in its holes), its size (m) and the cells at its rings'
    nodes (``ring_cells``, a boolean ``(nx, ny)`` array)."""

    name: str
    length: float
    height: float
    thickness: float
    density: np.ndarray
    ring_cells: np.ndarray

    @property
    def kept_solid(self) -> np.ndarray:
        """The cells at the rings' nodes that the member has (not holes): solid in the shape."""
        return self.ring_cells & np.isfinite(self.density)

    @property
    def cell(self) -> tuple[float, float]:
        """A cell's length and height (m)."""
        nx, ny = self.density.shape
        return self.length / nx, self.height / ny

    def box(self, i0: int, j0: int, i1: int, j1: int) -> Any:
        """The rectangle of cells ``i0 ≤ i < i1``, ``j0 ≤ j < j1`` in the member's frame."""
        import shapely

        dx, dy = self.cell
        return shapely.box(i0 * dx, j0 * dy - self.height / 2, i1 * dx, j1 * dy - self.height / 2)


def member_field(sim: Any, densities: Any, member: str | None = None) -> MemberField:
    """The physical ``densities`` (one per design variable, as :meth:`Simulation.run` takes
    them) on the cells of ``member`` (a name; ``None`` for a scene's only member). A design
    of the wrong length or not finite is a :class:`DesignError`; a scene without members, or
    a name that is none of them, a :class:`SceneError`."""
    spec = _member_spec(sim, member)
    values = sim.cell_densities(densities)
    cells = sim.model.cells()
    index = list(cells["members"]).index(spec["name"])
    names = sim.node_names
    density = np.full((spec["nx"], spec["ny"]), np.nan)
    for k in np.flatnonzero(np.asarray(cells["member"]) == index):
        i, j = _grid_index(names[int(cells["nodes"][k][0])])
        density[i, j] = values[k]
    return MemberField(spec["name"], float(spec["length"]), float(spec["height"]), float(spec["thickness"]), density,
                       _ring_cells(sim, spec))


def _member_spec(sim: Any, member: str | None) -> dict[str, Any]:
    """The scene entry of ``member``, or a SceneError naming what the scene has."""
    members = _members(sim)
    names = [m["name"] for m in members]
    if member is None:
        if len(members) > 1:
            raise SceneError(f"the scene has {len(members)} continuum members ({', '.join(names)}): name the one to draw")
        return members[0]
    if member not in names:
        raise SceneError(f"no continuum member '{member}' in the scene (it has {', '.join(names)})")
    return members[names.index(member)]


def _members(sim: Any) -> list[dict[str, Any]]:
    """The scene's continuum members, or a SceneError: there is no shape to draw."""
    members = sim.spec.get("members", [])
    if not members:
        raise SceneError(f"scene '{sim.spec.get('name', '')}' has no continuum member: there is no shape to draw")
    return members


def _grid_index(node: str) -> tuple[int, int]:
    """Column and row of a member's node from its name ``NAME[i,j]``."""
    found = _NODE.match(node)
    assert found is not None, node
    return int(found["i"]), int(found["j"])


def _ring_cells(sim: Any, spec: dict[str, Any]) -> np.ndarray:
    """The cells of member ``spec`` that touch a node of an interface ring."""
    touched = np.zeros((spec["nx"], spec["ny"]), bool)
    for ring in sim.spec.get("rings", []):
        for node in ring["nodes"]:
            found = _NODE.match(node)
            if found is None or found["member"] != spec["name"]:
                continue
            i, j = int(found["i"]), int(found["j"])
            touched[max(i - 1, 0): i + 1, max(j - 1, 0): j + 1] = True
    return touched


def nodal_field(field: MemberField) -> np.ndarray:
    """Each node's mean density over the member's cells around it, ``(nx + 1, ny + 1)``;
    0 at a node only holes touch."""
    nx, ny = field.density.shape
    padded = np.full((nx + 2, ny + 2), np.nan)
    padded[1:-1, 1:-1] = field.density
    around = np.stack([padded[a: a + nx + 1, b: b + ny + 1] for a in (0, 1) for b in (0, 1)])
    present = np.isfinite(around)
    total = np.where(present, around, 0.0).sum(axis=0)
    count = present.sum(axis=0)
    return np.divide(total, count, out=np.zeros_like(total), where=count > 0)


def outline(sim: Any, densities: Any, member: str | None = None, *, threshold: float = 0.5) -> Any:
    """The shape of ``member`` where its physical ``densities`` reach ``threshold`` (in
    (0, 1)), in the member's own frame (m): a shapely ``Polygon`` or ``MultiPolygon``,
    valid, holes as interior rings, its rings' cells included (see the module). A shape that
    comes out empty is a :class:`DesignError` naming the member and the threshold."""
    threshold = number("threshold (a density)", threshold, 0.0, 1.0, "()")
    _require()
    return shape_of(member_field(sim, densities, member), threshold)


def shape_of(field: MemberField, threshold: float) -> Any:
    """:func:`outline` of a member's densities ``field`` at ``threshold``: traced at the level
    whose shape holds the thresholded design's area (the module's step 4)."""
    present = np.isfinite(field.density)
    reached = present & (field.density >= threshold)
    if not reached.any():
        top = np.nanmax(field.density)
        raise DesignError(f"member '{field.name}': no part of it reaches density {threshold:g} (its densest cell "
                          f"is {top:.3g}); the outline at that threshold is empty: give a lower threshold")
    cell = field.cell[0] * field.cell[1]
    target = cell * np.count_nonzero(reached | field.kept_solid)
    tracer = _Tracer(field)
    shape = best = tracer.shape(threshold)
    # The area falls as the level rises: bracket the target between the field's extremes.
    low, high = (threshold, tracer.top) if shape.area > target else (tracer.bottom, threshold)
    for _ in range(_BISECTIONS):
        if abs(best.area - target) <= AREA_TOLERANCE * cell:
            return best
        level = 0.5 * (low + high)
        shape = tracer.shape(level)
        low, high = (level, high) if shape.area > target else (low, level)
        best = min(best, shape, key=lambda s: abs(s.area - target))
    warnings.warn(PlausibilityWarning(
        f"member '{field.name}': the outline holds {(best.area - target) / cell:+.3g} cells' area against the "
        f"{target / cell:.0f} cells at density {threshold:g} or more (the smoothed field jumps across the level "
        "that would hold them)"), stacklevel=3)
    return best


class _Tracer:
    """A member's smoothed nodal field on the fine grid (the module's steps 1–2), and its
    shape at a level (step 3)."""

    def __init__(self, field: MemberField) -> None:
        import contourpy
        import shapely
        from scipy.interpolate import RectBivariateSpline

        nx, ny = field.density.shape
        x = np.linspace(0.0, field.length, nx + 1)
        y = np.linspace(-field.height / 2, field.height / 2, ny + 1)
        # The rings' cells are solid in the shape: traced so, they join what holds them.
        solid = replace(field, density=np.where(field.kept_solid, 1.0, field.density))
        spline = RectBivariateSpline(x, y, nodal_field(solid), kx=min(3, nx), ky=min(3, ny))
        fine_x = np.linspace(0.0, field.length, SMOOTHING * nx + 1)
        fine_y = np.linspace(-field.height / 2, field.height / 2, SMOOTHING * ny + 1)
        z = spline(fine_x, fine_y).T  # rows along y, as contourpy reads z[y, x]
        self.bottom, self.top = float(z.min()), float(z.max())
        self.field = field
        self.generator = contourpy.contour_generator(fine_x, fine_y, z, fill_type=contourpy.FillType.OuterOffset)
        holes = [field.box(i, j, i + 1, j + 1) for i, j in np.argwhere(np.isnan(field.density))]
        self.holes = shapely.union_all(holes)
        self.rings = shapely.union_all([field.box(i, j, i + 1, j + 1) for i, j in np.argwhere(field.kept_solid)])

    def traced(self, level: float) -> Any:
        """The region where the smoothed field reaches ``level``, as shapely polygons."""
        import shapely

        points, offsets = cast(Any, self.generator.filled(level, max(self.top, level) + 1.0))
        polygons = []
        for xy, starts in zip(points, offsets):
            rings = [xy[a:b] for a, b in pairwise(starts)]
            polygons.append(shapely.make_valid(shapely.Polygon(rings[0], rings[1:])))
        return shapely.union_all(polygons)

    def shape(self, level: float) -> Any:
        """The traced region at ``level``, holes cut out, rings' cells added, valid and
        simplified."""
        import shapely

        shape = shapely.union_all([shapely.difference(self.traced(level), self.holes), self.rings])
        shape = shapely.make_valid(shape.simplify(0.01 * min(self.field.cell), preserve_topology=True))
        polygons = [g for g in getattr(shape, "geoms", [shape]) if isinstance(g, shapely.Polygon) and g.area > 0]
        return shapely.union_all(polygons)


def write(sim: Any, densities: Any, folder: str | os.PathLike, *, threshold: float = 0.5, unit: str = "mm",
          members: list[str] | None = None) -> list[Path]:
    """``NAME.dxf``, ``NAME.svg`` and ``NAME.stl`` in ``folder`` for every continuum member
    (or those named in ``members``) with designed cells, of its shape at ``threshold`` (see
    :func:`outline`), lengths in ``unit`` (``"mm"`` or ``"m"``). Returns the paths written."""
    threshold = number("threshold (a density)", threshold, 0.0, 1.0, "()")
    scale = _unit(unit)
    _require()
    fields = [member_field(sim, densities, name) for name in (members or _designed_members(sim))]
    shapes = [(field, shape_of(field, threshold)) for field in fields]
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    for field, shape in shapes:
        stem = folder / field.name
        document = dxf(shape, unit)
        document.saveas(stem.with_suffix(".dxf"))
        stem.with_suffix(".svg").write_text(svg(document, unit), encoding="utf-8")
        solid(shape, field.thickness, scale).export(stem.with_suffix(".stl"))
        written += [stem.with_suffix(suffix) for suffix in (".dxf", ".svg", ".stl")]
    return written


def _unit(unit: str) -> float:
    if unit not in UNITS:
        raise SettingsError(f"unit must be one of {', '.join(UNITS)}, got {unit!r}")
    return UNITS[unit]


def _designed_members(sim: Any) -> list[str]:
    """The names of the members with a designed cell (every member if none has one)."""
    names = [m["name"] for m in _members(sim)]
    cells = sim.model.cells()
    designed = {cells["members"][m] for m, v in zip(cells["member"], cells["variable"]) if v >= 0}
    return [name for name in names if name in designed] or names


def _polygons(shape: Any) -> list[Any]:
    return list(getattr(shape, "geoms", [shape]))


def dxf(shape: Any, unit: str = "mm") -> Any:
    """An ezdxf document of ``shape`` (m): each ring a closed polyline in ``unit``, outer
    rings on layer ``OUTLINE``, holes on ``HOLES``."""
    import ezdxf
    from ezdxf import units

    scale = _unit(unit)
    document = ezdxf.new("R2010", units=units.MM if unit == "mm" else units.M)
    document.layers.add("OUTLINE", color=7)
    document.layers.add("HOLES", color=1)
    space = document.modelspace()
    for polygon in _polygons(shape):
        for layer, ring in [("OUTLINE", polygon.exterior), *(("HOLES", r) for r in polygon.interiors)]:
            space.add_lwpolyline(scale * np.asarray(ring.coords)[:-1, :2], close=True, dxfattribs={"layer": layer})
    return document


def svg(document: Any, unit: str = "mm") -> str:
    """The drawing of the ezdxf ``document`` (lengths in ``unit``) as SVG, black on white, at
    1:1 on a page in millimetres with a 5 mm margin."""
    from ezdxf.addons.drawing import Frontend, RenderContext, layout
    from ezdxf.addons.drawing import svg as svg_backend
    from ezdxf.addons.drawing.config import BackgroundPolicy, ColorPolicy, Configuration

    backend = svg_backend.SVGBackend()
    config = Configuration(background_policy=BackgroundPolicy.WHITE, color_policy=ColorPolicy.BLACK)
    Frontend(RenderContext(document), backend, config=config).draw_layout(document.modelspace())
    page = layout.Page(0, 0, layout.Units.mm, margins=layout.Margins.all(5))
    return backend.get_string(page, settings=layout.Settings(fit_page=False, scale=UNITS["mm"] / _unit(unit)))


def solid(shape: Any, thickness: float, scale: float = 1.0) -> Any:
    """``shape`` (m) extruded by ``thickness`` (m) as a closed trimesh, lengths times
    ``scale``."""
    import shapely
    import trimesh

    parts = []
    for polygon in _polygons(shape):
        triangles = shapely.get_parts(shapely.constrained_delaunay_triangles(polygon))
        corners = np.stack([np.asarray(t.exterior.coords)[:3, :2] for t in triangles]) * scale
        vertices, faces = np.unique(corners.reshape(-1, 2), axis=0, return_inverse=True)
        parts.append(trimesh.creation.extrude_triangulation(vertices, faces.reshape(-1, 3), thickness * scale))
    return trimesh.util.concatenate(parts)
