"""The optimality-criteria method: the field's baseline for minimum compliance under one
volume constraint (Bendsøe and Sigmund; the update of the 88-line code, Andreassen et al.
2011, Eq. 3).

At a design x with one constraint g(x) ≤ 0 that is linear in x (a volume), the optimality
condition ∂f₀/∂xₑ + λ ∂g/∂xₑ = 0 suggests the fixed point

    xₑ ← clip(xₑ Bₑ^η, box),   Bₑ = max(0, −∂f₀/∂xₑ) / (λ ∂g/∂xₑ),

inside the move-limited box; λ is found by bisection so that the constraint, linear in x, is
active: g(x) + ∇g·(x_new − x) = 0. The classic Bₑ is only defined where the objective falls
as xₑ grows; a variable whose objective gradient is positive or zero gains nothing from its
volume, and Bₑ = 0 sends it to the lower side of its box at every λ (the update of
Sigmund's compliant-mechanism version of the 99-line code, whose sensitivities take both
signs: ``max(1e-10, -dc/lmid)``; Bendsøe and Sigmund 2003, on mechanism synthesis). λ = 0 only where that split box, every descent variable at its
upper side and every other at its lower, satisfies the linearized constraint: from a
feasible design the update never leaves it, and never raises a variable whose objective
grows with it.

The update's change is its optimality residual: xₑ (Bₑ^η − 1) vanishes where Bₑ = 1
(stationarity, with λ the multiplier) or a bound holds xₑ on the side Bₑ points to, so a
small change where the move limit held no variable is convergence (Status.FIXED_POINT of
:func:`~flextop.optimizers.optimize` with ``xtol``: the 88-line code's change < 0.01).
"""

from __future__ import annotations

from collections.abc import Callable
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

    Only for one constraint linear in the design (a volume, of filtered densities too):
    :meth:`check` refuses more constraints. Made for an objective that falls as any variable
    grows (compliance); a variable whose objective gradient is positive or zero moves to
    the lower side of its box (``Bₑ`` = 0, module doc), never up."""

    eta: float = 0.5
    tol: float = 1e-12
    name: ClassVar[str] = "oc"
    fixed_point: ClassVar[bool] = True
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

        if active(np.finfo(float).tiny) <= 0:  # the split box satisfies the constraint: λ = 0
            lam, x_new = 0.0, np.where(descent > 0, high, low)
        else:
            lam = self.multiplier(active)
            x_new = update(lam)
        return Step(x_new, evaluate(x_new), np.array([lam]))

    def multiplier(self, active: Callable[[float], float]) -> float:
        """The λ > 0 that makes the linearized constraint ``active(λ)`` (decreasing in λ)
        zero, by bisection to relative width ``tol``: the upper end of the final bracket,
        where the constraint holds."""
        lam_low, lam_high = 0.0, 1.0
        while active(lam_high) > 0 and lam_high < 1e300:
            lam_high *= 10.0
        while lam_high - lam_low > self.tol * (lam_low + lam_high):
            lam = 0.5 * (lam_low + lam_high)
            lam_low, lam_high = (lam, lam_high) if active(lam) > 0 else (lam_low, lam)
        return lam_high
