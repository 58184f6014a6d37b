"""ParaView output of a spatial motion, a VTU time series with a PVD index
(:meth:`flextop.spatial.SpatialResults.to_vtk`), and of an equilibrium, one VTU file
(:meth:`flextop.spatial.SpatialEquilibrium.to_vtk`), in the planar files' two conventions
(:mod:`flextop.io.export`).

A motion's frames hold the nodes where they are at that time (the series plays as it is
opened), then the joints' places (each joint's first anchor). An equilibrium's points are
the nodes and joints where the scene puts them, with ``displacement`` (m) to where they are
(Warp By Vector adds it) and the axes where they have turned to. Cells: every beam element and
truss bar as a line, every body's centre of mass and every joint as a vertex. Point data:
``velocity`` (m/s) and ``angular_velocity`` (rad/s), both in space, and the node's axes
``axis_1``, ``axis_2``, ``axis_3`` (unit vectors in space: glyphs show how each node turns);
NaN at a joint's point. Cell data: ``beam`` (the index of the scene's beam a line belongs
to, −1 for a vertex), ``vertex`` (1 for a joint, 3 for a body's centre, 0 for a line), as
the planar files', ``joint`` (the joint's index in the scene's joints, −1 for the others),
``density`` (each line's at the design the motion ran at, 1 where fixed; 1 for a vertex):
threshold on it to see a design; ``radius`` (m, each line's section's reach from its axis: a
circle's or a tube's outer radius, half a rectangle's larger side, a truss bar's the circle
of its area; NaN for a vertex): the Tube filter's radius by it draws the bars as built, and
``radius × density`` as designed."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import meshio
import numpy as np

from ..errors import SettingsError
from ..quaternion import rotations
from .export import BODY, JOINT, checked_path, frame_indices, write_index


def write_spatial_motion(results: Any, path: str | os.PathLike, *, every: int | None = None) -> Path:
    """The motion of spatial ``results`` as ``STEM_00000.vtu``… beside the PVD index ``path``
    (``.pvd``), every ``every``-th step (default: about 100 frames) and the last."""
    path = checked_path(path, ".pvd", "a motion is written as a .pvd index with its .vtu files")
    layout = results.layout
    cells, cell_data = _cells(layout, results.x)
    n_joints = len(layout.joint_anchors)
    frames = []
    for k in frame_indices(len(results.time), every):
        q, v = results.q[k].reshape(-1, 7), results.v[k].reshape(-1, 6)
        axes = rotations(q[:, 3:])
        point_data = {"velocity": v[:, :3], "angular_velocity": np.einsum("nij,nj->ni", axes, v[:, 3:]),
                      **_axes(axes)}
        point_data = {key: _at_joints(value, n_joints) for key, value in point_data.items()}
        name = f"{path.stem}_{k:05d}.vtu"
        meshio.Mesh(_points(layout, results.q[k]), cells, point_data=point_data, cell_data=cell_data).write(
            path.parent / name, binary=True)
        frames.append((float(results.time[k]), name))
    return write_index(path, frames)


def write_spatial_state(state: Any, reference: np.ndarray, path: str | os.PathLike) -> Path:
    """A spatial equilibrium ``state`` as one ``.vtu`` file at ``path``: its points where
    the scene puts them (``reference``, the initial configuration), ``displacement`` to the
    equilibrium and the axes there (NaN axes at a joint's place)."""
    path = checked_path(path, ".vtu", "an equilibrium is written as one .vtu file")
    layout = state.layout
    cells, cell_data = _cells(layout, state.x)
    at, start = _points(layout, state.q), _points(layout, reference)
    point_data = {"displacement": at - start,
                  **{k: _at_joints(v, len(layout.joint_anchors)) for k, v in _axes(rotations(state.q.reshape(-1, 7)[:, 3:])).items()}}
    meshio.Mesh(start, cells, point_data=point_data, cell_data=cell_data).write(path, binary=True)
    return path


def _points(layout: Any, q: np.ndarray) -> np.ndarray:
    """The nodes' origins at the configuration ``q``, then the joints' places."""
    return np.vstack([q.reshape(-1, 7)[:, :3], layout.joint_points(q)])


def _axes(axes: np.ndarray) -> dict[str, np.ndarray]:
    return {f"axis_{i + 1}": axes[:, :, i] for i in range(3)}


def _at_joints(nodal: np.ndarray, n_joints: int) -> np.ndarray:
    """A field on the nodes, NaN at the joints' places after them."""
    return np.vstack([nodal, np.full((n_joints, 3), np.nan)])


def _cells(layout: Any, x: np.ndarray | None) -> tuple[list[tuple[str, np.ndarray]], dict[str, list[np.ndarray]]]:
    """The structure's cells — lines, bodies' and joints' vertices — and their data at the
    design ``x``."""
    n, n_joints = len(layout.nodes_in_order), len(layout.joint_anchors)
    lines = np.array([ends for ends in layout.lines], dtype=int).reshape(-1, 2)
    bodies = np.array(layout.bodies, dtype=int).reshape(-1, 1)
    joints = (n + np.arange(n_joints)).reshape(-1, 1)
    beam, density, radius = (np.asarray(a, dtype=float) for a in (layout.line_beam, layout.line_densities(x),
                                                                   layout.line_radius))
    blocks = [_Block("line", lines, beam, 0.0, density, radius),
              _Block("vertex", bodies, -1.0, float(BODY), 1.0, np.nan),
              _Block("vertex", joints, -1.0, float(JOINT), 1.0, np.nan, np.arange(n_joints, dtype=float))]
    kept = [block for block in blocks if len(block.cells)]  # meshio refuses empty blocks
    if not kept:
        raise SettingsError("the scene has no beams, bars, bodies or joints to draw")
    fields = ("beam", "vertex", "joint", "density", "radius")
    return [(block.kind, block.cells) for block in kept], {f: [block.field(f) for block in kept] for f in fields}


@dataclass(frozen=True)
class _Block:
    """A block of cells of one ``kind`` and the cell data they share or carry one each:
    their beam's index, the ``vertex`` code, density, radius (m) and joint's index."""

    kind: str
    cells: np.ndarray
    beam: np.ndarray | float
    vertex: float
    density: np.ndarray | float
    radius: np.ndarray | float
    joint: np.ndarray | float = -1.0

    def field(self, name: str) -> np.ndarray:
        return np.broadcast_to(np.asarray(getattr(self, name), dtype=float), len(self.cells)).astype(float)
