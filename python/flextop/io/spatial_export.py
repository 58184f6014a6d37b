"""ParaView output of a spatial motion: a VTU time series with a PVD index
(:meth:`flextop.spatial.SpatialResults.to_vtk`).

Each frame's points are the nodes where they are at that time (the series plays as it is
opened). Cells: every beam element and truss bar as a line, every body's centre of mass as a
vertex. Point data: ``velocity`` (m/s) and ``angular_velocity`` (rad/s), both in space, and
the node's axes ``axis_1``, ``axis_2``, ``axis_3`` (unit vectors in space: glyphs show how
each node turns). Cell data: ``beam`` (the index of the scene's beam a line belongs to, −1
for a vertex), ``vertex`` (3 for a body's centre, 0 for a line), as the planar files', and
``density`` (each line's at the design the motion ran at, 1 where fixed; 1 for a body):
threshold on it to see a design."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import meshio
import numpy as np

from ..errors import SettingsError
from ..quaternion import rotations
from .export import BODY, frame_indices, write_index


def write_spatial_motion(results: Any, path: str | os.PathLike, *, every: int | None = None) -> Path:
    """The motion of spatial ``results`` as ``STEM_00000.vtu``… beside the PVD index ``path``
    (``.pvd``), every ``every``-th step (default: about 100 frames) and the last."""
    path = Path(path)
    if path.suffix != ".pvd":
        raise SettingsError(f"{path}: a motion is written as a .pvd index with its .vtu files; give a path ending in .pvd")
    path.parent.mkdir(parents=True, exist_ok=True)
    layout = results.layout
    lines = np.array([ends for ends in layout.lines], dtype=int).reshape(-1, 2)
    bodies = np.array(layout.bodies, dtype=int).reshape(-1, 1)
    density = layout.line_densities(results.x)
    blocks = [("line", lines, np.asarray(layout.line_beam, dtype=float), 0.0, density),
              ("vertex", bodies, -1.0, float(BODY), 1.0)]
    kept = [block for block in blocks if len(block[1])]  # meshio refuses empty blocks
    if not kept:
        raise SettingsError("the scene has no beams, bars or bodies to draw")
    cells = [(kind, c) for kind, c, *_ in kept]
    cell_data = {"beam": [np.broadcast_to(beam, len(c)).astype(float) for _, c, beam, _, _ in kept],
                 "vertex": [np.full(len(c), vertex) for _, c, _, vertex, _ in kept],
                 "density": [np.broadcast_to(rho, len(c)).astype(float) for _, c, _, _, rho in kept]}
    n = len(layout.nodes_in_order)
    frames = []
    for k in frame_indices(len(results.time), every):
        q, v = results.q[k].reshape(n, 7), results.v[k].reshape(n, 6)
        axes = rotations(q[:, 3:])
        point_data = {"velocity": v[:, :3], "angular_velocity": np.einsum("nij,nj->ni", axes, v[:, 3:]),
                      **{f"axis_{i + 1}": axes[:, :, i] for i in range(3)}}
        name = f"{path.stem}_{k:05d}.vtu"
        meshio.Mesh(q[:, :3], cells, point_data=point_data, cell_data=cell_data).write(path.parent / name, binary=True)
        frames.append((float(results.time[k]), name))
    return write_index(path, frames)

