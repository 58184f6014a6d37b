"""flextop's MMA (with its safeguard), GCMMA and CONLIN against NLopt's MMA (`LD_MMA`, the
conservative CCSA form of Svanberg's MMA) and mmapy (Deetman's port of Svanberg's
`mmasub`, plain MMA) on the same problems, from the same start, with the same budget:
objective reached (in the problem's units), iterations, evaluations, largest constraint.

    pip install nlopt mmapy
    python benches/optimizers_vs_nlopt.py     # writes benches/results/optimizers_vs_nlopt.md

Problems: Rosenbrock on [−2, 2]² from (−1.2, 1), without and with a² + b² ≤ 1.5 (where
plain MMA used to cycle); Svanberg's five-segment cantilever from x = 5; the static truss
(p = 3 and the convex p = 1) and the robot arm's two objectives from x = 0.4. NLopt counts
evaluations (its conservative inner steps evaluate extra points); its budget is in
evaluations, the others' in outer iterations.
"""

from __future__ import annotations

import sys
from pathlib import Path

import mmapy
import nlopt
import numpy as np

import flextop
from flextop.optimizers import EvaluationError

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "python"))
from test_optimizers import cantilever, rosenbrock  # noqa: E402


def ours(factory, x0, method: str, budget: int):
    problem = factory()
    result = flextop.optimize(problem, x0, method=method, max_iter=budget, xtol=0.0)
    return result.fun, result.nit, result.nfev, float(np.max(result.constr_scaled, initial=-np.inf))


def nlopt_mma(factory, x0, budget: int):
    problem = factory()
    cache: dict = {}
    calls = {"n": 0}

    def evaluation(x):
        key = x.tobytes()
        if key not in cache:
            cache.clear()
            calls["n"] += 1
            cache[key] = problem.evaluate(x)
        return cache[key]

    def objective(x, grad):
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
    if problem.m:
        opt.add_inequality_mconstraint(constraints, np.full(problem.m, 1e-8))
    opt.set_maxeval(budget)
    opt.set_xtol_rel(1e-10)
    x = opt.optimize(np.asarray(x0, dtype=float))
    e = problem.evaluate(x)
    return problem.physical(e)[0], "—", calls["n"], float(np.max(e.g, initial=-np.inf))


def mmapy_mma(factory, x0, budget: int):
    """Svanberg's mmasub as mmapy gives it: a0 = 1, a = 0, c = 1000, d = 1, move 0.2."""
    problem = factory()
    n, m = problem.n, max(problem.m, 1)
    x = np.asarray(x0, dtype=float).reshape(-1, 1)
    lo, hi = problem.lower.reshape(-1, 1), problem.upper.reshape(-1, 1)
    xold1, xold2, low, upp = x.copy(), x.copy(), lo.copy(), hi.copy()
    a, c, d = np.zeros((m, 1)), np.full((m, 1), 1000.0), np.ones((m, 1))

    def values(x):
        e = problem.evaluate(x.ravel())
        g = e.g if problem.m else np.array([-1.0])
        dg = e.dg if problem.m else np.zeros((1, n))
        return e, e.f0, e.df0.reshape(-1, 1), g.reshape(-1, 1), dg

    e, f0, df0, g, dg = values(x)
    evaluations = 1
    for k in range(1, budget + 1):
        xnew, *_, low, upp = mmapy.mmasub(m, n, k, x, lo, hi, xold1, xold2, f0, df0, g, dg, low, upp, 1.0, a, c, d, move=0.2)
        xold2, xold1, x = xold1, x, xnew
        e, f0, df0, g, dg = values(x)
        evaluations += 1
    return problem.physical(e)[0], budget, evaluations, float(np.max(e.g, initial=-np.inf))


def main() -> None:
    arm = lambda objective: (lambda: flextop.robot_arm_problem(objective))  # noqa: E731
    cases = [
        ("Rosenbrock", lambda: rosenbrock(False), np.array([-1.2, 1.0]), 1000),
        ("Rosenbrock, a² + b² ≤ 1.5", lambda: rosenbrock(True), np.array([-1.2, 1.0]), 1000),
        ("Svanberg's cantilever", cantilever, np.full(5, 5.0), 100),
        ("static truss, compliance (p = 3)", flextop.static_truss_problem, np.full(74, 0.4), 100),
        ("static truss, compliance (p = 1, convex)", lambda: flextop.static_truss_problem(p=1.0), np.full(74, 0.4), 100),
        ("robot arm, tip deflection", arm("tip_deflection"), np.full(148, 0.4), 30),
        ("robot arm, mean compliance", arm("compliance"), np.full(148, 0.4), 30),
    ]
    lines = ["Command: `python benches/optimizers_vs_nlopt.py` (same start and budget; objective in the problem's units)", "",
             "| problem | budget | optimizer | objective reached | iterations | evaluations | max g |", "|---|---|---|---|---|---|---|"]
    for name, factory, x0, budget in cases:
        runners = [("flextop MMA", lambda: ours(factory, x0, "mma", budget)), ("flextop GCMMA", lambda: ours(factory, x0, "gcmma", budget)),
                   ("flextop CONLIN", lambda: ours(factory, x0, "conlin", budget)), ("NLopt LD_MMA", lambda: nlopt_mma(factory, x0, budget)),
                   ("mmapy MMA", lambda: mmapy_mma(factory, x0, budget))]
        for label, run in runners:
            try:
                f, it, nfev, g = run()
                lines.append(f"| {name} | {budget} | {label} | {f:.6g} | {it} | {nfev} | {g:+.1e} |")
            except (ValueError, flextop.FlextopError, RuntimeError, EvaluationError) as error:  # CONLIN refuses x ≤ 0; a failed run
                lines.append(f"| {name} | {budget} | {label} | — ({type(error).__name__}: {str(error)[:60]}) | | | |")
            print(lines[-1], flush=True)
    text = "\n".join(lines)
    (Path(__file__).resolve().parents[1] / "benches" / "results" / "optimizers_vs_nlopt.md").write_text(text + "\n", encoding="utf-8")
    print(text)


if __name__ == "__main__":
    main()
