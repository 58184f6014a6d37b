"""A :class:`flextop.optimizers.Problem` solved by ``scipy.optimize.minimize``.

    from flextop.interop.scipy import minimize

    result = minimize(problem, np.full(problem.n, 0.4), method="SLSQP")
    result.fun          # the objective in its own units (m for tip_deflection)

:func:`minimize` returns scipy's ``OptimizeResult`` with ``fun`` and ``jac`` in the
objective's own units, as its users expect, and the scaled ones the optimizer saw beside
them (``fun_scaled``, ``jac_scaled``), with ``constrained`` the constrained responses in
their units. Scipy's optimizers work on the scaled functions the problem gives its own
optimizers — ``f0 = f/f_ref`` and ``g = r/b − 1 ≤ 0`` for a :class:`~flextop.TopologyProblem`
—, because their stopping tests are absolute: SLSQP's ``ftol = 1e-6`` on a tip deflection
of 1e-6 m would stop at once. :func:`arguments` gives those scaled functions to pass to
``scipy.optimize.minimize`` directly: ``fun``, ``jac``, ``bounds`` and one
``NonlinearConstraint`` ``−∞ < g(x) ≤ 0`` with its Jacobian, all four sharing one
evaluation per design. Methods that take bounds and nonlinear constraints with gradients:
``"SLSQP"``, ``"trust-constr"``; with bounds only (a problem without constraints): also
``"L-BFGS-B"``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.optimize
from scipy.optimize import Bounds, NonlinearConstraint, OptimizeResult

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


def minimize(problem: Problem, x0: Any, method: str = "SLSQP", **options: Any) -> OptimizeResult:
    """``scipy.optimize.minimize`` of ``problem`` from ``x0`` with ``method`` (further
    ``options`` passed on): its result with ``fun`` and ``jac`` the objective and its gradient
    in their own units at ``x`` (:meth:`Problem.physical`), ``fun_scaled`` and ``jac_scaled``
    those the optimizer saw, ``constrained`` the constrained responses in their units, and
    ``evaluations`` the designs evaluated. Those values are the evaluation the problem
    concludes at ``x`` (:meth:`Problem.conclude`: a problem held to a tolerance measures it
    there, unless it is the design measured last); ``success`` and ``message`` are
    scipy's, on the functions it saw."""
    args = arguments(problem)
    result = scipy.optimize.minimize(x0=np.asarray(x0, float), method=method, **args, **options)
    evaluation = args["fun"].evaluations(result.x)
    conclude = getattr(problem, "conclude", None)
    if conclude is not None:
        evaluation = conclude(result.x, evaluation)
    f, constrained, df = problem.physical(evaluation)
    result.fun_scaled, result.jac_scaled = evaluation.f0, np.asarray(evaluation.df0)
    result.fun, result.jac, result.constrained = float(f), np.asarray(df), np.asarray(constrained)
    result.evaluations = args["fun"].evaluations.calls
    return result
