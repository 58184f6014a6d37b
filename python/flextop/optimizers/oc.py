"""The optimality-criteria method: the field's baseline for minimum compliance under one
volume constraint (Bendsøe and Sigmund; the update of the 88-line code, Andreassen et al.
2011, Eq. 3).

At a design x with objective gradient ∂f₀/∂x ≤ 0 and one constraint g(x) ≤ 0 that is linear
in x (a volume), the optimality condition ∂f₀/∂xₑ + λ ∂g/∂xₑ = 0 suggests the fixed point

    xₑ ← clip(xₑ Bₑ^η, box),   Bₑ = −(∂f₀/∂xₑ) / (λ ∂g/∂xₑ),

inside the move-limited box; λ is found by bisection so that the constraint, linear in x, is
active: g(x) + ∇g·(x_new − x) = 0 (or λ = 0 if the box alone satisfies it).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ..errors import SettingsError
from .method import Evaluator, Method, Step, move_limits
from .problem import Problem
from .state import OptimizerState


@dataclass
class OptimalityCriteria(Method):
    """The optimality-criteria update with damping exponent ``eta`` (½ in the 88-line code)
    and a bisection on λ to relative width ``tol``; the move limit is the driver's. ``eta``
    lies in (0, 1] (1: the undamped fixed point; beyond it the update overshoots), ``tol``
    in (0, 1).

    Only for one constraint linear in the design (a volume, of filtered densities too) and
    an objective that falls as any variable grows (compliance): :meth:`check` refuses more
    constraints, and a variable whose objective gradient is positive stays put at its lower
    bound side (``Bₑ`` clipped at 0)."""

    eta: float = 0.5
    tol: float = 1e-12
    name: ClassVar[str] = "oc"
    ranges: ClassVar[dict[str, tuple[float, float, str]]] = {"eta": (0.0, 1.0, "(]"), "tol": (0.0, 1.0, "()")}

    def check(self, problem: Problem) -> None:
        if problem.m != 1:
            raise SettingsError(f"the optimality-criteria method takes exactly one constraint (a volume), "
                                f"the problem has {problem.m}; use MMA")

    def step(self, problem: Problem, state: OptimizerState, move: float, evaluate: Evaluator) -> Step:
        x, e = state.x, state.evaluation
        low, high = move_limits(x, problem.lower, problem.upper, move)
        dg = e.dg[0]
        if np.any(dg <= 0):
            raise SettingsError("the optimality-criteria method needs a constraint that grows with every "
                                "variable (a volume); use MMA")
        descent = np.maximum(-e.df0, 0.0)

        def update(lam: float) -> np.ndarray:
            with np.errstate(over="ignore"):  # λ → 0 sends Bₑ to inf: clipped to the box
                return np.clip(x * (descent / (lam * dg)) ** self.eta, low, high)

        def active(lam: float) -> float:
            return e.g[0] + dg @ (update(lam) - x)

        lam_low, lam_high = 0.0, 1.0
        while active(lam_high) > 0 and lam_high < 1e300:
            lam_high *= 10.0
        if active(np.finfo(float).tiny) <= 0:  # the box satisfies the constraint: λ = 0
            lam = 0.0
            x_new = high.copy()
        else:
            while lam_high - lam_low > self.tol * (lam_low + lam_high):
                lam = 0.5 * (lam_low + lam_high)
                lam_low, lam_high = (lam, lam_high) if active(lam) > 0 else (lam_low, lam)
            lam = lam_high
            x_new = update(lam)
        return Step(x_new, evaluate(x_new), np.array([lam]))
