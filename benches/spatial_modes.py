"""The spatial modal analysis: every mode densely against the lowest by shift-invert Lanczos.

A steel rod (1 cm, 1 m) of spatial beams, clamped at one end, and a lattice of truss bars
(``nx × 3 × 3`` nodes 0.2 m apart, diagonals, pinned at one face; its nodes' rotations are no
unknowns but count among the six per node), at rest: the dense solve
(``SpatialSimulation.modes()``, every mode on the joints' null space, at most 1500
unknowns) against the sparse one (``modes(count=10)``, the lowest ten with their Sturm
count), timed about the same equilibrium (``at=``), best of three; the sparse path alone
past the dense limit. The lowest ten frequencies of both agree to the digits printed.

    python benches/spatial_modes.py   # writes benches/results/spatial_modes.md
"""

from __future__ import annotations

import platform
import time
from pathlib import Path

import numpy as np

from flextop import SpatialScene, SpatialSimulation

ROOT = Path(__file__).resolve().parents[1]
COUNT = 10
DENSE = (33, 133, 233)
"""Elements of the rods solved both ways: 204, 804 and 1404 unknowns."""
SPARSE_ONLY = (900, 2000)
"""Elements past the dense limit: 5406 and 12006 unknowns (a beam splits into at most 1000,
so the longest rod is two beams)."""


def rod(elements: int) -> SpatialSimulation:
    scene = SpatialScene("rod", analysis="static")
    scene.section("steel", E=2.1e11, rho=7850.0, nu=0.3, diameter=0.01)
    scene.node("root", (0.0, 0.0, 0.0))
    scene.node("middle", (0.5, 0.0, 0.0))
    scene.node("end", (1.0, 0.0, 0.0))
    scene.beam("inner", "root", "middle", section="steel", split=elements // 2)
    scene.beam("outer", "middle", "end", section="steel", split=elements - elements // 2)
    scene.weld("clamp", "root")
    return SpatialSimulation(scene)


LATTICES = (6, 24, 60, 150)
"""Lattice lengths in nodes: 324, 1296, 3240 and 8100 unknowns; the first two both ways."""


def lattice(nx: int) -> SpatialSimulation:
    scene = SpatialScene("lattice", analysis="static")
    scene.section("steel", E=2.1e11, rho=7850.0, nu=0.3, diameter=0.01)
    scene.ground_structure("g", nx=nx, ny=3, nz=3, length=0.2 * (nx - 1), height=0.4, width=0.4, section="steel",
                           connectivity="diagonals", kind="truss")
    for j in range(3):
        for k in range(3):
            scene.spherical(f"pin{j}{k}", f"g[0,{j},{k}]")
    return SpatialSimulation(scene)


def best(run, repeats: int = 3) -> tuple[float, object]:
    times, out = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        out = run()
        times.append(time.perf_counter() - start)
    return min(times), out


def row(name: str, size: int, sim: SpatialSimulation, unknowns: int, dense: bool) -> tuple:
    eq = sim.equilibrium()
    sparse_s, sparse = best(lambda: sim.modes(at=eq, count=COUNT))
    dense_s, agree = float("nan"), ""
    if dense:
        dense_s, every = best(lambda: sim.modes(at=eq))
        gap = np.max(np.abs(sparse.frequencies - every.frequencies[:COUNT]) / every.frequencies[:COUNT])
        agree = f"{gap:.1e}"
    lowest = " ".join(f"{f:.4g}" for f in sparse.frequencies[:4])
    out = (f"{name} of {size}", unknowns, dense_s, sparse_s, agree, lowest, sparse.below)
    print(out, flush=True)
    return out


def main() -> None:
    rows = [row("rod", n, rod(n), 6 * (n + 1), n in DENSE) for n in DENSE + SPARSE_ONLY]
    rows += [row("lattice", nx, lattice(nx), 6 * 9 * nx, nx <= 24) for nx in LATTICES]
    lines = [
        "| model | unknowns | dense, every mode (s) | sparse, lowest 10 (s) | dense / sparse | "
        "largest relative difference | lowest four (Hz) | Sturm count |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for model, unknowns, dense_s, sparse_s, agree, lowest, below in rows:
        dense_text = "—" if np.isnan(dense_s) else f"{dense_s:.3f}"
        ratio = "—" if np.isnan(dense_s) else f"{dense_s / sparse_s:.{0 if dense_s >= 10 * sparse_s else 1}f}×"
        lines.append(f"| {model} | {unknowns} | {dense_text} | {sparse_s:.3f} | {ratio} | {agree or '—'} | "
                     f"{lowest} | {below} |")
    text = "\n".join([f"# Spatial modes, dense against sparse ({platform.machine()}, best of 3)", "", *lines, ""])
    out = ROOT / "benches" / "results" / "spatial_modes.md"
    out.write_text(text)
    print(text)


if __name__ == "__main__":
    main()
