"""One evaluation per design: what the adapters share."""

from __future__ import annotations

import numpy as np

from ..optimizers import Evaluation, Problem


class Evaluations:
    """``problem.evaluate`` remembered for the last design asked for, so that a tool that
    asks for the objective, its gradient and the constraints one call at a time (scipy,
    OpenMDAO) runs one simulation per design. ``calls`` counts the evaluations made."""

    def __init__(self, problem: Problem) -> None:
        self.problem = problem
        self.calls = 0
        self._x: np.ndarray | None = None
        self._evaluation: Evaluation | None = None

    def __call__(self, x: np.ndarray) -> Evaluation:
        x = np.asarray(x, dtype=float)
        if self._evaluation is None or self._x is None or not np.array_equal(x, self._x):
            self._evaluation = self.problem.evaluate(x.copy())
            self._x = x.copy()
            self.calls += 1
        return self._evaluation
