"""The spatial robot arm designed for three payloads: scenarios of a spatial scene.

    python benches/spatial_scenarios.py     # writes benches/results/spatial_scenarios.md

The spatial robot arm (``flextop.scenes.spatial_robot_arm``: links of 5 × 2 × 2 nodes, 188
tube densities) carrying 0.5, 2 and 4 kg through the same motion, V ≤ 0.4 V per link:

1. the 2 kg scenario alone, the weighted sum of the three and the worst case (started from
   the weighted sum's optimum), each by MMA from x = 0.4 on the scene's grid, the weighted
   sum serially and on two threads (the same bits, and the time of each);
2. every scenario's tip deflection at each design (and at x = 0.4), on the scene's grid
   and as built, measured to rtol = 1e-2.
"""

from __future__ import annotations

import platform
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

import flextop
from flextop.problems import Scenario, ScenarioProblem
from flextop.scenes.spatial_catalogue import spatial_robot_arm
from flextop.spatial import SpatialSimulation

ROOT = Path(__file__).resolve().parents[1]
PAYLOADS = (0.5, 2.0, 4.0)
ITERATIONS = 60


def cases() -> list[Scenario]:
    return [Scenario(f"{p:g} kg", spatial_robot_arm(payload=p)) for p in PAYLOADS]


def volumes(sim: SpatialSimulation) -> list[tuple[str, float]]:
    return [(f"volume:{link}", 0.4 * sim.volume(1.0, link)) for link in ("link1", "link2")]


def optimized(problem: ScenarioProblem, x0: np.ndarray) -> tuple[flextop.OptimizeResult, float]:
    start = time.perf_counter()
    result = flextop.optimize(problem, problem.start(x0), "mma", max_iter=ITERATIONS)
    return result, time.perf_counter() - start


def main() -> None:
    scenarios = cases()
    sim = SpatialSimulation(scenarios[0].scene)
    limits = volumes(sim)
    x0 = np.full(sim.n_design, 0.4)
    lines = [f"# The spatial robot arm for three payloads ({platform.machine()}, {ITERATIONS} MMA iterations each)", "",
             "| problem | evaluations | time (s) | KKT residual | status |", "|---|---|---|---|---|"]
    designs: dict[str, np.ndarray] = {"uniform 0.4": x0}

    def row(name: str, result, seconds: float) -> None:
        lines.append(f"| {name} | {result.nfev} | {seconds:.1f} | {result.kkt:.2e} | {result.status.name} |")
        print(lines[-1], flush=True)

    alone, seconds = optimized(ScenarioProblem([scenarios[1]], "tip_deflection", limits), x0)
    row("2 kg alone", alone, seconds)
    designs["2 kg alone"] = alone.x
    summed, seconds = optimized(ScenarioProblem(scenarios, "tip_deflection", limits), x0)
    row("weighted sum, serially", summed, seconds)
    with ThreadPoolExecutor(2) as pool:
        threaded, seconds = optimized(ScenarioProblem(scenarios, "tip_deflection", limits, executor=pool), x0)
    row("weighted sum, two threads", threaded, seconds)
    designs["weighted sum"] = summed.x
    worst, seconds = optimized(ScenarioProblem(scenarios, "tip_deflection", limits, aggregate="worst"), summed.x)
    row("worst case, from the weighted sum's", worst, seconds)
    designs["worst case"] = worst.x[:-1]
    lines.append(f"\nThe same design serially and on two threads: {np.array_equal(summed.x, threaded.x)}.")

    lines += ["", "Each scenario's tip deflection d (m²) at each design, on the scene's grid / as built (to rtol 1e-2):", "",
              "| design | " + " | ".join(s.name for s in scenarios) + " | worst / uniform's worst |",
              "|---|" + "---|" * len(scenarios) + "---|"]
    sims = [SpatialSimulation(s.scene) for s in scenarios]
    reference = None
    for name, x in designs.items():
        grid = [s.run_with_sensitivities(x, "tip_deflection").values[0] for s in sims]
        built = [s.run_with_sensitivities(x, "tip_deflection", rtol=1e-2).values[0] for s in sims]
        reference = reference or max(built)
        cells = " | ".join(f"{g:.3e} / {b:.3e}" for g, b in zip(grid, built))
        lines.append(f"| {name} | {cells} | {max(built) / reference:.3f} |")
        print(lines[-1], flush=True)
    out = ROOT / "benches" / "results" / "spatial_scenarios.md"
    out.write_text("\n".join(lines) + "\n")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
