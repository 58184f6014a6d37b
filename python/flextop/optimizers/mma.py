"""MMA, the method of moving asymptotes (Svanberg 1987), and its globally
convergent variant GCMMA (Svanberg 2002), in the form of Svanberg's note
"MMA and GCMMA - two methods for nonlinear optimization" (2007).

Approximation at x^k, with asymptotes L_j < x^k_j < U_j and
df_ij = df_i/dx_j(x^k), (.)^+ / (.)^- the positive / negative parts:

    f~_i(x) = f_i(x^k) + sum_j [ p_ij (1/(U_j - x_j) - 1/(U_j - x^k_j))
                               + q_ij (1/(x_j - L_j) - 1/(x^k_j - L_j)) ]
    p_ij = (U_j - x^k_j)^2 (1.001 df_ij^+ + 0.001 df_ij^- + rho_i / (xmax_j - xmin_j))
    q_ij = (x^k_j - L_j)^2 (0.001 df_ij^+ + 1.001 df_ij^- + rho_i / (xmax_j - xmin_j))

MMA uses rho_i = 1e-5; the small extra terms make every f~_i strictly convex.
The subproblem is solved on alpha <= x <= beta,

    alpha_j = max(xmin_j, L_j + 0.1 (x^k_j - L_j), x^k_j - move (xmax_j - xmin_j))
    beta_j  = min(xmax_j, U_j - 0.1 (U_j - x^k_j), x^k_j + move (xmax_j - xmin_j)),

with Svanberg's artificial variables a_0 = 1, a_i = 0 (so z = 0), c_i large
and d_i = 1: the elastic form (P) of :mod:`.dual`. For dual weights
w = (1, lam), P_j = w p_j and Q_j = w q_j, the per-variable minimizer is

    x_j(lam) = (sqrt(P_j) L_j + sqrt(Q_j) U_j) / (sqrt(P_j) + sqrt(Q_j))   clipped to [alpha_j, beta_j].

Asymptotes: in the first two iterations L = x - asyinit (xmax - xmin),
U = x + asyinit (xmax - xmin); afterwards, with
s_j = (x^k_j - x^{k-1}_j)(x^{k-1}_j - x^{k-2}_j) and gamma_j = asyincr
(s_j > 0), asydecr (s_j < 0) or 1 (s_j = 0),

    L_j = x^k_j - gamma_j (x^{k-1}_j - L^{k-1}_j),   U_j = x^k_j + gamma_j (U^{k-1}_j - x^{k-1}_j),

kept within 0.01 .. 10 times (xmax_j - xmin_j) of x^k_j.
"""

from __future__ import annotations

import math
from copy import copy
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ..checks import whole
from .dual import DualSolution, SeparableApproximation, solve_dual
from .method import Evaluator, Method, Step, move_limits, trend_factor
from .problem import Evaluation, Problem, Values
from .state import OptimizerState


def update_asymptotes(x: np.ndarray, x_prev1: np.ndarray | None, x_prev2: np.ndarray | None,
                      lower_prev: np.ndarray | None, upper_prev: np.ndarray | None,
                      span: np.ndarray, asyinit: float, asyincr: float,
                      asydecr: float) -> tuple[np.ndarray, np.ndarray]:
    """Asymptotes (L, U) for the subproblem at x (see module doc).

    Widened (asyincr) where the design keeps moving in the same direction,
    narrowed (asydecr) where it oscillates.
    """
    if x_prev2 is None:
        return x - asyinit * span, x + asyinit * span
    gamma = trend_factor(x, x_prev1, x_prev2, asyincr, asydecr)
    lower = x - gamma * (x_prev1 - lower_prev)
    upper = x + gamma * (upper_prev - x_prev1)
    return (np.clip(lower, x - 10.0 * span, x - 0.01 * span),
            np.clip(upper, x + 0.01 * span, x + 10.0 * span))


class MMAApproximation(SeparableApproximation):
    """The MMA approximations f~_0..f~_m at x^k (see module doc)."""

    def __init__(self, xk: np.ndarray, evaluation: Evaluation, lower: np.ndarray,
                 upper: np.ndarray, alpha: np.ndarray, beta: np.ndarray,
                 span: np.ndarray, rho: np.ndarray):
        super().__init__(alpha, beta)
        df = np.vstack([evaluation.df0, evaluation.dg])
        plus, minus = np.maximum(df, 0.0), np.maximum(-df, 0.0)
        self.xk, self.L, self.U, self.span = xk, lower, upper, span
        self.f = np.concatenate(([evaluation.f0], evaluation.g))
        self.p_df, self.q_df = 1.001 * plus + 0.001 * minus, 0.001 * plus + 1.001 * minus
        self.set_rho(rho)

    def set_rho(self, rho: np.ndarray) -> None:
        """p_ij and q_ij for the regularization rho_i (module doc)."""
        regularization = rho[:, None] / self.span
        self.rho = rho
        self.p = (self.U - self.xk) ** 2 * (self.p_df + regularization)
        self.q = (self.xk - self.L) ** 2 * (self.q_df + regularization)

    def regularized(self, rho: np.ndarray) -> MMAApproximation:
        """The same approximation with rho_i instead (GCMMA's inner iterations change
        nothing else)."""
        if rho is self.rho:
            return self
        approx = copy(self)
        approx.set_rho(rho)
        return approx

    def minimizer(self, weights: np.ndarray) -> np.ndarray:
        sqrt_p, sqrt_q = np.sqrt(weights @ self.p), np.sqrt(weights @ self.q)
        x = (sqrt_p * self.L + sqrt_q * self.U) / (sqrt_p + sqrt_q)
        return np.clip(x, self.alpha, self.beta)

    def values(self, x: np.ndarray) -> np.ndarray:
        xk, L, U = self.xk, self.L, self.U
        return (self.f + self.p @ ((x - xk) / ((U - x) * (U - xk)))
                + self.q @ ((xk - x) / ((x - L) * (xk - L))))

    def gradients(self, x: np.ndarray) -> np.ndarray:
        return self.p / (self.U - x) ** 2 - self.q / (x - self.L) ** 2

    def curvature(self, x: np.ndarray, weights: np.ndarray) -> np.ndarray:
        return 2.0 * ((weights @ self.p) / (self.U - x) ** 3 + (weights @ self.q) / (x - self.L) ** 3)

    def asymptotes(self) -> dict[str, np.ndarray]:
        """L and U, to be carried to the next iteration."""
        return {"lower_asymptote": self.L, "upper_asymptote": self.U}

    def rho_sensitivity(self, x: np.ndarray) -> float:
        """d f~_i(x) / d rho_i, the same for every i (GCMMA's d(x)):

            sum_j (U_j - L_j)(x_j - x^k_j)^2 / ((U_j - x_j)(x_j - L_j)(xmax_j - xmin_j))
        """
        L, U = self.L, self.U
        return float(np.sum((U - L) * (x - self.xk) ** 2 / ((U - x) * (x - L) * self.span)))


@dataclass(frozen=True)
class MMA(Method):
    """The method of moving asymptotes.

    ``asyinit``, ``asyincr``, ``asydecr``: asymptote rules (module doc);
    ``c``, ``d``: cost of the elastic variables (c should be large compared
    with the expected multipliers, so scale f0 to order 1..100);
    ``rho``: the regularization rho_i of p_ij and q_ij. Each is checked as the method is
    made: ``asyinit`` in [0.01, 10] (where the asymptotes are kept), ``asyincr`` ≥ 1,
    ``asydecr`` in (0, 1], ``c`` ≥ 0, ``d`` and ``rho`` > 0.

    Plain MMA is not globally convergent. In particular, a variable whose
    optimum is interior and set by the objective alone (no active constraint
    balancing it) is always stepped close to one asymptote, so once the
    asymptotes reach their minimum distance 0.01 (xmax - xmin) it can cycle
    with an amplitude of about 0.9 % of its range: on the two-variable
    Rosenbrock function it alternated between two points for 1,000 iterations.
    Hence the ``safeguard``: a step whose design is dominated by the current one
    — a higher objective and no smaller constraint violation ``Σ max(g_i, 0)``, as
    a filter method would reject it — is redone with GCMMA's conservative inner
    iterations (raising rho_i until every approximation bounds its function from
    above at the new design), from rho_i already raised by the rejected trial's own
    shortfall (:func:`raised_rho`; the first inner iterate from GCMMA's plain start was
    rejected in every safeguarded iteration of the arm to a tolerance: one evaluation
    fewer per such iteration, 198 against 236 for 40 iterations to the same design, and
    14 % fewer over the 18 Rosenbrock runs of the tests). In a cycle every other step is such a step, so the
    cycle ends; every other step is plain MMA, including those that trade
    objective for feasibility (the cantilever's first steps) and all 28 of the
    robot arm's tip-deflection optimization. Measured instead: a merit function
    ``f0 + c Σ max(g_i, 0)`` (it also redid the cantilever's steps into
    infeasibility: 35 evaluations for 10 iterations instead of 12 for 11), and
    shrinking move limits or closer asymptotes on oscillation (they end the cycle
    but leave MMA crawling along Rosenbrock's valley: f = 0.04 after 1,000
    iterations).
    """

    asyinit: float = 0.5
    asyincr: float = 1.2
    asydecr: float = 0.7
    c: float = 1000.0
    d: float = 1.0
    rho: float = 1e-5
    safeguard: bool = True
    name: ClassVar[str] = "mma"
    ranges: ClassVar[dict[str, tuple[float, float, str]]] = {
        "asyinit": (0.01, 10.0, "[]"), "asyincr": (1.0, math.inf, "[)"), "asydecr": (0.0, 1.0, "(]"),
        "c": (0.0, math.inf, "[)"), "d": (0.0, math.inf, "()"), "rho": (0.0, math.inf, "()")}

    def approximation(self, problem: Problem, state: OptimizerState, move: float,
                      rho: np.ndarray) -> MMAApproximation:
        """Asymptotes, subproblem box and approximation at ``state.x``."""
        x, span = state.x, problem.upper - problem.lower
        lower, upper = update_asymptotes(x, state.x_prev1, state.x_prev2,
                                         state.method_data.get("lower_asymptote"),
                                         state.method_data.get("upper_asymptote"),
                                         span, self.asyinit, self.asyincr, self.asydecr)
        alpha, beta = move_limits(x, problem.lower, problem.upper, move)
        alpha = np.maximum(alpha, lower + 0.1 * (x - lower))
        beta = np.minimum(beta, upper - 0.1 * (upper - x))
        return MMAApproximation(x, state.evaluation, lower, upper, alpha, beta, span, rho)

    def solve(self, approx: MMAApproximation, lam0: np.ndarray) -> DualSolution:
        """Solve the subproblem through its dual (see :mod:`.dual`)."""
        m = lam0.size
        return solve_dual(approx, np.full(m, self.c), np.full(m, self.d), lam0)

    def step(self, problem: Problem, state: OptimizerState, move: float,
             evaluate: Evaluator) -> Step:
        approx = self.approximation(problem, state, move, np.full(problem.m + 1, self.rho))
        solution = self.solve(approx, state.multipliers)
        trial = evaluate.trial(solution.x) if self.safeguard else None
        if trial is not None and dominated(trial, state.evaluation):
            rho = raised_rho(approx, initial_rho(state.evaluation, problem.upper - problem.lower), solution.x, trial)
            return conservative_step(self, problem, state, move, evaluate, rho)
        return Step(solution.x, evaluate(solution.x) if trial is None else trial, solution.lam, approx.asymptotes())


def dominated(new: Values, current: Values) -> bool:
    """Whether ``new`` is no better than ``current`` in both objective and infeasibility
    ``Σ max(g_i, 0)``, and worse in the objective."""
    violation = lambda e: float(np.sum(np.maximum(e.g, 0.0)))  # noqa: E731
    return new.f0 > current.f0 and violation(new) >= violation(current)


def initial_rho(evaluation: Evaluation, span: np.ndarray, rho_min: float = 1e-6) -> np.ndarray:
    """GCMMA's rho_i^(k,0) = max(rho_min, 0.1/n sum_j |df_ij| (xmax_j - xmin_j))."""
    df = np.vstack([evaluation.df0, evaluation.dg])
    return np.maximum(rho_min, 0.1 * np.abs(df) @ span / span.size)


def raised_rho(approx: MMAApproximation, rho: np.ndarray, x: np.ndarray, evaluation: Values) -> np.ndarray:
    """GCMMA's update of ``rho`` from a design ``x`` evaluated already (the rejected MMA
    trial): each approximation with ``rho_i`` that falls below its function there by
    ``delta_i d(x)`` gets ``min(1.1 (rho_i + delta_i), 10 rho_i)``, as if ``x`` had been the
    first inner iterate (the approximations differ only in rho, so ``d(x)`` is theirs)."""
    exact = np.concatenate(([evaluation.f0], evaluation.g))
    d = max(approx.rho_sensitivity(x), np.finfo(float).tiny)
    delta = (exact - approx.values(x)) / d - (rho - approx.rho)
    return np.where(delta > 0.0, np.minimum(1.1 * (rho + delta), 10.0 * rho), rho)


def conservative_step(method: MMA, problem: Problem, state: OptimizerState, move: float, evaluate: Evaluator,
                      rho: np.ndarray, max_inner: int = 15, rounding: float = 1e-14) -> Step:
    """GCMMA's inner iterations from ``rho``: solve, evaluate, and while an approximation
    falls below its function at the new design raise its rho_i (class doc of
    :class:`GCMMA`), at most ``max_inner`` times.

    An approximation is conservative when f~_i(x^) >= f_i(x^) - rounding (1 + |f_i(x^)|):
    the allowance is for rounding only. Near an optimum f changes by less than 1e-10 from
    one design to the next, and a tolerance that large (this one's earlier value) accepted
    every step there, conservative or not: GCMMA then moved like plain MMA, and on
    Rosenbrock's function its KKT residual stayed near 1e-4 a few 1e-7 from the optimum
    for a thousand iterations."""
    lam = state.multipliers
    approx = method.approximation(problem, state, move, rho)
    for inner in range(max_inner + 1):
        approx = approx.regularized(rho)
        solution = method.solve(approx, lam)
        lam = solution.lam
        trial = evaluate.trial(solution.x)
        exact = np.concatenate(([trial.f0], trial.g))
        shortfall = exact - approx.values(solution.x)
        if (shortfall <= rounding * (1.0 + np.abs(exact))).all() or inner == max_inner:
            return Step(solution.x, trial, lam, approx.asymptotes())
        rho = raised_rho(approx, rho, solution.x, trial)
    raise AssertionError("unreachable")


@dataclass(frozen=True)
class GCMMA(MMA):
    """Globally convergent MMA: inner iterations make the approximation conservative.

    At outer iteration k, start from
        rho_i = max(rho_min, 0.1/n sum_j |df_ij| (xmax_j - xmin_j)),
    solve the subproblem for x^, evaluate f(x^) and accept x^ if every
    approximation is conservative there, f~_i(x^) >= f_i(x^) (to rounding:
    :func:`conservative_step`). Otherwise raise
    the rho_i of the violated ones,
        delta_i = (f_i(x^) - f~_i(x^)) / d(x^),   rho_i <- min(1.1 (rho_i + delta_i), 10 rho_i),
    (adding delta_i makes f~_i exact at x^, since f~_i grows by d(x) per unit
    rho_i) and solve again, at most ``max_inner`` times (a whole number ≥ 0; ``rho_min`` > 0).
    """

    rho_min: float = 1e-6
    max_inner: int = 15
    name: ClassVar[str] = "gcmma"
    ranges: ClassVar[dict[str, tuple[float, float, str]]] = {**MMA.ranges, "rho_min": (0.0, math.inf, "()")}

    def __post_init__(self) -> None:
        super().__post_init__()
        whole("GCMMA: max_inner", self.max_inner, 0)
    # MMA's ``safeguard`` has nothing to do here: every GCMMA step is conservative.

    def step(self, problem: Problem, state: OptimizerState, move: float,
             evaluate: Evaluator) -> Step:
        rho = initial_rho(state.evaluation, problem.upper - problem.lower, self.rho_min)
        return conservative_step(self, problem, state, move, evaluate, rho, self.max_inner)
