"""Void cells of linear energy (issue 53): the continuum arm's designs with every cell
nonlinear (``void = "nonlinear"``) and with each cell's energy blended between its nonlinear
and its linear form by its density (``void = "linear_energy"``, the default; Wang, Lazarov
& Sigmund 2014, γ(x) a smoothed step at η₁ = 0.05 of sharpness β₁ = 500, on each cell's co-rotated
displacement).

The robot arm of the paper with 60 × 20 cells per link (:func:`flextop.scenes.continuum_robot_arm`),
over its 1.3 s motion in 100 steps, on BENCHMARKS' designs (uniform 0.5, random in
[0.01, 1], and the random void/solid mix, x ∈ {0.01, 1}, rng seed 0 as ``continuum.py``
draws them): whether the run ends, a run with the adjoint gradients of the tip deflection
and the strain energy (s), the tip deflection d (Eq. 40), and the void cells' share of the
cells' strain energy over the motion (their largest share at a step; void: x < 0.12, where
γ < 1). The void cells turn with their link; in the paper's fixed frame the linear energy,
not objective, loads a rigidly turned void cell by the contraction (1 − cos θ) times
s(x_min) = 1e-6 of the solid's stiffness (the `void.rs` tests); co-rotated, not at all.

    python benches/void.py   # → benches/results/void.md (about 2 minutes)
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

import flextop
from flextop.scenes import continuum_robot_arm

ROOT = Path(__file__).resolve().parents[1]
RESPONSES = ["tip_deflection", "strain_energy"]
NX, NY = 60, 20


def designs(n: int) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(0)
    return {"uniform 0.5": np.full(n, 0.5), "random": rng.uniform(0.01, 1.0, n),
            "void or solid": np.where(rng.random(n) < 0.5, 0.01, 1.0)}


def void_share(sim: flextop.Simulation, x: np.ndarray, run) -> float:
    """The void cells' largest share of the cells' strain energy at a step."""
    variable = np.asarray(sim.model.cells()["variable"])
    density = np.where(variable >= 0, x[np.maximum(variable, 0)], 1.0)
    energy = run.cell_fields[:, :, 1]
    total = energy.sum(axis=1)
    void = energy[:, density < 0.12].sum(axis=1)
    return float((void / np.where(total > 0, total, 1.0)).max())


def row(sim: flextop.Simulation, x: np.ndarray) -> tuple[str, float | None]:
    try:
        run = sim.run(x)
    except flextop.SimulationError as error:
        return f"stops: {str(error).split(':')[0]} … | — | — | —", None
    start = time.perf_counter()
    f, _ = sim.run_with_sensitivities(x, RESPONSES, method="adjoint")
    seconds = time.perf_counter() - start
    d = float(f[0])
    return f"runs to t = {run.time[-1]:.2f} s | {seconds:.2f} | {d:.6e} | {void_share(sim, x, run):.1e}", d


def main() -> None:
    sims = {void: flextop.Simulation(continuum_robot_arm(nx=NX, ny=NY, void=void))
            for void in ("nonlinear", "linear_energy")}
    lines = ["| design (60 × 20) | void | outcome | run + adjoint (s) | d (m²) | void cells' energy share |",
             "|---|---|---|---|---|---|"]
    for name, x in designs(sims["nonlinear"].n_design).items():
        values = {}
        for void, sim in sims.items():
            text, values[void] = row(sim, x)
            lines.append(f"| {name} | {void} | {text} |")
        if None not in values.values():
            change = values["linear_energy"] / values["nonlinear"] - 1
            lines.append(f"| {name} | d changed by | {change:+.2e} | | | |")
    text = ("Produced by `python benches/void.py`: the continuum arm, 60 × 20 cells per link, 100 steps over "
            "1.3 s, every cell nonlinear or void cells blended to the linear energy.\n\n" + "\n".join(lines) + "\n")
    (ROOT / "benches" / "results" / "void.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
