"""The spatial modal analysis: every mode densely against the lowest by shift-invert Lanczos.

A steel rod (1 cm, 1 m) of spatial beams, clamped at one end, at rest: the dense solve
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


def best(run, repeats: int = 3) -> tuple[float, object]:
    times, out = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        out = run()
        times.append(time.perf_counter() - start)
    return min(times), out


def main() -> None:
    rows = []
    for elements in DENSE + SPARSE_ONLY:
        sim = rod(elements)
        eq = sim.equilibrium()
        sparse_s, sparse = best(lambda: sim.modes(at=eq, count=COUNT))
        dense_s, agree = float("nan"), ""
        if elements in DENSE:
            dense_s, dense = best(lambda: sim.modes(at=eq))
            gap = np.max(np.abs(sparse.frequencies - dense.frequencies[:COUNT]) / dense.frequencies[:COUNT])
            agree = f"{gap:.1e}"
        lowest = " ".join(f"{f:.4g}" for f in sparse.frequencies[:4])
        rows.append((elements, 6 * (elements + 1), dense_s, sparse_s, agree, lowest, sparse.below))
        print(rows[-1], flush=True)
    lines = [
        "| elements | unknowns | dense, every mode (s) | sparse, lowest 10 (s) | dense / sparse | "
        "largest relative difference | lowest four (Hz) | Sturm count |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for elements, unknowns, dense_s, sparse_s, agree, lowest, below in rows:
        dense_text = "—" if np.isnan(dense_s) else f"{dense_s:.3f}"
        ratio = "—" if np.isnan(dense_s) else f"{dense_s / sparse_s:.0f}×"
        lines.append(f"| {elements} | {unknowns} | {dense_text} | {sparse_s:.3f} | {ratio} | {agree or '—'} | "
                     f"{lowest} | {below} |")
    text = "\n".join([f"# Spatial modes, dense against sparse ({platform.machine()}, best of 3)", "", *lines, ""])
    out = ROOT / "benches" / "results" / "spatial_modes.md"
    out.write_text(text)
    print(text)


if __name__ == "__main__":
    main()
