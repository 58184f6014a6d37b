"""First-order optimality: the KKT residual of the problem and its multipliers.

A design x of

    minimize f0(x)  s.t.  g_i(x) <= 0 (i = 1..m),  lower <= x <= upper

is a KKT point when there are multipliers lam >= 0 with

    x = clip(x - grad l, lower, upper),   grad l = grad f0 + sum_i lam_i grad g_i,
    g <= 0,   lam_i g_i = 0

(stationarity up to the bounds' own multipliers, feasibility, complementarity). The
residual measured here is the natural residual of that system, of the problem with its
objective divided by F = max(1, |f0(x)|) (its multipliers lam / F), so that it is relative
for a large objective and absolute for one near zero:

    r_x   = x - clip(x - grad l / F, lower, upper)      the projected gradient: grad l / F
                                                      where no bound is reached
    r_lam = lam / F - max(0, lam / F + g)             min(lam_i / F, -g_i) if g_i <= 0
                                                      (complementarity), -g_i if g_i > 0
                                                      (infeasibility)
    kkt   = max(|r_x|_inf, |r_lam|_inf),

zero exactly at a KKT point: the largest violation of any one condition, whatever the
number of variables (IPOPT measures its optimality error in the same norm). A small kkt
with any lam >= 0 certifies x; :func:`kkt_estimate` takes the smallest over a few
estimates of lam.
"""

from __future__ import annotations

import numpy as np

from .problem import Evaluation


def kkt_residual(x: np.ndarray, evaluation: Evaluation, multipliers: np.ndarray,
                 lower: np.ndarray, upper: np.ndarray) -> float:
    """The natural KKT residual at x for the multipliers ``multipliers`` (module doc)."""
    scale = max(1.0, abs(evaluation.f0))
    lam = multipliers / scale
    gradient = evaluation.df0 / scale + lam @ evaluation.dg
    r_x = x - np.clip(x - gradient, lower, upper)
    r_lam = lam - np.maximum(0.0, lam + evaluation.g)
    return float(np.max(np.abs(np.concatenate((r_x, r_lam)))))


def least_squares_multipliers(x: np.ndarray, evaluation: Evaluation, lower: np.ndarray,
                              upper: np.ndarray, active: np.ndarray) -> np.ndarray:
    """lam >= 0, zero off the constraints ``active``, minimizing the gradient of the
    Lagrangian on the variables strictly inside their bounds,

        min_{lam >= 0} | (grad f0 + sum_{i active} lam_i grad g_i)_free |_2     (NNLS).
    """
    from scipy.optimize import nnls  # here: importing scipy.optimize doubles `import flextop`

    lam = np.zeros(evaluation.g.size)
    free = (x > lower) & (x < upper)
    if active.any() and free.any():
        lam[active] = nnls(evaluation.dg[np.ix_(active, free)].T, -evaluation.df0[free])[0]
    return lam


def kkt_estimate(x: np.ndarray, evaluation: Evaluation, lower: np.ndarray, upper: np.ndarray,
                 multipliers: np.ndarray | None = None) -> tuple[float, np.ndarray]:
    """The KKT residual at x and the multipliers that give it: the smallest residual of
    lam = 0, of ``multipliers`` (the subproblem's, if given) and of the least-squares
    multipliers of the near-active constraints, those with -g_i below the better of the
    first two residuals (a constraint further from active would add its slack -g_i)."""
    candidates = [np.zeros(evaluation.g.size)]
    if multipliers is not None:
        candidates.append(np.maximum(multipliers, 0.0))
    residuals = [kkt_residual(x, evaluation, lam, lower, upper) for lam in candidates]
    active = -evaluation.g < min(residuals)
    if active.any():
        candidates.append(least_squares_multipliers(x, evaluation, lower, upper, active))
        residuals.append(kkt_residual(x, evaluation, candidates[-1], lower, upper))
    best = int(np.argmin(residuals))
    return residuals[best], candidates[best]
