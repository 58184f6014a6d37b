#!/usr/bin/env python
"""What Rayleigh damping costs: the reference robot arm with its sections damped by
``rayleigh = [α, β]`` against the same arm undamped, across designs (uniform x = 0.1, 0.5
and 1, a random one), for a plain run and a run with adjoint and direct gradients (best of
five each). The stiffness part's derivative is only partly symmetric: Newton's matrix takes
the symmetric part (Newton then converges linearly) and the gradients' solves iterate on
the symmetric factors until the rest is resolved, so both cost more.

    OPENBLAS_NUM_THREADS=1 python benches/damping.py     # writes benches/results/damping.md
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

import flextop
from flextop import scenes

sys.path.insert(0, str(Path(__file__).resolve().parent))
from work_precision import timed  # noqa: E402

HERE = Path(__file__).resolve().parent
DAMPINGS = {"none": None, "β = 1e-4 s": [0.0, 1e-4], "α = 2/s, β = 1e-4 s": [2.0, 1e-4]}


def arm(rayleigh) -> flextop.Simulation:
    spec = scenes.robot_arm().to_dict()
    if rayleigh is not None:
        for section in spec["sections"].values():
            section["rayleigh"] = rayleigh
    return flextop.Simulation(spec)


def main() -> None:
    rng = np.random.default_rng(3)
    n = arm(None).n_design
    designs = {"x = 0.1": np.full(n, 0.1), "x = 0.5": np.full(n, 0.5), "x = 1": np.ones(n),
               "random": rng.uniform(0.05, 1.0, n)}
    rows = ["| design | damping | run (ms) | ratio | Newton iterations per step | adjoint (ms) | ratio | direct (ms) | ratio |",
            "|---|---|---|---|---|---|---|---|---|"]
    for name, x in designs.items():
        base = None
        for label, rayleigh in DAMPINGS.items():
            sim = arm(rayleigh)
            t_run, res = timed(lambda: sim.run(x), 5)
            t_adj, _ = timed(lambda: sim.run_with_sensitivities(x, ["tip_deflection"], method="adjoint"), 5)
            t_dir, _ = timed(lambda: sim.run_with_sensitivities(x, ["tip_deflection"], method="direct"), 5)
            base = base or (t_run, t_adj, t_dir)
            rows.append(f"| {name} | {label} | {1e3 * t_run:.1f} | {t_run / base[0]:.2f} | {res.newton['mean']:.2f} | "
                        f"{1e3 * t_adj:.1f} | {t_adj / base[1]:.2f} | {1e3 * t_dir:.1f} | {t_dir / base[2]:.2f} |")
            print(rows[-1], flush=True)
    text = ["# Cost of Rayleigh damping", "",
            "`OPENBLAS_NUM_THREADS=1 python benches/damping.py`: the reference robot arm (1.3 s, h = 0.02 s), "
            "best of five; ratios against the undamped arm at the same design.", "", *rows, ""]
    (HERE / "results" / "damping.md").write_text("\n".join(text))


if __name__ == "__main__":
    main()
