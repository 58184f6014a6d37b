"""The optimization problem seen by the optimizers.

All methods in :mod:`flextop.optimizers` solve

    minimize    f0(x)
    subject to  g_j(x) <= 0,          j = 1..m
                lower_i <= x_i <= upper_i,  i = 1..n

and only ever ask the problem for one thing: the values and first derivatives
of f0 and g at a design x (an :class:`Evaluation`).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar, Protocol

import numpy as np

from ..errors import DesignError, FlextopError


@dataclass
class Evaluation:
    """Values and gradients of the objective and constraints at one design.

    ``f0``: objective value; ``g``: constraint values, shape (m,);
    ``df0``: objective gradient, shape (n,); ``dg``: constraint Jacobian,
    shape (m, n) with ``dg[j, i] = dg_j/dx_i``.
    """

    f0: float
    g: np.ndarray
    df0: np.ndarray
    dg: np.ndarray

    def __post_init__(self) -> None:
        self.f0 = float(self.f0)
        self.g = np.atleast_1d(np.asarray(self.g, dtype=float))
        self.df0 = np.asarray(self.df0, dtype=float)
        self.dg = np.asarray(self.dg, dtype=float)
        if self.dg.size == 0 or self.dg.ndim == 1:
            self.dg = self.dg.reshape(self.g.size, self.df0.size)
        if self.df0.ndim != 1 or self.dg.shape != (self.g.size, self.df0.size):
            raise ValueError(f"dg must have shape (m, n) = {(self.g.size, self.df0.size)}, "
                             f"got {self.dg.shape}")

    def is_finite(self) -> bool:
        """True if every value and derivative is a finite number."""
        return bool(
            np.isfinite(self.f0)
            and np.isfinite(self.g).all()
            and np.isfinite(self.df0).all()
            and np.isfinite(self.dg).all()
        )

    def to_dict(self) -> dict:
        """Plain-Python (JSON-able) form."""
        return {"f0": self.f0, "g": self.g.tolist(), "df0": self.df0.tolist(), "dg": self.dg.tolist()}

    @classmethod
    def from_dict(cls, data: dict) -> Evaluation:
        """Inverse of :meth:`to_dict`."""
        return cls(data["f0"], data["g"], data["df0"], data["dg"])


class Values(Protocol):
    """What an :class:`Evaluation` and a :class:`Trial` both hold: the objective's and
    constraints' values."""

    f0: float
    g: np.ndarray


class Trial:
    """The objective's and constraints' values at a design an optimizer may still reject,
    ``f0`` and ``g`` as in :class:`Evaluation`, and the whole :meth:`evaluation` when it
    keeps it: a problem whose gradients cost extra (an adjoint sweep) makes them only then.
    ``gradients()`` returns the evaluation at the same design, its values those of the
    trial."""

    def __init__(self, f0: float, g: np.ndarray, gradients: Callable[[], Evaluation]) -> None:
        self.f0 = float(f0)
        self.g = np.atleast_1d(np.asarray(g, dtype=float))
        self._gradients: Callable[[], Evaluation] | None = gradients
        self._evaluation: Evaluation | None = None

    @classmethod
    def of(cls, evaluation: Evaluation) -> Trial:
        """A trial whose gradients are made already."""
        return cls(evaluation.f0, evaluation.g, lambda: evaluation)

    def evaluation(self) -> Evaluation:
        """Values and gradients, the gradients made on the first call (may raise
        :class:`EvaluationError`)."""
        if self._evaluation is None:
            assert self._gradients is not None
            self._evaluation, self._gradients = self._gradients(), None
        return self._evaluation


class EvaluationError(FlextopError):
    """The problem could not be evaluated at design ``x`` (a :class:`FlextopError`, so that
    one ``except`` catches every error flextop raises).

    Raise it (or a subclass) from :meth:`Problem.evaluate` when the analysis
    fails, e.g. a simulation that does not converge. The optimizer then steps
    back to the last good design with a smaller move limit instead of crashing.
    """

    def __init__(self, message: str, x: np.ndarray | None = None):
        super().__init__(message)
        self.x = None if x is None else np.array(x, dtype=float)


class Problem(ABC):
    """Base class of an optimization problem with n box-bounded variables and m constraints.

    Subclasses call ``super().__init__(lower, upper, m, names)`` and implement
    :meth:`evaluate`. Bounds must be finite with ``lower < upper``. The
    optimizers only use ``n``, ``m``, ``lower``, ``upper`` and ``evaluate``,
    so any object providing them (and :meth:`accept`, :meth:`conclude` and :meth:`trial`, if not this class's)
    works as well.
    """

    def __init__(self, lower: Sequence[float], upper: Sequence[float], m: int,
                 names: Sequence[str] | None = None):
        self.lower = np.array(lower, dtype=float)
        self.upper = np.array(upper, dtype=float)
        self.m = int(m)
        self.names = None if names is None else list(names)
        if self.lower.ndim != 1 or self.lower.shape != self.upper.shape:
            raise ValueError("lower and upper must be 1-d arrays of the same length")
        if not (np.isfinite(self.lower).all() and np.isfinite(self.upper).all()):
            raise ValueError("bounds must be finite")
        if not (self.lower < self.upper).all():
            raise ValueError("every lower bound must be smaller than its upper bound")
        if self.names is not None and len(self.names) != self.m:
            raise ValueError(f"expected {self.m} constraint names, got {len(self.names)}")

    @property
    def n(self) -> int:
        """Number of design variables."""
        return self.lower.size

    def design(self, x: Any) -> np.ndarray:
        """``x`` as a design of this problem: a vector of :attr:`n` real numbers, each
        finite and within its bounds; else a :class:`~flextop.errors.DesignError` naming
        the first that is not."""
        try:
            xv = np.asarray(x, dtype=float)
        except (TypeError, ValueError):
            raise DesignError(f"x must be a vector of {self.n} real numbers, got {type(x).__name__}") from None
        if xv.shape != (self.n,):
            raise DesignError(f"x must be a vector of {self.n} real numbers, one per design variable, got shape {xv.shape}")
        outside = np.flatnonzero(~((self.lower <= xv) & (xv <= self.upper)))
        if outside.size:
            i = outside[0]
            raise DesignError(f"x[{i}] = {xv[i]:g} is outside its bounds [{self.lower[i]:g}, {self.upper[i]:g}]")
        return xv

    @abstractmethod
    def evaluate(self, x: np.ndarray) -> Evaluation:
        """Objective, constraints and their gradients at x (may raise EvaluationError)."""

    def trial(self, x: np.ndarray) -> Trial:
        """The values at ``x`` for an optimizer that may reject it, the gradients made when
        it keeps it (:class:`Trial`). The default evaluates everything at once; a problem
        whose gradients cost extra overrides it."""
        return Trial.of(self.evaluate(x))

    accepts_trials: ClassVar[bool] = False
    """Whether :meth:`accept` takes the :class:`Trial` a method kept, and makes its gradients
    only if it keeps its evaluation (a problem held to a tolerance replaces it where it
    measures the design); otherwise the optimizer makes them before."""

    def accept(self, x: np.ndarray, evaluation: Evaluation) -> Evaluation:
        """Called once per iteration with the design the optimizer moves to and its
        evaluation; returns the evaluation the next iteration builds on. A problem whose
        functions adapt between iterations (the normalization of a stress limit, the grid
        of a problem held to a tolerance) changes here, and only here, so that every
        iteration sees fixed functions; it may raise :class:`EvaluationError`, which the
        optimizer recovers from as from one in :meth:`evaluate`. The default changes
        nothing."""
        return evaluation

    def conclude(self, x: np.ndarray, evaluation: Evaluation) -> Evaluation:
        """Called once, as a run ends, with the design it returns and that design's
        evaluation; returns the evaluation the result reports. A problem whose model was
        held while the optimizer travelled (a grid held to a tolerance since a design
        nearby was measured) measures the returned design here, so that what the result
        reports meets the tolerance at that design; it may raise
        :class:`EvaluationError`. The default changes nothing."""
        return evaluation

    def physical(self, evaluation: Evaluation) -> tuple[float, np.ndarray, np.ndarray]:
        """The objective, the constrained quantities and the objective's gradient in the
        problem's own units, from an evaluation as the optimizer sees it (scaled). Here
        they are the same; problems that scale (such as ``f/f_ref`` and ``r/b − 1``)
        undo it."""
        return evaluation.f0, evaluation.g, evaluation.df0


class FunctionProblem(Problem):
    """A :class:`Problem` built from plain callables.

    ``objective(x) -> (f0, df0)`` and ``constraints(x) -> (g, dg)`` return
    values together with gradients (``dg`` of shape (m, n)). ``m`` is the
    number of constraints; use ``constraints=None`` and ``m=0`` for a purely
    box-constrained problem.
    """

    def __init__(self, objective: Callable, constraints: Callable | None,
                 lower: Sequence[float], upper: Sequence[float], m: int,
                 names: Sequence[str] | None = None):
        super().__init__(lower, upper, m, names)
        if constraints is None and self.m != 0:
            raise ValueError("constraints callable is required when m > 0")
        self.objective = objective
        self.constraints = constraints

    def evaluate(self, x: np.ndarray) -> Evaluation:
        f0, df0 = self.objective(x)
        if self.constraints is None:
            return Evaluation(f0, np.zeros(0), df0, np.zeros((0, self.n)))
        g, dg = self.constraints(x)
        return Evaluation(f0, g, df0, dg)
