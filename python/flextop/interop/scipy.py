"""A :class:`flextop.optimizers.Problem` as the arguments of ``scipy.optimize.minimize``.

    from scipy.optimize import minimize
    from flextop.interop.scipy import arguments

    result = minimize(x0=np.full(problem.n, 0.4), method="SLSQP", **arguments(problem))

The objective and constraints are those the problem gives its own optimizers — scaled,
``f0 = f/f_ref`` and ``g = r/b − 1 ≤ 0`` for a :class:`~flextop.TopologyProblem` — as
``fun``, ``jac``, ``bounds`` and one ``NonlinearConstraint`` ``−∞ < g(x) ≤ 0`` with its
Jacobian; all four share one evaluation per design. Methods that take bounds and
nonlinear constraints with gradients: ``"SLSQP"``, ``"trust-constr"``; with bounds only
(a problem without constraints): also ``"L-BFGS-B"``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.optimize import Bounds, NonlinearConstraint

from ..optimizers import Problem
from .cache import Evaluations


def arguments(problem: Problem) -> dict[str, Any]:
    """``fun``, ``jac``, ``bounds`` and ``constraints`` of ``scipy.optimize.minimize``
    for ``problem``, sharing one evaluation per design (``arguments(p)["fun"].evaluations``
    counts them)."""
    evaluations = Evaluations(problem)

    def fun(x: np.ndarray) -> float:
        return evaluations(x).f0

    def jac(x: np.ndarray) -> np.ndarray:
        return evaluations(x).df0

    fun.evaluations = evaluations  # type: ignore[attr-defined]
    out: dict[str, Any] = {"fun": fun, "jac": jac, "bounds": Bounds(problem.lower, problem.upper)}
    if problem.m:
        out["constraints"] = [NonlinearConstraint(lambda x: evaluations(x).g, -np.inf, 0.0, jac=lambda x: evaluations(x).dg)]
    return out
