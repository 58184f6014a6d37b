"""Our MMA, GCMMA and CONLIN against NLopt's MMA (Svanberg's globally convergent MMA in
NLopt, `LD_MMA`) on the same problems: objective reached and iterations (evaluations) used.

    pip install nlopt
    python benches/optimizers_vs_nlopt.py     # writes benches/results/optimizers_vs_nlopt.md

NLopt counts evaluations (its MMA evaluates several points per outer iteration when its
conservative check fails); we report both codes' evaluation counts, each run with the same
budget and started from x = 0.4, and each objective at the end.
"""

from __future__ import annotations

from pathlib import Path

import nlopt
import numpy as np

import flextop


def ours(problem_factory, method: str, budget: int) -> tuple[float, int, int]:
    problem = problem_factory()
    result = flextop.optimize(problem, np.full(problem.n, 0.4), method=method, max_iter=budget)
    return result.fun, result.nit, result.nfev, float(np.max(result.constr_scaled))


def nlopt_mma(problem_factory, budget: int) -> tuple[float, int, int, float]:
    problem = problem_factory()
    cache: dict = {}

    def evaluation(x):
        key = x.tobytes()
        if key not in cache:
            cache.clear()
            cache[key] = problem.evaluate(x)
        return cache[key]

    calls = {"n": 0}

    def objective(x, grad):
        calls["n"] += 1
        e = evaluation(x)
        if grad.size:
            grad[:] = e.df0
        return e.f0

    def constraints(result, x, grad):
        e = evaluation(x)
        result[:] = e.g
        if grad.size:
            grad[:] = e.dg

    opt = nlopt.opt(nlopt.LD_MMA, problem.n)
    opt.set_lower_bounds(problem.lower)
    opt.set_upper_bounds(problem.upper)
    opt.set_min_objective(objective)
    opt.add_inequality_mconstraint(constraints, np.full(problem.m, 1e-8))
    opt.set_maxeval(budget)
    opt.set_xtol_rel(1e-4)
    x = opt.optimize(np.full(problem.n, 0.4))
    e = problem.evaluate(x)
    return e.f0 * problem.objective_scale, calls["n"], calls["n"], float(np.max(e.g))


def main() -> None:
    cases = [
        ("static truss, compliance (p = 3)", flextop.static_truss_problem, 100),
        ("static truss, compliance (p = 1, convex)", lambda: flextop.static_truss_problem(p=1.0), 100),
        ("robot arm, tip deflection", lambda: flextop.robot_arm_problem("tip_deflection"), 30),
        ("robot arm, mean compliance", lambda: flextop.robot_arm_problem("compliance"), 30),
    ]
    lines = ["Command: `python benches/optimizers_vs_nlopt.py` (start x = 0.4, same iteration/evaluation budget)", "",
             "| problem | budget | optimizer | objective reached | iterations | evaluations | max g |", "|---|---|---|---|---|---|---|"]
    for name, factory, budget in cases:
        for label, run in [("flextop MMA", lambda: ours(factory, "mma", budget)), ("flextop GCMMA", lambda: ours(factory, "gcmma", budget)),
                           ("flextop CONLIN", lambda: ours(factory, "conlin", budget)), ("NLopt LD_MMA", lambda: nlopt_mma(factory, budget))]:
            f, it, nfev, g = run()
            lines.append(f"| {name} | {budget} | {label} | {f:.6g} | {it} | {nfev} | {g:+.1e} |")
    text = "\n".join(lines)
    print(text)
    (Path(__file__).parent / "results" / "optimizers_vs_nlopt.md").write_text(text + "\n")


if __name__ == "__main__":
    main()
