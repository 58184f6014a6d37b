"""The tolerance rule of an optimization: where a problem held to ``rtol`` measures its error.

The model changes only between iterations, in :meth:`~flextop.optimizers.Problem.accept`:
a design the optimizer accepts that has moved by more than ``readapt`` (in any variable)
from the design measured last is measured — its error estimated, its grid refined until it
meets ``rtol`` from the discretization held, so that refinement and steps only grow — and
its evaluation replaced by the one on that grid (the measurement reads the kept trial's runs
where a candidate is the grid held, and the trial's gradients are not made). Every other evaluation (an iteration's
trial, MMA's inner iterations) runs on the grid held
(:class:`~flextop.discretization.refinement.Held`): a trial the optimizer may reject
reads the values, and the gradients are made, by the adjoint about the same runs, only
for the design it keeps. The design a run returns is measured as it ends
(:meth:`~flextop.optimizers.Problem.conclude`) unless it is the design measured last, so
that the values reported meet the tolerance there, not only near it (``optimize`` and
:func:`flextop.interop.scipy.minimize` call it). A caller that never calls ``accept``
(the scipy and OpenMDAO adapters) has an evaluation measured where it moved by more than
``readapt``; one that never calls ``conclude`` either (``scipy.optimize.minimize`` given
:func:`~flextop.interop.scipy.arguments`, OpenMDAO) may end on a design within
``readapt`` of the one measured last. :class:`~flextop.TopologyProblem`, :class:`~flextop.ScenarioProblem`,
:class:`~flextop.problems.SpatialProblem` and :class:`~flextop.problems.SizingProblem` (on its design scaled to
its bounds) follow it.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from ..errors import SettingsError

READAPT = 0.1
"""The design change (largest in any variable) after which a problem with a tolerance
measures an accepted design's error again: MMA moves the arm's densities by up to 0.2 per
iteration (its move limit) while it travels and by 5e-4 in its last iteration (the
tip-deflection optimization from x = 0.4), so its travels are measured and its convergence
runs on the grid measured nearby. From the one-element optimum at rtol 1e-2 it measured 9
of 40 accepted designs (0.3: 5, in 8 % less time)."""


class Readapt:
    """Where the error is measured: ``readapt``, the design measured last (``at``) and
    whether the optimizer calls ``accept`` (``accepts``)."""

    def __init__(self, readapt: float = READAPT) -> None:
        if not (isinstance(readapt, (int, float)) and 0.0 <= readapt <= 1.0):
            raise SettingsError(f"readapt must be a design change in [0, 1], got {readapt!r}")
        self.readapt = float(readapt)
        self.at: np.ndarray | None = None
        self.accepts = False

    def near(self, x: np.ndarray) -> bool:
        """Whether ``x`` is within ``readapt`` of the design measured last."""
        return self.at is not None and float(np.max(np.abs(np.asarray(x, float) - self.at), initial=0.0)) <= self.readapt

    def in_evaluate(self, x: np.ndarray, held: bool) -> bool:
        """Whether an evaluation at ``x`` measures: no grid is ``held`` yet, or the caller
        never accepts and ``x`` moved."""
        return not held or (not self.accepts and not self.near(x))

    def in_accept(self, x: np.ndarray) -> bool:
        """Whether the design ``x`` the optimizer accepts is measured: it moved."""
        self.accepts = True
        return not self.near(x)

    def in_conclude(self, x: np.ndarray) -> bool:
        """Whether the design ``x`` a run returns is measured: an error was measured before
        (a grid is held), at another design."""
        return self.at is not None and not np.array_equal(self.at, np.asarray(x, dtype=float))

    def measured(self, x: np.ndarray) -> None:
        """``x``'s error was measured: the next designs are judged against it."""
        self.at = np.array(x, dtype=float)

    def to_dict(self) -> dict[str, Any]:
        return {"readapt": self.readapt, "measured_at": None if self.at is None else self.at.tolist(), "accepts": self.accepts}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Readapt:
        rule = cls(data.get("readapt", READAPT))
        if data.get("measured_at") is not None:
            rule.at = np.array(data["measured_at"], dtype=float)
        rule.accepts = bool(data.get("accepts", False))
        return rule
