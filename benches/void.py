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
    python benches/void.py --projection   # → benches/results/void_projection.md (seconds)
    python benches/void.py --local   # → benches/results/void_local.md (about 11 minutes)

``--projection``: on 20 × 6 cells per link, the random void/solid mix of the design (0.02 or
0.98, rng seed 3) through a density filter of 1.5 and 2.5 cells and a projection at β = 32
(η = ½), at the scene's step and at a half and a quarter of it: the physical cells' void
(below 0.05) and solid (above 0.95) shares, and whether the run ends. Then the same two
designs under local error control (``local_tol`` 1e-2 and 1e-3, from the scene's step):
whether the run ends, its steps, d, the plausibility warnings it gave, and whether the
steps it took carry the same design again (its gradients are computed on them: ``+0``)
and the design with its most influential cell's density (of those inside the bounds) moved
by ±1e-6 (the gradient's differences need them to).

``--local``: the 60 × 20 void/solid mix (void cells of linear energy) under local error
control (``local_tol = 1e-3``): whether the run ends, its steps, d and the seconds.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

import flextop
from flextop.problems import DensityFilter
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


def projection() -> None:
    """The ``--projection`` table (module docs)."""
    lines = ["| filter radius (cells) | h (s) | void share | solid share | outcome |", "|---|---|---|---|---|"]
    for h in (None, 0.0065, 0.00325):
        sim = flextop.Simulation(continuum_robot_arm(nx=20, ny=6, **({} if h is None else {"h": h})))
        x = np.where(np.random.default_rng(3).random(sim.n_design) < 0.5, 0.02, 0.98)
        for radius in (1.5, 2.5):
            physical = DensityFilter(sim, radius_cells=radius, beta=32.0, eta=0.5).physical(x)
            try:
                run = sim.run(physical)
                outcome = f"runs to t = {run.time[-1]:.2f} s, d = {run.response('tip_deflection'):.4e} m²"
            except flextop.SimulationError as error:
                outcome = f"stops: {error}"
            step = "the scene's (0.013)" if h is None else f"{h:g}"
            lines.append(f"| {radius} | {step} | {np.mean(physical < 0.05):.2f} | {np.mean(physical > 0.95):.2f} | {outcome} |")
    text = ("Produced by `python benches/void.py --projection`: the continuum arm, 20 × 6 cells per link, a random "
            "void/solid mix filtered and projected at β = 32.\n\n" + "\n".join(lines) + "\n\n"
            "Under local error control (module docs):\n\n" + "\n".join(projection_local()) + "\n")
    (ROOT / "benches" / "results" / "void_projection.md").write_text(text)
    print(text)


def projection_local() -> list[str]:
    """The ``--projection`` rows under local error control (module docs)."""
    import warnings

    lines = ["| filter radius (cells) | local_tol | outcome | steps | d (m²) | warnings | on the same steps: the design, one cell ±1e-6 |",
             "|---|---|---|---|---|---|---|"]
    sim = flextop.Simulation(continuum_robot_arm(nx=20, ny=6))
    x = np.where(np.random.default_rng(3).random(sim.n_design) < 0.5, 0.02, 0.98)
    for radius in (1.5, 2.5):
        physical = DensityFilter(sim, radius_cells=radius, beta=32.0, eta=0.5).physical(x)
        for tol in (1e-2, 1e-3):
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                try:
                    run = sim.run(physical, local_tol=tol)
                except flextop.SimulationError as error:
                    lines.append(f"| {radius} | {tol:g} | stops: {error} | — | — | — | — |")
                    continue
            said = "; ".join(str(w.message).split(";")[0] for w in caught) or "none"
            lines.append(f"| {radius} | {tol:g} | runs to t = {run.time[-1]:.2f} s | {len(run.steps)} | "
                         f"{run.response('tip_deflection'):.4e} | {said} | {replayed(sim, physical, run.steps)} |")
    return lines


def replayed(sim: flextop.Simulation, physical: np.ndarray, steps: np.ndarray) -> str:
    """Whether ``steps`` carry the design ``physical`` again, with its gradient, and then
    the design with its most influential cell inside the bounds moved by ±1e-6."""
    def on_steps(y: np.ndarray) -> tuple[str, np.ndarray | None]:
        try:
            return "runs", sim.sensitivities_fixed(y, ["tip_deflection"], {"method": "adjoint"}, steps).gradients[0]
        except flextop.SimulationError as error:
            return f"stops {str(error).split(':')[0]}", None

    said, gradient = on_steps(physical)
    if gradient is None:
        return f"+0: {said}"
    inside = (physical > sim.x_min + 1e-5) & (physical < 1.0 - 1e-5)
    j = int(np.argmax(np.where(inside, np.abs(gradient), -1.0)))
    moved = [f"{dx:+g}: {on_steps(physical + dx * np.eye(sim.n_design)[j])[0]}" for dx in (1e-6, -1e-6)]
    return "; ".join([f"+0: {said}", *moved])


def local() -> None:
    """The ``--local`` table (module docs)."""
    sim = flextop.Simulation(continuum_robot_arm(nx=NX, ny=NY))
    x = designs(sim.n_design)["void or solid"]
    start = time.perf_counter()
    try:
        run = sim.run(x, local_tol=1e-3)
        outcome = f"runs to t = {run.time[-1]:.2f} s | {len(run.time) - 1} | {run.response('tip_deflection'):.4e}"
    except flextop.SimulationError as error:
        outcome = f"stops: {error} | — | —"
    text = ("Produced by `python benches/void.py --local`: the continuum arm's 60 × 20 void/solid mix (seed 0), "
            "void cells of linear energy, local error control at 1e-3.\n\n| outcome | steps | d (m²) | seconds |\n"
            f"|---|---|---|---|\n| {outcome} | {time.perf_counter() - start:.0f} |\n")
    (ROOT / "benches" / "results" / "void_local.md").write_text(text)
    print(text)


if __name__ == "__main__":
    import sys

    local() if "--local" in sys.argv else projection() if "--projection" in sys.argv else main()
