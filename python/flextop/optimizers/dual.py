"""Dual solution of a convex separable subproblem (shared by CONLIN and MMA).

CONLIN and MMA both replace the problem, at the current design x^k, by convex
separable approximations

    f~_i(x) = f_i(x^k) + sum_j phi_ij(x_j),   i = 0..m,   phi_ij(x^k_j) = 0,

on a box alpha <= x <= beta, and solve the subproblem

    minimize    f~_0(x) + sum_i (c_i y_i + d_i y_i^2 / 2)
    subject to  f~_i(x) - y_i <= 0,   y_i >= 0,   alpha <= x <= beta.      (P)

The elastic variables y_i keep (P) feasible even when the approximated
constraints cannot be met inside the box; with a large c_i they vanish
whenever they can.

(P) is solved through its dual. With multipliers lam >= 0 the Lagrangian

    l(x, y, lam) = f~_0(x) + sum_i lam_i f~_i(x) + sum_i (c_i y_i + d_i y_i^2/2 - lam_i y_i)

separates over the variables, so the dual function

    W(lam) = min_{alpha <= x <= beta, y >= 0} l(x, y, lam)

has a closed-form minimizer: x_j(lam) minimizes the one-dimensional convex
function phi_0j + sum_i lam_i phi_ij on [alpha_j, beta_j] (a formula specific
to each method) and y_i(lam) = max(0, (lam_i - c_i) / d_i). W is concave with

    dW/dlam_i        = f~_i(x(lam)) - y_i(lam)
    d2W/dlam_i dlam_k = - sum_{j free} (df~_i/dx_j)(df~_k/dx_j) / l''_j  -  [y_i > 0] delta_ik / d_i

where "free" are the x_j strictly inside their box and l''_j the curvature of
the Lagrangian in x_j. :func:`solve_dual` maximizes W over lam >= 0 by a
projected Newton method with a backtracking line search; m is small, so each
Newton system is m x m.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np


class SeparableApproximation(ABC):
    """Convex separable approximations f~_0..f~_m on the box alpha <= x <= beta.

    Rows of all (m+1)-sized results are ordered objective first, then the
    constraints; ``weights`` is the vector (1, lam_1, .., lam_m).
    """

    def __init__(self, alpha: np.ndarray, beta: np.ndarray):
        self.alpha = alpha
        self.beta = beta

    @abstractmethod
    def minimizer(self, weights: np.ndarray) -> np.ndarray:
        """x minimizing sum_i weights_i f~_i(x) over the box (closed form, per variable)."""

    @abstractmethod
    def values(self, x: np.ndarray) -> np.ndarray:
        """(f~_0(x), .., f~_m(x)), shape (m+1,)."""

    @abstractmethod
    def gradients(self, x: np.ndarray) -> np.ndarray:
        """df~_i/dx_j, shape (m+1, n)."""

    @abstractmethod
    def curvature(self, x: np.ndarray, weights: np.ndarray) -> np.ndarray:
        """d2/dx_j2 of sum_i weights_i f~_i at x, shape (n,) (the Hessian is diagonal)."""


@dataclass(frozen=True)
class DualSolution:
    """Solution of (P): design x, multipliers lam, and Newton iterations used."""

    x: np.ndarray
    lam: np.ndarray
    iterations: int


@dataclass(frozen=True)
class _DualPoint:
    """W and its gradient at lam, with the primal minimizer x(lam)."""

    lam: np.ndarray
    x: np.ndarray
    value: float
    gradient: np.ndarray

    def residual(self) -> float:
        """Optimality residual of max W s.t. lam >= 0: |lam - max(0, lam + grad W)|_inf."""
        r = self.lam - np.maximum(0.0, self.lam + self.gradient)
        return float(np.max(np.abs(r), initial=0.0))


def _weights(lam: np.ndarray) -> np.ndarray:
    return np.concatenate(([1.0], lam))


def _dual_point(approx: SeparableApproximation, c: np.ndarray, d: np.ndarray,
                lam: np.ndarray) -> _DualPoint:
    """W(lam) = l(x(lam), y(lam), lam) and dW/dlam = f~(x(lam)) - y(lam)."""
    x = approx.minimizer(_weights(lam))
    y = np.maximum(0.0, (lam - c) / d)
    f = approx.values(x)
    value = f[0] + lam @ f[1:] + c @ y + 0.5 * d @ y**2 - lam @ y
    return _DualPoint(lam, x, float(value), f[1:] - y)


def _dual_hessian(approx: SeparableApproximation, c: np.ndarray, d: np.ndarray,
                  point: _DualPoint) -> np.ndarray:
    """d2W/dlam2 at a point where x(lam) and y(lam) are locally smooth (see module doc)."""
    x = point.x
    curvature = approx.curvature(x, _weights(point.lam))
    free = (x > approx.alpha) & (x < approx.beta) & (curvature > 0.0)
    dg = approx.gradients(x)[1:, free]
    return -(dg / curvature[free]) @ dg.T - np.diag((point.lam > c) / d)


def _newton_direction(approx: SeparableApproximation, c: np.ndarray, d: np.ndarray,
                      point: _DualPoint) -> np.ndarray:
    """Newton ascent direction on the multipliers not held at zero by the bound lam >= 0.

    A multiplier with lam_i = 0 and dW/dlam_i <= 0 stays at zero. On the others,
    solve (-H + mu I) s = grad W; the tiny mu keeps the system solvable when
    too few variables are free to make H definite.
    """
    free = (point.lam > 0.0) | (point.gradient > 0.0)
    system = -_dual_hessian(approx, c, d, point)[np.ix_(free, free)]
    mu = 1e-10 * max(1.0, float(np.trace(system)))
    direction = np.zeros_like(point.lam)
    direction[free] = np.linalg.solve(system + mu * np.eye(system.shape[0]), point.gradient[free])
    return direction


def _projected_search(approx: SeparableApproximation, c: np.ndarray, d: np.ndarray,
                      point: _DualPoint, direction: np.ndarray,
                      sigma: float = 1e-4, max_halvings: int = 60) -> _DualPoint | None:
    """Backtrack along lam(t) = max(0, lam + t * direction), t = 1, 1/2, 1/4, ...

    Accept the first t with sufficient increase (Armijo)
        W(lam(t)) >= W(lam) + sigma * grad W . (lam(t) - lam),
    or, since W is flat to rounding error close to the maximum, a step that
    halves the optimality residual without measurably decreasing W.
    Returns None when no step is acceptable.
    """
    rounding = 1e-13 * (1.0 + abs(point.value))
    t = 1.0
    for _ in range(max_halvings):
        lam = np.maximum(0.0, point.lam + t * direction)
        gain = point.gradient @ (lam - point.lam)
        trial = _dual_point(approx, c, d, lam)
        if gain > 0.0 and trial.value >= point.value + sigma * gain:
            return trial
        if trial.value >= point.value - rounding and trial.residual() <= 0.5 * point.residual():
            return trial
        t *= 0.5
    return None


def solve_dual(approx: SeparableApproximation, c: np.ndarray, d: np.ndarray,
               lam0: np.ndarray, tol: float = 1e-10, max_iter: int = 100) -> DualSolution:
    """Maximize the dual W(lam) over lam >= 0, starting from lam0.

    Projected Newton steps; if the line search finds no acceptable Newton step
    a projected gradient step is tried, and if that fails too the current
    multipliers are optimal to rounding error. Stops when the optimality
    residual |lam - max(0, lam + grad W)|_inf is below ``tol``.
    """
    if np.size(lam0) == 0:  # no constraints: (P) is the separable minimization of f~_0
        return DualSolution(approx.minimizer(np.ones(1)), np.zeros(0), 0)
    point = _dual_point(approx, c, d, np.maximum(0.0, np.asarray(lam0, dtype=float)))
    iteration = 0
    while iteration < max_iter and point.residual() > tol:
        iteration += 1
        trial = _projected_search(approx, c, d, point, _newton_direction(approx, c, d, point))
        if trial is None:
            trial = _projected_search(approx, c, d, point, point.gradient)
        if trial is None:
            break
        point = trial
    return DualSolution(point.x, point.lam, iteration)
