"""The continuum arm's tip deflection and lowest frequencies against its mesh, plain and
enhanced cells side by side.

The robot arm of the paper with each link a plane-stress member (1.0 m × 0.1 m, 5 mm of
aluminium, :func:`flextop.scenes.continuum_robot_arm`) at density 0.5 everywhere, over its
1.3 s motion in 100 steps: the tip deflection d (Eq. 40), also of the solid arm (x = 1), and the three lowest natural
frequencies at the start (drives locked), at 20 × 6 … 120 × 40 cells per link, for
``cell="plain"`` (compatible four-node cells) and ``cell="enhanced"`` (four condensed
incompatible modes, the default); then enhanced cells with the rings' passive solid region
fixed at 50 mm from each ring (``solid_radius=0.05``) rather than one column of cells,
whose width is the mesh's: the one design every mesh represents. Each column's spread,
(max − min)/max.

    python benches/continuum_cell.py   # → benches/results/continuum_cell.md (about 3 minutes)
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

import flextop
from flextop.scenes import continuum_robot_arm

ROOT = Path(__file__).resolve().parents[1]
MESHES = [(20, 6), (40, 12), (60, 20), (120, 40)]


SERIES = [("plain", None), ("enhanced", None), ("enhanced", 0.05)]
"""Each cell kind with the rings' solid cells: those touching a ring (``None``), or within a
distance (m) of one."""


def measured(nx: int, ny: int, cell: str, radius: float | None) -> tuple[float, float, np.ndarray, float]:
    """d (m²) at x = 0.5 and at x = 1, the three lowest frequencies (Hz) at x = 0.5 and the
    run's seconds at x = 0.5."""
    sim = flextop.Simulation(continuum_robot_arm(nx=nx, ny=ny, cell=cell, solid_radius=radius))
    x = np.full(sim.n_design, 0.5)
    clock = time.perf_counter()
    d = sim.run(x).response("tip_deflection")
    seconds = time.perf_counter() - clock
    solid = sim.run(np.ones(sim.n_design)).response("tip_deflection")
    return d, solid, sim.natural_frequencies(3, x, rtol=None), seconds


def main() -> None:
    lines = ["| cells per link | cell | d (m²) | d at x = 1 (m²) | f₁ (Hz) | f₂ (Hz) | f₃ (Hz) | run (s) |",
             "|---|---|---|---|---|---|---|---|"]
    spreads = []
    for cell, radius in SERIES:
        name = cell if radius is None else f"{cell}, rings' solid {1e3 * radius:g} mm"
        rows = []
        for nx, ny in MESHES:
            d, solid, f, seconds = measured(nx, ny, cell, radius)
            rows.append([d, solid, *f])
            lines.append(f"| {nx} × {ny} | {name} | {d:.4e} | {solid:.4e} | {f[0]:.3f} | {f[1]:.3f} | {f[2]:.3f} | "
                         f"{seconds:.2f} |")
            print(lines[-1], flush=True)
        values = np.array(rows)
        spread = (values.max(axis=0) - values.min(axis=0)) / values.max(axis=0)
        spreads.append(f"| {name} | " + " | ".join(f"{100 * s:.1f} %" for s in spread) + " |")
    table = "\n".join(lines)
    summary = "\n".join(["| cell | d | d at x = 1 | f₁ | f₂ | f₃ |", "|---|---|---|---|---|---|", *spreads])
    text = (f"Produced by `python benches/continuum_cell.py`: the continuum robot arm at x = 0.5, 100 steps.\n\n"
            f"{table}\n\nSpread from 20 × 6 to 120 × 40 cells per link, (max − min)/max:\n\n{summary}\n")
    (ROOT / "benches" / "results" / "continuum_cell.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
