"""CONLIN: convex linearization (Fleury & Braibant, 1986).

Each function is linearized in the direct variable x_j where its derivative
is positive and in the reciprocal variable 1/x_j where it is negative:

    f~_i(x) = f_i(x0) + sum_{j: df_ij > 0} df_ij (x_j - x0_j)
                      - sum_{j: df_ij < 0} x0_j^2 df_ij (1/x_j - 1/x0_j),

with df_ij = df_i/dx_j(x0). Writing A_ij = max(df_ij, 0) and
B_ij = x0_j^2 max(-df_ij, 0) >= 0,

    f~_i(x) = f_i(x0) + sum_j [A_ij (x_j - x0_j) + B_ij (1/x_j - 1/x0_j)],

which is convex for x > 0 (reciprocal variables need positive lower bounds).
For dual weights w = (1, lam) the per-variable minimization of
a_j x_j + b_j / x_j, a = w A, b = w B, gives

    x_j(lam) = sqrt(b_j / a_j)   clipped to [alpha_j, beta_j].

The subproblem is solved through this dual (see :mod:`.dual`) inside move
limits |x_j - x0_j| <= s_j (xmax_j - xmin_j). The linearization is not
conservative in general (e.g. 1/x^3 is convex in 1/x), so with fixed move
limits CONLIN can cycle between two designs; the move limits therefore adapt
per variable like MMA's asymptotes: s_j starts at ``move`` and is multiplied
by ``move_decr`` when x_j oscillates and by ``move_incr`` when it keeps its
direction, never exceeding ``move``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ..errors import SettingsError
from .dual import SeparableApproximation, solve_dual
from .method import Evaluator, Method, Step, move_limits, trend_factor
from .problem import Evaluation, Problem
from .state import OptimizerState


class ConlinApproximation(SeparableApproximation):
    """The CONLIN approximations of f0 and g at x0 on the box alpha <= x <= beta."""

    def __init__(self, x0: np.ndarray, evaluation: Evaluation,
                 alpha: np.ndarray, beta: np.ndarray):
        super().__init__(alpha, beta)
        df = np.vstack([evaluation.df0, evaluation.dg])
        self.x0 = x0
        self.f = np.concatenate(([evaluation.f0], evaluation.g))
        self.A = np.maximum(df, 0.0)
        self.B = x0**2 * np.maximum(-df, 0.0)

    def minimizer(self, weights: np.ndarray) -> np.ndarray:
        a, b = weights @ self.A, weights @ self.B
        with np.errstate(divide="ignore", invalid="ignore"):
            x = np.sqrt(b / a)
        # a = b = 0: x_j does not enter the weighted sum; keep it where it is.
        x = np.where(np.isnan(x), self.x0, x)
        return np.clip(x, self.alpha, self.beta)

    def values(self, x: np.ndarray) -> np.ndarray:
        return self.f + self.A @ (x - self.x0) + self.B @ ((self.x0 - x) / (x * self.x0))

    def gradients(self, x: np.ndarray) -> np.ndarray:
        return self.A - self.B / x**2

    def curvature(self, x: np.ndarray, weights: np.ndarray) -> np.ndarray:
        return 2.0 * (weights @ self.B) / x**3


@dataclass(frozen=True)
class Conlin(Method):
    """CONLIN with adaptive move limits.

    ``move_incr``, ``move_decr``: adaptation factors of the move limits
    (module doc); ``c``, ``d``: cost of the elastic variables y_i (linear and
    quadratic) that keep the subproblem feasible, as in MMA; c should be
    large compared with the expected multipliers. ``move_incr`` ≥ 1, ``move_decr`` in
    (0, 1], ``c`` ≥ 0, ``d`` > 0.
    """

    move_incr: float = 1.2
    move_decr: float = 0.7
    c: float = 1000.0
    d: float = 1.0
    name: ClassVar[str] = "conlin"
    ranges: ClassVar[dict[str, tuple[float, float, str]]] = {
        "move_incr": (1.0, math.inf, "[)"), "move_decr": (0.0, 1.0, "(]"), "c": (0.0, math.inf, "[)"), "d": (0.0, math.inf, "()")}

    def check(self, problem: Problem) -> None:
        """CONLIN's reciprocal variables 1/x_j need x_j > 0: every lower bound positive."""
        bad = np.flatnonzero(problem.lower <= 0.0)
        if bad.size:
            j = bad[0]
            others = f" (and {bad.size - 1} more)" if bad.size > 1 else ""
            raise SettingsError(f"CONLIN needs positive lower bounds (its reciprocal variables 1/x): "
                                f"x[{j}] has lower bound {problem.lower[j]:g}{others}; use MMA or GCMMA")

    def move_widths(self, state: OptimizerState, move: float) -> np.ndarray:
        """Move limits s_j (fractions of xmax_j - xmin_j) for the step from ``state.x``."""
        previous = state.method_data.get("move_limit")
        if state.x_prev2 is None or previous is None:
            return np.full(state.x.size, move)
        factor = trend_factor(state.x, state.x_prev1, state.x_prev2, self.move_incr, self.move_decr)
        return np.minimum(move, factor * previous)

    def step(self, problem: Problem, state: OptimizerState, move: float,
             evaluate: Evaluator) -> Step:
        widths = self.move_widths(state, move)
        alpha, beta = move_limits(state.x, problem.lower, problem.upper, widths)
        approx = ConlinApproximation(state.x, state.evaluation, alpha, beta)
        m = problem.m
        solution = solve_dual(approx, np.full(m, self.c), np.full(m, self.d), state.multipliers)
        return Step(solution.x, evaluate(solution.x), solution.lam, {"move_limit": widths})
