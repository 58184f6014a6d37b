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
signs: ``max(1e-10, -dc/lmid)``; Bendsøe and Sigmund 2003, on mechanism synthesis).
λ = 0 only where that split box, every descent variable at its upper side and every other
at its lower, satisfies the linearized constraint: from a feasible design the update never
leaves it, and never raises a variable whose objective grows with it.

A volume of projected densities is not quite linear, and the step can overshoot its
linearization. From a feasible design, a trial (values only) over the bound by more than
round-off has its update redone with the linearized constraint held at a target below zero
(:func:`corrected_target`), at most ``CORRECTIONS`` times.

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

CORRECTIONS = 3
"""Updates redone, at most, where a trial overshoots a constraint not quite linear."""
ROUND_OFF = 1e-9
"""A trial's constraint value above zero by no more than this is the round-off of a linear one."""


def corrected_target(targets: list[float], values: list[float], linearized: float) -> float:
    """The next target of the linearized constraint where the trials (their constraint
    ``values`` at the ``targets``) overshoot the bound: the secant through the last two
    trials to zero (the trial's constraint grows with the target), or after the first, the
    target at which the last trial's error against its linearization ``linearized`` would
    leave it at zero."""
    if len(values) == 1 or values[-1] == values[-2]:
        return linearized - values[-1]
    return targets[-1] - values[-1] * (targets[-1] - targets[-2]) / (values[-1] - values[-2])


@dataclass
class OptimalityCriteria(Method):
    """The optimality-criteria update with damping exponent ``eta`` (½ in the 88-line code)
    and a bisection on λ to relative width ``tol``; the move limit is the driver's. ``eta``
    lies in (0, 1] (1: the undamped fixed point; beyond it the update overshoots), ``tol``
    in (0, 1).

    Only for one constraint linear in the design (a volume, of filtered densities too) or
    nearly (of projected ones: the trials corrected, module doc): :meth:`check` refuses
    more constraints. Made for an objective that falls as any variable
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
        if np.any(e.dg[0] <= 0):
            raise SettingsError("the optimality-criteria method needs a constraint that grows with every "
                                "variable (a volume); use MMA")
        box = move_limits(x, problem.lower, problem.upper, move)
        lam, x_new = self.update(x, e.df0, e.g[0], e.dg[0], box, 0.0)
        trial = evaluate.trial(x_new)
        targets, values = [0.0], [trial.g[0]]
        while e.g[0] <= ROUND_OFF and values[-1] > ROUND_OFF and len(values) <= CORRECTIONS:
            targets.append(corrected_target(targets, values, e.g[0] + e.dg[0] @ (x_new - x)))
            lam, x_new = self.update(x, e.df0, e.g[0], e.dg[0], box, targets[-1])
            trial = evaluate.trial(x_new)
            values.append(trial.g[0])
        return Step(x_new, trial, np.array([lam]))

    def update(self, x: np.ndarray, df0: np.ndarray, g: float, dg: np.ndarray,
               box: tuple[np.ndarray, np.ndarray], target: float) -> tuple[float, np.ndarray]:
        """λ and the update inside ``box`` (module doc) that bring the linearized constraint
        g + dg·(x_new − x) to ``target`` (λ > 0), or below it (λ = 0: the split box)."""
        low, high = box
        descent = np.maximum(-df0, 0.0)

        def at(lam: float) -> np.ndarray:
            with np.errstate(over="ignore"):  # λ → 0 sends Bₑ to inf: clipped to the box
                return np.clip(x * (descent / (lam * dg)) ** self.eta, low, high)

        def active(lam: float) -> float:
            return g + dg @ (at(lam) - x) - target

        if active(np.finfo(float).tiny) <= 0:  # the split box satisfies the constraint: λ = 0
            return 0.0, np.where(descent > 0, high, low)
        lam = self.multiplier(active)
        return lam, at(lam)

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
