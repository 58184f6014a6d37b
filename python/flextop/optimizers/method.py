"""What every sequential convex programming method provides: one outer step.

An outer step k builds a convex approximation of the problem at the current
design x^k (from values and gradients only), solves it inside a move-limited
box, and evaluates the problem at the solution x^{k+1}.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import ClassVar, Protocol

import numpy as np

from ..checks import number
from .problem import Evaluation, Problem, Trial
from .state import OptimizerState

class Evaluator(Protocol):
    """How a method evaluates the problem: whole (``evaluate(x)``), or as a :class:`Trial`
    whose gradients are made only if the method keeps the design (``evaluate.trial(x)``).
    Either may raise :class:`~flextop.optimizers.EvaluationError`."""

    def __call__(self, x: np.ndarray) -> Evaluation: ...

    def trial(self, x: np.ndarray) -> Trial: ...


@dataclass(frozen=True)
class Step:
    """Outcome of one outer step: the new design, its evaluation, the
    subproblem multipliers and the arrays the method needs at the next step
    (stored as ``OptimizerState.method_data``)."""

    x: np.ndarray
    evaluation: Evaluation | Trial
    """The evaluation at ``x``, or the :class:`Trial` of it the method kept, its gradients
    made when the driver asks (after :meth:`~Problem.accept` for a problem that
    ``accepts_trials``)."""
    multipliers: np.ndarray
    method_data: dict[str, np.ndarray] = field(default_factory=dict)


class Method(ABC):
    """A sequential convex programming method (CONLIN, MMA, GCMMA, OC): a dataclass of
    settings, each checked as it is made against its interval in ``ranges`` (name →
    ``(low, high, brackets)``), a refusal a :class:`~flextop.errors.SettingsError` naming
    the setting."""

    name: ClassVar[str]
    ranges: ClassVar[dict[str, tuple[float, float, str]]] = {}
    fixed_point: ClassVar[bool] = False
    """Whether a step's design change is the method's own optimality residual (a fixed-point
    update, OC): then a change below ``xtol`` where the move limit held no variable is
    convergence; for the approximation methods it is a stall (MMA's steps are small
    wherever its asymptotes are close)."""

    def __post_init__(self) -> None:
        for setting, span in self.ranges.items():
            number(f"{type(self).__name__}: {setting}", getattr(self, setting), *span)

    def check(self, problem: Problem) -> None:
        """Raise :class:`~flextop.errors.SettingsError` (a ValueError) if the method cannot
        handle ``problem``."""

    @abstractmethod
    def step(self, problem: Problem, state: OptimizerState, move: float,
             evaluate: Evaluator) -> Step:
        """Approximate at ``state.x``, solve the subproblem with move limit ``move``
        (a fraction of upper - lower) and evaluate the new design with ``evaluate``
        (which may raise EvaluationError)."""


def move_limits(x: np.ndarray, lower: np.ndarray, upper: np.ndarray,
                move: float | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Box of the subproblem around x, with s = move (upper - lower):

        max(lower, x - s) <= x_new <= min(upper, x + s).
    """
    step = move * (upper - lower)
    return np.maximum(lower, x - step), np.minimum(upper, x + step)


def trend_factor(x: np.ndarray, x_prev1: np.ndarray, x_prev2: np.ndarray,
                 increase: float, decrease: float) -> np.ndarray:
    """Per-variable factor for adapting a step bound (MMA asymptotes, CONLIN move limits):

        gamma_j = increase  if (x_j - x_prev1_j)(x_prev1_j - x_prev2_j) > 0  (steady direction)
                  decrease  if it is < 0                                    (oscillation)
                  1         otherwise.
    """
    trend = (x - x_prev1) * (x_prev1 - x_prev2)
    return np.where(trend > 0.0, increase, np.where(trend < 0.0, decrease, 1.0))
