"""Stresses and buckling: the accuracy of the aggregates across designs, the paper's problems
with stress limits and a frequency floor, and the ten-bar truss of the literature.

1. The arm's design family (benches/tolerance.py): ``stress`` (p-mean, p = 8, q = ½) and its
   peak at rtol = 1e-2 and 3e-3 against a converged reference (8× the elements per bar,
   h/16), with the time of each run.
2. The robot arm minimizing tip deflection (V ≤ 0.4 V per link), MMA, 50 iterations, started
   from the unconstrained optimum (continuation): unconstrained, with a stress limit, and
   with stress limits and first-frequency floors. Each design is judged on the converged
   structure (rtol 3e-3 for d and the stress, the frequencies to 1e-3). The scene's grid
   reads the peak stress low by a factor κ (a maximum over coarse samples converges
   slower than the mean), so a constrained run has a second stage of half the iterations
   with the model limited to limit/(κ(1 + margin)) and the floor raised by the margin
   (``flextop.problems.tightened``). The
   static truss of Section 3.1 minimizing compliance with and without a stress limit,
   judged likewise.
3. The ten-bar truss: minimum weight under member stress limits against the literature.

    python benches/stress.py [--quick]   # writes benches/results/stress.md, docs/stress_*.png
"""

from __future__ import annotations

import argparse
import platform
import sys
import time
from pathlib import Path

import numpy as np

import flextop
from flextop.discretization.accuracy import split_by
from flextop.plots import plot_design
from flextop.problems import (MIN_FREQUENCY, TopologyProblem, robot_arm_problem, static_truss_problem, ten_bar_truss_problem,
                              tightened)
from flextop.scenes import INCH

sys.path.insert(0, str(Path(__file__).resolve().parent))
from tolerance import arm_designs  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def timed(fn):
    start = time.perf_counter()
    out = fn()
    return time.perf_counter() - start, out


def family(quick: bool) -> list[str]:
    sim = flextop.Simulation(flextop.scenes.robot_arm())
    fine = flextop.Simulation(split_by(sim.spec, 8))
    out = ["## The stress p-mean to a tolerance across the arm's designs", "",
           "Reference: 8× the elements per bar, h = 0.00125 s. Errors relative; the peak's against the reference's peak.", "",
           "| design | rtol | error of the mean | estimate | error of ∇ (2-norm) | error of the peak | discretization | time (s) |",
           "|---|---|---|---|---|---|---|---|"]
    worst: dict[float, list[float]] = {1e-2: [], 3e-3: []}
    for name, x in arm_designs(sim, quick).items():
        ref = fine.run_with_sensitivities(x, ["stress"], h=0.00125)
        for rtol in worst:
            try:
                seconds, run = timed(lambda: sim.run_with_sensitivities(x, ["stress"], rtol=rtol))
            except flextop.errors.ToleranceError as error:
                out.append(f"| {name} | {rtol:g} | refused: {str(error).split(':')[1].split(',')[0].strip()} | | | | | |")
                continue
            error = abs(run.values[0] / ref.values[0] - 1)
            gradient = np.linalg.norm(run.gradients - ref.gradients) / np.linalg.norm(ref.gradients)
            peak = abs(run.peaks["stress"] / ref.peaks["stress"] - 1)
            worst[rtol].append(error)
            out.append(f"| {name} | {rtol:g} | {error:.2e} | {run.errors['stress']:.2e} | {gradient:.2e} | {peak:.2e} | "
                       f"{run.discretization} | {seconds:.2f} |")
        print(out[-1], flush=True)
    out += ["", *(f"Worst error of the mean at rtol {r:g}: {max(e):.2e}." for r, e in worst.items()), ""]
    return out


def judged(sim: flextop.Simulation, x: np.ndarray, objective: str) -> dict[str, float]:
    """The design on the converged structure."""
    run = sim.run_with_sensitivities(x, [objective, "stress"], rtol=3e-3, hold_gradients=False)
    return {"f": run.values[0], "peak": run.peaks["stress"], "f1": float(sim.modes(1, x, rtol=1e-3).frequencies[0])}


DRAWN = {"unconstrained": "unconstrained", "stress ≤ 40 MPa": "stress", "stress ≤ 41 MPa, f₁ ≥ 8.2 Hz": "stress_frequency"}
"""The arm's designs drawn into docs/stress_arm_*.png."""

STAGE_MARGIN = 5e-3
"""The second stage's margin (``tightened``): κ moves by 0.2 % with the design between
stages, and MMA ends up to 0.04 % short of a frequency floor that competes with a stress
limit."""

KAPPA_RTOL = 1e-2
"""The tolerance of the run that measures κ: on the arm's stage-one designs its peak is
within 0.01 % of the one at 3e-3 (42.045 against 42.049 MPa), for 1.3 s instead of 12 s;
each final design is judged at 3e-3 all the same."""


def arm(quick: bool) -> list[str]:
    base = robot_arm_problem("tip_deflection")
    sim = base.simulation
    iterations = 10 if quick else 50
    start = flextop.optimize(base, 0.4, "mma", max_iter=iterations).x
    cases = [("unconstrained", {}), ("stress ≤ 40 MPa", {"stress": 40e6}),
             ("stress ≤ 40 MPa, f₁ ≥ 8.1 Hz", {"stress": 40e6, MIN_FREQUENCY: 8.1}),
             ("stress ≤ 41 MPa, f₁ ≥ 8.2 Hz", {"stress": 41e6, MIN_FREQUENCY: 8.2}),
             ("stress ≤ 40 MPa, f₁ ≥ 8.2 Hz", {"stress": 40e6, MIN_FREQUENCY: 8.2})]
    out = ["## The paper's problems with stress limits and a frequency floor", "",
           f"Robot arm, tip deflection, V ≤ 0.4 V per link, MMA from the unconstrained optimum, {iterations} iterations; "
           f"with limits, a second stage of {iterations // 2} from there with the stress limit at target/(κ(1 + "
           f"{STAGE_MARGIN:g})) and the floor at target·(1 + {STAGE_MARGIN:g}) (κ at rtol {KAPPA_RTOL:g}). 'model' is "
           "what the optimizer saw (the scene's grid; an aggregate's limit as c·P), 'converged' the design judged on the "
           "converged structure (rtol 3e-3; f₁ to 1e-3). Time: both stages and the measurement of κ, not the judging.", "",
           "| problem | time (s) | iterations | κ | d model | d converged | stress: model c·P / converged peak (MPa) "
           "| f₁ converged (Hz) | KS floor model (Hz) | active on the model (g > −1e-3) | every limit met, converged | message |",
           "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for label, limits in cases:
        problem = TopologyProblem(sim, "tip_deflection", [*base.constraints, *limits.items()])
        seconds, result = timed(lambda: flextop.optimize(problem, start, "mma", max_iter=iterations))
        iterations_run, kappa = result.nit, "—"
        if limits:
            more, (problem, factors) = timed(lambda: tightened(problem, result.x, rtol=KAPPA_RTOL, targets=limits,
                                                                margin=STAGE_MARGIN))
            later, result = timed(lambda: flextop.optimize(problem, result.x, "mma", max_iter=iterations // 2))
            seconds, iterations_run, kappa = seconds + more + later, iterations_run + result.nit, f"{factors['stress']:.4f}"
        truth = judged(sim, result.x, "tip_deflection")
        names = [c[0] for c in problem.constraints]
        met = truth["peak"] <= limits.get("stress", np.inf) and truth["f1"] >= limits.get(MIN_FREQUENCY, 0.0)
        model_stress = f"{result.constr[names.index('stress')] / 1e6:.2f}" if "stress" in names else "—"
        floor = f"{result.constr[names.index(MIN_FREQUENCY)]:.3f}" if MIN_FREQUENCY in names else "—"
        active = ", ".join(name for name, g in zip(names, result.constr_scaled) if g > -1e-3) or "none"
        out.append(f"| {label} | {seconds:.1f} | {iterations_run} | {kappa} | {result.fun:.4e} | {truth['f']:.4e} | "
                   f"{model_stress} / {truth['peak'] / 1e6:.2f} | {truth['f1']:.3f} | {floor} | {active} | "
                   f"{'yes' if met else 'no'} | {result.message.split(';')[0][:60]} |")
        print(out[-1], flush=True)
        if label in DRAWN:
            plot_design(sim, result.x, title=f"robot arm, {label}: d = {truth['f']:.3e} m² converged",
                        path=ROOT / "docs" / f"stress_arm_{DRAWN[label]}.png")
    out += ["", "Static truss (Section 3.1), compliance, V ≤ 0.4 V, MMA from x = 0.4:", "",
            "| problem | time (s) | iterations | compliance | peak stress model / converged (MPa) | message |", "|---|---|---|---|---|---|"]
    plain = static_truss_problem()
    for label, extra in (("unconstrained", []), ("stress ≤ 30 MPa", [("stress", 30e6)])):
        problem = TopologyProblem(plain.simulation, "compliance", [*plain.constraints, *extra])
        seconds, result = timed(lambda: flextop.optimize(problem, 0.4, "mma", max_iter=100))
        sim = problem.simulation
        model = sim.run_with_sensitivities(result.x, ["stress"]).peaks["stress"]
        converged = flextop.Simulation(split_by(sim.spec, 8)).run_with_sensitivities(result.x, ["stress"]).peaks["stress"]
        out.append(f"| {label} | {seconds:.1f} | {result.nit} | {result.fun:.4g} | {model / 1e6:.2f} / {converged / 1e6:.2f} | "
                   f"{result.message.split(';')[0][:70]} |")
        print(out[-1], flush=True)
        plot_design(sim, result.x, title=f"static truss, {label}: compliance {result.fun:.4g} J",
                    path=ROOT / "docs" / f"stress_truss_{'limited' if extra else 'unconstrained'}.png")
    return out + [""]


def ten_bar() -> list[str]:
    literature = np.array([7.938, 0.1, 8.062, 3.938, 0.1, 0.1, 5.745, 5.569, 5.569, 0.1])
    out = ["## The ten-bar truss under member stress limits", "",
           "Literature (Venkayya 1971; Schmit and Farshi 1974; Haftka and Gürdal 1992): 1593.2 lb.", "",
           "| E | weight (lb) | vs literature | largest area difference (in²) | iterations | time (s) |", "|---|---|---|---|---|---|"]
    for label, factor in (("literature's (10⁴ ksi)", 1.0), ("10⁵× (linear model)", 1e5)):
        problem = ten_bar_truss_problem(E=1e4 * flextop.scenes.KSI * factor)
        seconds, result = timed(lambda: flextop.optimize(problem, 0.5, "mma", max_iter=200))
        weight = 0.1 * result.fun / INCH**3
        out.append(f"| {label} | {weight:.2f} | {weight / 1593.18 - 1:+.2e} | {np.abs(result.x * 10 - literature).max():.3f} | "
                   f"{result.nit} | {seconds:.2f} |")
    return out + [""]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    quick = parser.parse_args().quick
    out = ["# Stresses and buckling", "", f"`python benches/stress.py{' --quick' if quick else ''}` on {platform.machine()}, "
           f"{platform.python_version()}.", ""]
    out += ten_bar()
    out += arm(quick)
    out += family(quick)
    path = ROOT / "benches" / "results" / "stress.md"
    path.write_text("\n".join(out) + "\n")
    print("\n".join(out))


if __name__ == "__main__":
    main()
