"""ParaView output: a run's motion as a VTU time series with a PVD index, a static result or
a design as one VTU file.

Each file holds the structure as VTK cells: every element of every bar and beam as a line
(a bar split into m elements gives m lines), every cell of a continuum member as a quad,
and every joint, point mass and rigid body's centre as a vertex.

Points follow one of ParaView's two conventions, said here because Warp By Vector depends on it:

* **A motion** (``.pvd`` series): each frame's points are where the structure is at that time,
  so the series plays as it is opened; there is no ``displacement`` field (warping would move
  it twice). Point data: ``rotation`` (rad, from the reference), ``velocity`` (m/s) and
  ``angular_velocity`` (rad/s).
* **A static result or a design** (one ``.vtu``): points are the reference configuration and
  ``displacement`` (m) the field that Warp By Vector adds, scaled to make small deflections
  visible; ``rotation`` (rad) beside it.
* Cell data of the lines: ``density`` (of the element's bar, 1 where it is not designed),
  ``bar`` (its index in :attr:`Simulation.bars`), ``axial_force`` N (N, tension positive),
  ``moment_1`` and ``moment_2`` (N m, the end moments in the chord frame),
  ``axial_stress`` N/A (Pa, on the solid section's area). Quads carry their ``density`` (1
  where not designed), ``von_mises`` (Pa, the volume mean over the cell's Gauss points of the
  stress its material carries) and ``strain_energy`` (J), ``bar`` = −1 and NaN for the bars'
  forces; lines carry NaN for the cells' fields. Vertices carry NaN there and
  ``vertex`` = 1 (a joint), 2 (a point mass) or 3 (a rigid body's centre of mass); lines and
  quads carry ``vertex`` = 0.

Points are 3-D (z = 0), as VTK wants. meshio writes the VTU files; the PVD index (the
collection ParaView opens, one dataset per time) is built with ElementTree. The functions
take a :class:`~flextop.Simulation` and its results without importing their module, which
calls them (``Results.to_vtk``).
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..checks import whole
from ..errors import SettingsError


JOINT, POINT_MASS, BODY = 1, 2, 3

FRAMES = 100
"""Frames of a motion (a VTU series, an animation) when ``every`` is not given."""


def frame_indices(n_times: int, every: int | None = None) -> np.ndarray:
    """Every ``every``-th of ``n_times`` states (default: about :data:`FRAMES` of them),
    always ending on the last one."""
    every = -(-n_times // FRAMES) if every is None else whole("every", every)
    indices = np.arange(0, n_times, every)
    return indices if indices[-1] == n_times - 1 else np.append(indices, n_times - 1)


def write_motion(results: Any, path: str | os.PathLike, *, every: int | None = None) -> Path:
    """The motion of ``results`` as ``STEM_00000.vtu``… beside the PVD index ``path``
    (``.pvd``), every ``every``-th step (default: about :data:`FRAMES` frames) and the
    last. Returns the index's path."""
    path = checked_path(path, ".pvd", "a motion is written as a .pvd index with its .vtu files")
    steps = frame_indices(len(results.time), every)
    forces, fields = results.section_forces, results.cell_fields
    speeds = results.qdot.reshape(len(results.time), -1, 3)
    structure = _Structure.of(results.simulation, results.x)
    frames = []
    for k in steps:
        name = f"{path.stem}_{k:05d}.vtu"
        extra = {"velocity": _xyz(speeds[k, :, :2]), "angular_velocity": speeds[k, :, 2]}
        structure.mesh(results.q[k], forces[k], fields[k], extra, moved=True).write(path.parent / name, binary=True)
        frames.append((float(results.time[k]), name))
    return write_index(path, frames)


def write_index(path: Path, frames: list[tuple[float, str]]) -> Path:
    """The PVD index ``path`` of a series: each frame's time (s) and VTU file (beside it)."""
    collection = ET.Element("VTKFile", type="Collection", version="0.1")
    datasets = ET.SubElement(collection, "Collection")
    for time, name in frames:
        ET.SubElement(datasets, "DataSet", timestep=repr(time), part="0", file=name)
    ET.ElementTree(collection).write(path, xml_declaration=True, encoding="utf-8")
    return path


def write_state(results: Any, path: str | os.PathLike) -> Path:
    """A static result as one VTU file ``path``."""
    path = _vtu(path)
    structure = _Structure.of(results.simulation, results.x)
    structure.mesh(results.q, results.section_forces[0], results.cell_fields[0], {}, moved=False).write(path, binary=True)
    return path


def write_design(sim: Any, x: Any, path: str | os.PathLike) -> Path:
    """Design ``x`` (densities) on the reference configuration as one VTU file ``path``."""
    path = _vtu(path)
    structure = _Structure.of(sim, x)
    structure.mesh(np.zeros(3 * len(sim.node_names)), np.zeros((len(structure.lines), 3)), np.zeros((len(structure.quads), 2)), {},
                   moved=False).write(path, binary=True)
    return path


def _vtu(path: str | os.PathLike) -> Path:
    return checked_path(path, ".vtu")


def checked_path(path: str | os.PathLike, suffix: str, what: str = "") -> Path:
    """``path`` if it ends in ``suffix`` (its folder made), else a :class:`SettingsError`
    saying ``what`` is written so."""
    path = Path(path)
    if path.suffix != suffix:
        raise SettingsError(f"{path}: {what + '; ' if what else ''}give a path ending in {suffix}")
    path.parent.mkdir(parents=True, exist_ok=True)
    return path


def _xyz(planar: np.ndarray) -> np.ndarray:
    return np.column_stack([planar, np.zeros(len(planar))])


@dataclass(frozen=True)
class _Structure:
    """What every frame of a scene's files shares: the reference points, the elements as
    lines with their bar, density and solid area, and the vertices with their kind."""

    reference: np.ndarray
    lines: np.ndarray
    bar: np.ndarray
    density: np.ndarray
    area: np.ndarray
    quads: np.ndarray
    quad_density: np.ndarray
    vertices: np.ndarray
    kinds: np.ndarray

    @classmethod
    def of(cls, sim: Any, x: Any) -> _Structure:
        elements = sim.model.elements()
        lines = np.asarray(elements["nodes"], dtype=np.int64).reshape(-1, 2)
        bar = np.asarray(elements["bar"], dtype=np.int64)
        vertices, kinds = _vertices(sim)
        quads = np.asarray(sim.model.cells()["nodes"], dtype=np.int64).reshape(-1, 4)
        return cls(np.asarray(sim.model.reference_positions), lines, bar, sim.bar_densities(x)[bar],
                   _areas(sim, lines, bar)[bar], quads, sim.cell_densities(x), vertices, kinds)

    def mesh(self, q: np.ndarray, forces: np.ndarray, fields: np.ndarray, extra: dict[str, np.ndarray], *,
             moved: bool) -> Any:
        """The frame of state ``q`` with section ``forces``, the cells' ``fields`` (von Mises,
        strain energy) and ``extra`` point data: points
        ``moved`` to where ``q`` puts them, or at the reference with ``q``'s translations as
        the ``displacement`` field."""
        import meshio

        q = np.asarray(q).reshape(-1, 3)
        nan, none = np.full(len(self.vertices), np.nan), np.full(len(self.quads), np.nan)
        unread = np.full(len(self.lines), np.nan)
        forces, fields = np.asarray(forces).reshape(-1, 3), np.asarray(fields).reshape(-1, 2)
        cell_data = {
            "density": [self.density, self.quad_density, nan],
            "bar": [self.bar.astype(float), np.full(len(self.quads), -1.0), np.full(len(self.vertices), -1.0)],
            "axial_force": [forces[:, 0], none, nan],
            "moment_1": [forces[:, 1], none, nan],
            "moment_2": [forces[:, 2], none, nan],
            "axial_stress": [forces[:, 0] / self.area, none, nan],
            "von_mises": [unread, fields[:, 0], nan],
            "strain_energy": [unread, fields[:, 1], nan],
            "vertex": [np.zeros(len(self.lines)), np.zeros(len(self.quads)), self.kinds.astype(float)],
        }
        blocks = [("line", self.lines), ("quad", self.quads), ("vertex", self.vertices[:, None])]
        # A mechanism of rigid bodies alone has no lines, a frame no quads: meshio refuses an
        # empty block.
        kept = [k for k, (_, cells) in enumerate(blocks) if len(cells)]
        points = self.reference + q[:, :2] if moved else self.reference
        point_data = {**({} if moved else {"displacement": _xyz(q[:, :2])}), "rotation": q[:, 2], **extra}
        return meshio.Mesh(_xyz(points), [blocks[k] for k in kept], point_data=point_data,
                           cell_data={name: [data[k] for k in kept] for name, data in cell_data.items()})


def _vertices(sim: Any) -> tuple[np.ndarray, np.ndarray]:
    """Nodes of joints (kind 1), of point masses (kind 2) and of rigid bodies and rings (kind 3)."""
    joints = [(n, JOINT) for j in sim.joints for n in j.nodes]
    masses = [(sim.node(p["node"]), POINT_MASS) for p in sim.spec.get("point_masses", [])]
    rigid_links = [g["name"] for g in sim.spec.get("ground_structures", []) if g.get("rigid")]
    named = [b["name"] for b in sim.spec.get("rigid_bodies", []) + sim.spec.get("rings", [])]
    bodies = [(sim.node(name), BODY) for name in named + rigid_links]
    entries = joints + masses + bodies
    return np.array([n for n, _ in entries], dtype=np.int64), np.array([k for _, k in entries], dtype=np.int64)


def _areas(sim: Any, lines: np.ndarray, bar: np.ndarray) -> np.ndarray:
    """Per bar: the solid section's area, its volume over its length."""
    ends = sim.model.reference_positions[lines]
    lengths = np.bincount(bar, weights=np.linalg.norm(ends[:, 1] - ends[:, 0], axis=1), minlength=len(sim.bars))
    return np.asarray(sim.bars.volume) / lengths
