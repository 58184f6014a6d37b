"""Time the paper's two optimizations and split the time between simulation, gradients,
the optimizer's subproblem and the rest (Python overhead, bookkeeping).

    python benches/optimization.py            # writes benches/results/optimization.md
"""

from __future__ import annotations

import platform
import time
from pathlib import Path

import numpy as np

import flextop


def run(name: str, problem: flextop.TopologyProblem, iterations: int, repeats: int = 3) -> dict:
    best = None
    for _ in range(repeats):
        problem.timings = {"simulation": 0.0, "gradients": 0.0}
        problem.objective_scale = None
        start = time.perf_counter()
        result = flextop.optimize(problem, np.full(problem.n, 0.4), method="mma", max_iter=iterations)
        total = time.perf_counter() - start
        if best is None or total < best["total"]:
            sub = sum(r.solve_time for r in result.history)
            best = {"name": name, "total": total, "iterations": result.nit, "evaluations": result.nfev, "subproblem": sub,
                    **problem.timings, "start": problem.objective_scale, "final": result.fun,
                    "status": result.status.name}
    best["other"] = best["total"] - best["simulation"] - best["gradients"] - best["subproblem"]
    return best


def main() -> None:
    rows = [
        run("robot arm, tip deflection (148 variables, adjoint)", flextop.robot_arm_problem("tip_deflection"), 30),
        run("robot arm, mean compliance (148 variables, adjoint)", flextop.robot_arm_problem("compliance"), 30),
        run("static truss, compliance (74 variables)", flextop.static_truss_problem("compliance"), 100),
    ]
    lines = [
        "Command: `python benches/optimization.py` (MMA, start x = 0.4, volume ≤ 0.4 V_full per link; best of 3)",
        f"Machine: {platform.processor() or platform.machine()}, Python {platform.python_version()}",
        "",
        "| problem | iterations | evaluations | total (s) | simulation | gradients | subproblem | other | objective: start → end |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        share = {k: 100 * r[k] / r["total"] for k in ("simulation", "gradients", "subproblem", "other")}
        lines.append(f"| {r['name']} | {r['iterations']} ({r['status']}) | {r['evaluations']} | {r['total']:.2f} | {share['simulation']:.1f} % | "
                     f"{share['gradients']:.1f} % | {share['subproblem']:.1f} % | {share['other']:.1f} % | {r['start']:.4g} → {r['final']:.4g} |")
    text = "\n".join(lines)
    print(text)
    out = Path(__file__).parent / "results" / "optimization.md"
    out.write_text(text + "\n")


if __name__ == "__main__":
    main()
