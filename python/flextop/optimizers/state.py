"""Serializable optimizer state and per-iteration records.

Everything the next iteration depends on lives in :class:`OptimizerState`,
so a run checkpointed with ``state.to_dict()`` (JSON-able) and resumed with
``optimize(..., state=OptimizerState.from_dict(d))`` continues exactly as
if it had never stopped. States are never modified in place: the driver
makes a new one every iteration, so a state handed to a callback is a safe
snapshot.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields

import numpy as np

from .problem import Evaluation


def _array_or_none(value) -> np.ndarray | None:
    return None if value is None else np.array(value, dtype=float)


def _list_or_none(value: np.ndarray | None) -> list | None:
    return None if value is None else value.tolist()


@dataclass
class IterationRecord:
    """What happened in one outer iteration.

    ``change`` is max_i |x_i^k - x_i^{k-1}| / (upper_i - lower_i); ``kkt`` the
    KKT residual of the problem at x^k (:mod:`.kkt`); ``move`` the move limit used;
    ``evaluations`` the calls of ``evaluate`` (GCMMA inner iterations and failed
    attempts included); ``eval_time`` and ``solve_time`` the wall-clock seconds
    spent in ``evaluate`` and in building/solving subproblems. ``state`` is set
    only on the record passed to the callback: the state after this iteration.
    """

    iteration: int
    f0: float
    g: np.ndarray
    change: float
    kkt: float
    move: float
    evaluations: int
    eval_time: float
    solve_time: float
    state: OptimizerState | None = field(default=None, repr=False, compare=False)

    def to_dict(self) -> dict:
        """Plain-Python form (without ``state``)."""
        data = {f.name: getattr(self, f.name) for f in fields(self) if f.name != "state"}
        data["g"] = self.g.tolist()
        return data

    @classmethod
    def from_dict(cls, data: dict) -> IterationRecord:
        """Inverse of :meth:`to_dict`."""
        return cls(**{**data, "g": np.array(data["g"], dtype=float)})


@dataclass(frozen=True)
class Design:
    """A feasible evaluated design remembered as the best so far."""

    x: np.ndarray
    evaluation: Evaluation
    kkt: float
    multipliers: np.ndarray
    iteration: int

    @property
    def f0(self) -> float:
        return self.evaluation.f0

    def to_dict(self) -> dict:
        return {"x": self.x.tolist(), "evaluation": self.evaluation.to_dict(), "kkt": self.kkt,
                "multipliers": self.multipliers.tolist(), "iteration": self.iteration}

    @classmethod
    def from_dict(cls, data: dict) -> Design:
        return cls(np.array(data["x"], dtype=float), Evaluation.from_dict(data["evaluation"]), data["kkt"],
                   np.array(data["multipliers"], dtype=float), data["iteration"])


@dataclass(frozen=True)
class OptimizerState:
    """Complete state of an optimization run after ``iteration`` outer iterations.

    ``x``/``evaluation``: current design and its evaluation; ``multipliers``:
    subproblem multipliers that produced it (zeros at the start); ``kkt``: KKT
    residual at x; ``move``: current move limit (halved after evaluation
    failures); ``x_prev1``, ``x_prev2``: x^{k-1}, x^{k-2}; ``method_data``:
    what the method carries from one iteration to the next (MMA: the
    asymptotes L, U; CONLIN: the adaptive move limits); ``best``: best
    feasible design so far; ``nfev``: evaluate calls; ``failures``:
    evaluation failures in total, ``consecutive_failures`` since the last
    success, ``last_error`` the message of the last one; ``history``: one
    record per iteration, the start design's first (iteration 0).
    """

    method: str
    iteration: int
    x: np.ndarray
    evaluation: Evaluation
    multipliers: np.ndarray
    kkt: float
    move: float
    x_prev1: np.ndarray | None = None
    x_prev2: np.ndarray | None = None
    method_data: dict[str, np.ndarray] = field(default_factory=dict)
    best: Design | None = None
    nfev: int = 0
    failures: int = 0
    consecutive_failures: int = 0
    last_error: str = ""
    history: tuple[IterationRecord, ...] = ()

    _ARRAYS = ("x", "multipliers", "x_prev1", "x_prev2")

    def to_dict(self) -> dict:
        """Plain-Python form; ``json.dumps`` round-trips it exactly."""
        data = {f.name: getattr(self, f.name) for f in fields(self)}
        for name in self._ARRAYS:
            data[name] = _list_or_none(data[name])
        data["method_data"] = {key: value.tolist() for key, value in self.method_data.items()}
        data["evaluation"] = self.evaluation.to_dict()
        data["best"] = None if self.best is None else self.best.to_dict()
        data["history"] = [record.to_dict() for record in self.history]
        return data

    @classmethod
    def from_dict(cls, data: dict) -> OptimizerState:
        """Inverse of :meth:`to_dict`."""
        data = dict(data)
        for name in cls._ARRAYS:
            data[name] = _array_or_none(data[name])
        data["method_data"] = {key: np.array(value, dtype=float)
                               for key, value in data["method_data"].items()}
        data["evaluation"] = Evaluation.from_dict(data["evaluation"])
        data["best"] = None if data["best"] is None else Design.from_dict(data["best"])
        data["history"] = tuple(IterationRecord.from_dict(r) for r in data["history"])
        return cls(**data)
