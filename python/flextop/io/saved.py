"""Saved results: one ``.npz`` file that gives back, bit for bit, everything a result holds.

The arrays are stored under the names Python uses (``time``, ``q``, ``qdot``, ``qddot``,
``lam``, the energies, ``steps``, Newton ``iterations``; a static result: ``q``, ``lam``)
and the design as ``x``. Beside them, a JSON document (array ``meta``) holds what rebuilds
the run's context: the scene, the Simulation's options and the run's settings, the step and
spectral radius used, a tolerance's discretization and estimated errors, and for reading
the file without flextop: node names and reference positions (``q`` holds displacements
and rotations from them), design-variable names, the bars, and the joints with the names of
their multipliers (``lam`` columns; the ``drive`` rows are the motor torques).

:func:`flextop.load` rebuilds the :class:`~flextop.Simulation` from the scene and
returns :class:`~flextop.Results` or :class:`~flextop.StaticResults` equal to the saved
ones (:func:`read` gives it the file's parts). :func:`write` takes the results without
importing their module, which calls it (``Results.save``); :func:`write_sensitivities` the
same for :class:`~flextop.Sensitivities` (``Sensitivities.save``), which
:func:`flextop.load` gives back too.
"""

from __future__ import annotations

import json
import os
import zipfile
import zlib
from dataclasses import astuple
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import SettingsError


VERSION = 1
"""Layout of the saved file."""

ROWS = {"clamp": ("x", "y", "rotation"), "pin": ("x", "y"), "hinge": ("x", "y"), "weld": ("x", "y", "rotation"),
        "prismatic": ("normal", "rotation"), "roller": ("normal",)}
"""The multipliers of a joint's rows, by kind: its constraint rows, then ``drive`` when driven."""


def multiplier_names(sim: Any) -> list[str]:
    """``JOINT:ROW`` for every column of ``lam``: ``shoulder:x``, ``shoulder:y``,
    ``shoulder:drive`` (the motor torque) and so on; then each averaging ring's
    ``RING:mean_x``, ``RING:mean_y`` and ``RING:rotation``, whose rows follow the joints'."""
    names = []
    for joint in sim.joints:
        rows = [*ROWS.get(joint.kind, ()), *(["drive"] if joint.driven else [])]
        if len(rows) != len(joint.rows):
            rows = [f"row{k}" for k in range(len(joint.rows))]
        names += [f"{joint.name}:{row}" for row in rows]
    rings = [r["name"] for r in sim.spec.get("rings", []) if r.get("kind", "rigid") == "averaging"]
    names += [f"{ring}:{row}" for ring in rings for row in ("mean_x", "mean_y", "rotation")]
    return names


def write(results: Any, path: str | os.PathLike) -> Path:
    """Writes ``results`` to ``path`` (``.npz``)."""
    path = Path(path)
    if path.suffix != ".npz":
        raise SettingsError(f"{path}: results are saved as .npz; give a path ending in .npz")
    path.parent.mkdir(parents=True, exist_ok=True)
    sim = results.simulation
    arrays = {k: np.asarray(v) for k, v in results.raw.items() if not np.isscalar(v)}
    scalars = {k: v for k, v in results.raw.items() if np.isscalar(v)}
    if results.x is not None:
        arrays["x"] = np.asarray(results.x)
    meta = {
        "version": VERSION,
        "kind": "dynamic" if "qdot" in results.raw else "static",
        "scene": sim.spec, "simulation": sim.options, "settings": results.settings, "scalars": scalars,
        "discretization": None if results.discretization is None else list(astuple(results.discretization)),
        "errors": results.errors,
        "node_names": sim.node_names, "reference_positions": np.asarray(sim.model.reference_positions).tolist(),
        "variable_names": sim.variable_names, "components": sim.components,
        "bars": {"name": list(sim.bars.name), "nodes": np.asarray(sim.bars.nodes).tolist(),
                 "variable": np.asarray(sim.bars.variable).tolist(), "component": np.asarray(sim.bars.component).tolist(),
                 "volume": np.asarray(sim.bars.volume).tolist()},
        "joints": [{"name": j.name, "kind": j.kind, "nodes": list(j.nodes), "rows": [j.rows.start, j.rows.stop],
                    "driven": j.driven} for j in sim.joints],
        "multipliers": multiplier_names(sim),
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(path, meta=np.array(json.dumps(meta, default=_plain)), **arrays)
    return path


def write_sensitivities(sens: Any, path: str | os.PathLike) -> Path:
    """Writes :class:`~flextop.Sensitivities` to ``path`` (``.npz``): its arrays (``values``,
    ``gradients``, ``parameter_gradients``, ``steps``, ``time_errors`` where present) and, in ``meta``, the
    rest (names, method, timings, discretization, estimated errors, peaks, parameters)."""
    path = Path(path)
    if path.suffix != ".npz":
        raise SettingsError(f"{path}: sensitivities are saved as .npz; give a path ending in .npz")
    arrays = {name: np.asarray(value) for name, value in (("values", sens.values), ("gradients", sens.gradients),
                                                          ("parameter_gradients", sens.parameter_gradients),
                                                          ("steps", sens.steps), ("time_errors", sens.time_errors))
              if value is not None}
    meta = {"version": VERSION, "kind": "sensitivities", "names": list(sens.names), "method": sens.method,
            "timings": sens.timings, "errors": sens.errors, "gradient_errors": sens.gradient_errors, "peaks": sens.peaks,
            "peak_errors": sens.peak_errors,
            "parameters": list(sens.parameters),
            "discretization": None if sens.discretization is None else list(astuple(sens.discretization))}
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(path, meta=np.array(json.dumps(meta, default=_plain)), **arrays)
    return path


def read(path: str | os.PathLike) -> tuple[dict[str, Any], dict[str, Any], np.ndarray | None]:
    """The saved file's description, the run's raw data (arrays and scalars; a
    sensitivities file: its arrays) and design."""
    try:
        with np.load(path, allow_pickle=False) as data:
            meta = json.loads(str(data["meta"]))
            arrays = {k: data[k] for k in data.files if k != "meta"}
        if meta.get("version") != VERSION:
            raise SettingsError(f"{path}: saved results of layout {meta.get('version')!r}; this flextop reads {VERSION}")
        x = arrays.pop("x", None)
        raw: dict[str, Any] = {**arrays, **meta.get("scalars", {})}
        if meta["kind"] == "dynamic":
            raw["iterations"] = raw["iterations"].tolist()
    except (OSError, ValueError, KeyError, TypeError, AttributeError, EOFError, zipfile.BadZipFile, zlib.error) as error:
        raise SettingsError(f"{path}: not a file of saved flextop results, or a damaged one ({type(error).__name__}: "
                            f"{error})") from None
    return meta, raw, x


def _plain(value: Any) -> Any:
    """JSON for numpy scalars and arrays inside the scene or settings."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"cannot save {type(value).__name__}")
