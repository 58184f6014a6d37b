"""The outer loop shared by all methods: :func:`optimize`.

Each iteration asks the method for one step (approximate, solve the convex
subproblem, evaluate the new design), records it with its KKT residual
(:mod:`.kkt`), and checks the stopping rules. The KKT residual says a run
converged, and for a fixed-point method (OC, :attr:`Method.fixed_point`) so does its
own residual, the design change, below ``xtol`` where the move limit held no variable.
Otherwise a small step or a small change of the objective does not (MMA's steps are
small wherever its asymptotes are close, converged or not), so ``xtol`` and ``ftol``,
when given, stop a run as stalled, unconverged. If the problem cannot
be evaluated at a proposed design (:class:`EvaluationError`), the loop stays at
the last good design, halves the move limit and tries again, up to
``max_retries`` consecutive times. A run that ends at its iteration limit, or on repeated
failures, returns the best feasible design it saw where its last is infeasible or worse.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from enum import IntEnum
from time import perf_counter
from typing import TypeVar

import numpy as np

from ..checks import number, whole
from ..errors import DesignError, SettingsError
from .conlin import Conlin
from .kkt import kkt_estimate
from .method import Method
from .mma import GCMMA, MMA
from .oc import OptimalityCriteria
from .problem import Evaluation, EvaluationError, Problem, Trial
from .state import Design, IterationRecord, OptimizerState

T = TypeVar("T")

METHODS: dict[str, type[Method]] = {"mma": MMA, "gcmma": GCMMA, "conlin": Conlin, "oc": OptimalityCriteria}


class Status(IntEnum):
    """Why :func:`optimize` stopped."""

    KKT = 0                #: converged: KKT residual below kkt_tol at a feasible design
    XTOL = 1               #: stalled: design change below xtol, KKT residual above kkt_tol
    FTOL = 2               #: stalled: relative objective change below ftol, KKT residual above kkt_tol
    MAX_ITER = 3           #: iteration budget used up
    CALLBACK = 4           #: the callback returned True
    EVALUATION_FAILED = 5  #: evaluation failed more than max_retries times in a row
    UNCONFIRMED = 6        #: a KKT point on the model held, not on the one measured at the returned design (or not measured)
    FIXED_POINT = 7        #: converged (a fixed-point method, OC): design change below xtol, the move limit holding no variable, at a feasible design


CONVERGED = (Status.KKT, Status.FIXED_POINT)  # the stops that are a success; XTOL and FTOL are stalls


@dataclass
class OptimizeResult:
    """Outcome of :func:`optimize` (fields named as in scipy where they exist).

    ``x``: the returned design. In the problem's own units (:meth:`Problem.physical`; for a
    :class:`~flextop.TopologyProblem`, the response in its unit and the constrained
    responses beside their bounds): ``fun``, the objective; ``constr``, the constrained
    quantities; ``jac``, the objective's gradient. As the optimizer saw them:
    ``fun_scaled`` (``f0``) and ``constr_scaled`` (``g``, feasible when ≤ 0). ``kkt`` and
    ``multipliers``: the KKT residual at ``x`` and the multipliers that give it, of the
    scaled problem (:func:`~flextop.optimizers.kkt.kkt_estimate`); ``nit``: iterations; ``nfev``:
    calls of ``evaluate``; ``history``: one :class:`IterationRecord` per iteration, the
    start design's first (iteration 0), each with the KKT residual of its design.

    ``status`` says why the run stopped (:class:`Status`) and ``message`` in words, with
    the KKT residual and ``kkt_tol``, any evaluation failures recovered and whether the
    design is infeasible. At the iteration limit (MAX_ITER) ``x`` is the last iterate, or
    the best feasible design seen where the last iterate is infeasible or has a larger
    objective: the message then names its iteration and both objectives. ``success`` is True only when the KKT residual of ``x`` is below
    ``kkt_tol`` and ``x`` is feasible (status KKT), or when a fixed-point method's update
    (OC) changed the feasible ``x`` by less than ``xtol`` with no variable at its move limit
    (status FIXED_POINT): False after a small step of another method or a small objective
    change (XTOL, FTOL), at the iteration limit, after repeated evaluation failures (the
    best feasible design is then returned), when the callback stopped the run unless
    ``x`` is a KKT point, and where a problem that held its model (a grid held to a
    tolerance) measured the returned design as the run ended (:meth:`Problem.conclude`)
    and found no KKT point there (for FIXED_POINT: an infeasible one), or could not measure
    it (status UNCONFIRMED); the values
    and gradients reported are that measurement's where it was made. ``state``: the final state, to resume with
    ``optimize(..., state=result.state)``.
    """

    x: np.ndarray
    fun: float
    constr: np.ndarray
    jac: np.ndarray
    fun_scaled: float
    constr_scaled: np.ndarray
    kkt: float
    multipliers: np.ndarray
    nit: int
    nfev: int
    status: Status
    message: str
    success: bool
    history: list[IterationRecord] = field(repr=False)
    state: OptimizerState | None = field(repr=False)


class _CountingEvaluator:
    """problem.evaluate (and problem.trial) with call count, accumulated wall time and
    checks: a trial counts as an evaluation, and its gradients' time as evaluation time.

    A result with NaN or infinite entries is turned into an EvaluationError,
    wrongly shaped results into a ValueError.
    """

    def __init__(self, problem: Problem, calls: int):
        self.problem = problem
        self.calls = calls
        self.time = 0.0

    def __call__(self, x: np.ndarray) -> Evaluation:
        return self.trial(x, whole=True).evaluation()

    def trial(self, x: np.ndarray, whole: bool = False) -> Trial:
        """The problem's :meth:`~Problem.trial` at ``x`` (its ``evaluate``, ``whole``, or
        for a problem without ``trial``), checked, its gradients timed and checked when
        made."""
        self.calls += 1
        make = getattr(self.problem, "trial", None)
        trial = self._timed(lambda: Trial.of(self.problem.evaluate(x.copy())) if whole or make is None else make(x.copy()))
        if trial.g.shape != (self.problem.m,):
            raise ValueError(f"evaluate returned g of shape {trial.g.shape}; expected ({self.problem.m},)")
        if not (np.isfinite(trial.f0) and np.isfinite(trial.g).all()):
            raise EvaluationError("evaluation returned non-finite values", x)
        return Trial(trial.f0, trial.g, lambda: self._checked(x, self._timed(trial.evaluation)))

    def _timed(self, make: Callable[[], T]) -> T:
        start = perf_counter()
        try:
            return make()
        finally:
            self.time += perf_counter() - start

    def _checked(self, x: np.ndarray, evaluation: Evaluation) -> Evaluation:
        if evaluation.g.shape != (self.problem.m,) or evaluation.df0.shape != (self.problem.n,):
            raise ValueError(f"evaluate returned g of shape {evaluation.g.shape} and df0 of shape "
                             f"{evaluation.df0.shape}; expected ({self.problem.m},) and ({self.problem.n},)")
        if not evaluation.is_finite():
            raise EvaluationError("evaluation returned non-finite values", x)
        return evaluation


def _check_settings(*, move: float, kkt_tol: float, xtol: float | None, ftol: float | None, feas_tol: float,
                    max_iter: int, max_retries: int) -> None:
    """The settings of :func:`optimize` in their ranges: each refusal a SettingsError that
    names the setting and its range (a tolerance of 0 never stops a run: it runs to
    ``max_iter``)."""
    number("move", move, 0.0, 1.0, "(]")
    for name, value in (("kkt_tol", kkt_tol), ("xtol", xtol), ("ftol", ftol), ("feas_tol", feas_tol)):
        if value is not None:
            number(name, value, 0.0, math.inf, "[)")
    whole("max_iter", max_iter, 0)
    whole("max_retries", max_retries, 0)


def _resolve_method(method: str | Method) -> Method:
    if isinstance(method, Method):
        return method
    try:
        return METHODS[method.lower()]()
    except KeyError:
        raise SettingsError(f"unknown method {method!r}; choose from {sorted(METHODS)}") from None


def _is_feasible(g: np.ndarray, feas_tol: float) -> bool:
    return bool(np.max(g, initial=-np.inf) <= feas_tol)


def _best_design(best: Design | None, state: OptimizerState, feas_tol: float) -> Design | None:
    """The better of ``best`` and the current design of ``state`` (feasible ones only)."""
    evaluation = state.evaluation
    if not _is_feasible(evaluation.g, feas_tol) or (best is not None and best.f0 <= evaluation.f0):
        return best
    return Design(state.x, evaluation, state.kkt, state.multipliers, state.iteration)


def _better_than_last(state: OptimizerState, feas_tol: float) -> Design | None:
    """The best feasible design seen (``state.best``) where the last iterate is infeasible
    or has a larger objective; ``None`` where the last iterate is that design."""
    best, last = state.best, state.evaluation
    if best is None or best.iteration == state.iteration:
        return None
    return best if not _is_feasible(last.g, feas_tol) or best.f0 < last.f0 else None


def _start(problem: Problem, x0) -> np.ndarray:
    """The start design: one number for every variable or one per variable, finite, clipped
    to the bounds."""
    try:
        x = np.asarray(x0, dtype=float)
    except (TypeError, ValueError):
        raise DesignError(f"x0 must be numbers, got {type(x0).__name__}") from None
    x = np.full(problem.n, float(x)) if x.ndim == 0 else x
    if x.shape != (problem.n,) or not np.all(np.isfinite(x)):
        raise DesignError(f"x0 must be one finite number or {problem.n}, got shape {x.shape}")
    return np.clip(x, problem.lower, problem.upper)


def _accept(problem: Problem, x: np.ndarray, made: Evaluation | Trial) -> Evaluation:
    """:meth:`Problem.accept` of the evaluation ``made`` (a kept :class:`Trial`'s gradients
    made first, unless the problem ``accepts_trials``), or the evaluation as it is for a
    problem without it."""
    accept = getattr(problem, "accept", None)
    if accept is not None and getattr(problem, "accepts_trials", False):
        return accept(x, made)
    evaluation = made.evaluation() if isinstance(made, Trial) else made
    return evaluation if accept is None else accept(x, evaluation)


def _initial_state(problem: Problem, x: np.ndarray, method: Method, move: float,
                   evaluate: _CountingEvaluator, feas_tol: float) -> OptimizerState:
    """Evaluate the start design; multipliers start at zero."""
    evaluation = _accept(problem, x, evaluate(x))
    multipliers = np.zeros(problem.m)
    kkt = kkt_estimate(x, evaluation, problem.lower, problem.upper)[0]
    start = IterationRecord(iteration=0, f0=evaluation.f0, g=evaluation.g, change=0.0, kkt=kkt, move=move,
                            evaluations=evaluate.calls, eval_time=evaluate.time, solve_time=0.0)
    state = OptimizerState(method.name, 0, x, evaluation, multipliers, kkt, move, nfev=evaluate.calls, history=(start,))
    return replace(state, best=_best_design(None, state, feas_tol))


def _iterate(problem: Problem, method: Method, state: OptimizerState,
             evaluate: _CountingEvaluator, max_retries: int,
             feas_tol: float) -> tuple[OptimizerState, bool]:
    """One outer iteration; returns the new state and whether it succeeded.

    On EvaluationError, from ``evaluate`` or from the problem's ``accept`` (a problem
    held to a tolerance measures the accepted design there): keep x, halve the move limit,
    retry; give up (return False) after more than ``max_retries`` consecutive failures.
    The time ``accept`` takes counts as evaluation time.
    """
    calls, eval_time, start = evaluate.calls, evaluate.time, perf_counter()
    accepting = 0.0
    while True:
        try:
            step = method.step(problem, state, state.move, evaluate)
            before, evaluating = perf_counter(), evaluate.time
            try:
                evaluation = _accept(problem, step.x, step.evaluation)
            finally:  # a kept trial's gradients made in there are the evaluator's time already
                accepting += perf_counter() - before - (evaluate.time - evaluating)
            break
        except EvaluationError as error:
            state = replace(state, move=0.5 * state.move, nfev=evaluate.calls,
                            failures=state.failures + 1,
                            consecutive_failures=state.consecutive_failures + 1,
                            last_error=str(error))
            if state.consecutive_failures > max_retries:
                return state, False
    eval_time = evaluate.time - eval_time + accepting
    solve_time = perf_counter() - start - eval_time
    kkt = kkt_estimate(step.x, evaluation, problem.lower, problem.upper, step.multipliers)[0]
    record = IterationRecord(
        iteration=state.iteration + 1, f0=evaluation.f0, g=evaluation.g,
        change=float(np.max(np.abs(step.x - state.x) / (problem.upper - problem.lower))),
        kkt=kkt, move=state.move, evaluations=evaluate.calls - calls,
        eval_time=eval_time, solve_time=solve_time)
    state = replace(
        state, iteration=record.iteration, x=step.x, evaluation=evaluation,
        multipliers=step.multipliers, kkt=kkt, x_prev1=state.x, x_prev2=state.x_prev1,
        method_data=step.method_data,
        nfev=evaluate.calls, consecutive_failures=0, history=state.history + (record,))
    return replace(state, best=_best_design(state.best, state, feas_tol)), True


def _is_kkt_point(state: OptimizerState, kkt_tol: float, feas_tol: float) -> bool:
    """Whether the current design is converged: KKT residual below kkt_tol, feasible."""
    return state.kkt < kkt_tol and _is_feasible(state.evaluation.g, feas_tol)


def _stopped(state: OptimizerState, method: Method, kkt_tol: float, feas_tol: float, xtol: float | None,
             ftol: float | None) -> Status | None:
    """Stopping test after an iteration: converged (KKT; FIXED_POINT, :func:`_is_fixed_point`),
    or stalled on a design change below xtol or an objective change below ftol (not
    converged)."""
    if _is_kkt_point(state, kkt_tol, feas_tol):
        return Status.KKT
    record = state.history[-1]
    if xtol is not None and record.change < xtol:
        return Status.FIXED_POINT if _is_fixed_point(state, method, feas_tol) else Status.XTOL
    if ftol is not None and len(state.history) > 1:
        previous = state.history[-2].f0
        if abs(record.f0 - previous) <= ftol * max(1.0, abs(record.f0)):
            return Status.FTOL
    return None


def _is_fixed_point(state: OptimizerState, method: Method, feas_tol: float) -> bool:
    """Whether a fixed-point method's last change is its residual: the move limit held no
    variable (a variable it holds changes by the whole limit, so a change under half of it
    says none was held) and the design is feasible."""
    record = state.history[-1]
    return method.fixed_point and record.change < 0.5 * record.move and _is_feasible(state.evaluation.g, feas_tol)


def _stop_message(state: OptimizerState, status: Status, max_iter: int, max_retries: int,
                  tolerances: dict[str, float | None]) -> str:
    """Human-readable reason for stopping (without the remarks added by _result)."""
    if status is Status.EVALUATION_FAILED:
        return (f"evaluation failed {state.consecutive_failures} consecutive times "
                f"(max_retries={max_retries}), last error: {state.last_error}")
    if status is Status.MAX_ITER:
        return f"maximum number of iterations ({max_iter}) reached"
    if status is Status.CALLBACK:
        return "stopped by callback"
    if status is Status.KKT:
        return "converged"
    record = state.history[-1]
    if status is Status.FIXED_POINT:
        return (f"converged: the update's max design change {record.change:.3g} below xtol = {tolerances['xtol']:g}, "
                f"no variable at its move limit")
    if status is Status.XTOL:
        return f"stalled: max design change {record.change:.3g} below xtol = {tolerances['xtol']:g}"
    return f"stalled: relative objective change below ftol = {tolerances['ftol']:g}"


def _optimality(kkt: float, kkt_tol: float) -> str:
    """The KKT residual beside its tolerance, in words."""
    relation = "below" if kkt < kkt_tol else "not below"
    return f"KKT residual {kkt:.3g} {relation} kkt_tol = {kkt_tol:g}"


def _result(problem: Problem, state: OptimizerState, status: Status, message: str, kkt_tol: float,
            feas_tol: float) -> OptimizeResult:
    """Assemble the result; after evaluation failures, and at the iteration limit where the
    last iterate is infeasible or worse, return the best feasible design seen, and say so.
    The returned design's evaluation is the one the problem concludes (:func:`_concluded`);
    the KKT residual and multipliers are those of that evaluation; success only if it is a
    KKT point there, or, for a fixed point of OC's update, feasible there. The state keeps
    the concluded evaluation, so that a resume builds on it."""
    x, evaluation, lam, remarks = state.x, state.evaluation, state.multipliers, ""
    if status is Status.EVALUATION_FAILED:
        if state.best is not None:
            best = state.best
            x, evaluation, lam = best.x, best.evaluation, best.multipliers
            remarks += f"; returning the best feasible design (iteration {best.iteration})"
        else:
            remarks += ("; no feasible design was found, returning the last successfully "
                        f"evaluated design (iteration {state.iteration})")
    elif state.failures:
        remarks += (f" ({state.failures} evaluation failure(s) recovered by halving the move "
                    f"limit, now {state.move:g}; last error: {state.last_error})")
    if status is Status.MAX_ITER and (best := _better_than_last(state, feas_tol)) is not None:
        x, evaluation, lam = best.x, best.evaluation, best.multipliers
        last = "infeasible" if not _is_feasible(state.evaluation.g, feas_tol) else f"f0 = {state.evaluation.f0:.6g}"
        remarks += (f"; returning the best feasible design, iteration {best.iteration}'s (f0 = {best.f0:.6g}; "
                    f"the last, iteration {state.iteration}: {last})")
    evaluation, unmeasured = _concluded(problem, x, evaluation)
    kkt, lam = kkt_estimate(x, evaluation, problem.lower, problem.upper, lam)
    g = evaluation.g
    feasible = _is_feasible(g, feas_tol)
    if status is Status.KKT and (unmeasured or not (kkt < kkt_tol and feasible)):
        status, message = Status.UNCONFIRMED, "a KKT point on the model held, not on the one measured at the returned design"
    if status is Status.FIXED_POINT and (unmeasured or not feasible):
        status, message = Status.UNCONFIRMED, "a fixed point on the model held, not feasible on the one measured at the returned design"
    message += remarks + unmeasured + f": {_optimality(kkt, kkt_tol)}"
    if x is state.x:
        state = replace(state, evaluation=evaluation, kkt=kkt)
    if not feasible:
        message += f"; the design is infeasible (max g = {np.max(g):.3g})"
    fun, constr, jac = problem.physical(evaluation)
    return OptimizeResult(x=x, fun=float(fun), constr=np.asarray(constr, dtype=float), jac=np.asarray(jac, dtype=float),
                          fun_scaled=evaluation.f0, constr_scaled=g, kkt=kkt, multipliers=lam, nit=state.iteration,
                          nfev=state.nfev, status=status, message=message,
                          success=status in CONVERGED,
                          history=list(state.history), state=state)


def _concluded(problem: Problem, x: np.ndarray, evaluation: Evaluation) -> tuple[Evaluation, str]:
    """The returned design's evaluation as the problem concludes it (:meth:`Problem.conclude`:
    measured where its model was held since a design nearby), or, where that measurement
    fails, the evaluation as it was and a remark that says so."""
    conclude = getattr(problem, "conclude", None)
    if conclude is None:
        return evaluation, ""
    try:
        concluded = conclude(x, evaluation)
    except EvaluationError as error:
        return evaluation, f"; the returned design could not be measured ({error}): its values are the model's held"
    if not concluded.is_finite():
        return evaluation, "; the returned design's measurement gave non-finite values: its values are the model's held"
    return concluded, ""


def _failed_start(problem: Problem, x0: np.ndarray, error: EvaluationError, nfev: int) -> OptimizeResult:
    """Result when not even the start design could be evaluated."""
    return OptimizeResult(
        x=x0, fun=float("nan"), constr=np.full(problem.m, np.nan),
        jac=np.full(problem.n, np.nan), fun_scaled=float("nan"), constr_scaled=np.full(problem.m, np.nan),
        kkt=float("nan"), multipliers=np.zeros(problem.m), nit=0, nfev=nfev,
        status=Status.EVALUATION_FAILED, success=False, history=[], state=None,
        message=f"evaluation of the start design failed: {error}")


def optimize(problem: Problem, x0=None, method: str | Method = "mma", *,
             max_iter: int = 100, move: float = 0.2, kkt_tol: float = 1e-6,
             xtol: float | None = None, ftol: float | None = None, feas_tol: float = 1e-6,
             max_retries: int = 3, callback: Callable[[IterationRecord], bool | None] | None = None,
             state: OptimizerState | None = None) -> OptimizeResult:
    """Minimize f0(x) s.t. g(x) <= 0, lower <= x <= upper by sequential convex programming.

    Parameters
    ----------
    problem : Problem
        Gives n, m, bounds and ``evaluate(x) -> Evaluation``.
    x0 : array (n,) or one number
        Start design (clipped to the bounds; one number for every variable); ignored when
        resuming.
    method : "mma", "gcmma", "conlin", "oc" or a configured :class:`Method`
        (e.g. ``MMA(asyincr=1.1)``).
    max_iter : total number of outer iterations, including those done before a resume.
    move : largest step per iteration as a fraction of upper - lower, in (0, 1].
    kkt_tol : converged, and stop, when the KKT residual (:mod:`.kkt`: the projected
        gradient of the Lagrangian with the objective divided by max(1, |f0|),
        complementarity and infeasibility) falls below it at a feasible design; the one
        stop that is a success for every method (OC's FIXED_POINT under ``xtol`` is the
        other). Default 1e-6.
    xtol : if given, stop when max_i |x_i^k - x_i^{k-1}| / (upper_i - lower_i) falls below
        it: converged (FIXED_POINT) for a fixed-point method (OC: the change is its optimality
        residual; the 88-line code stops at 0.01) at a feasible design where the move limit
        held no variable, stalled (not converged, unless the KKT test holds) otherwise. Off
        by default: MMA takes small steps wherever its asymptotes are close, far from an
        optimum too.
    ftol : if given, stop as stalled when |f0^k - f0^{k-1}| <= ftol max(1, |f0^k|).
    feas_tol : a design is feasible when max(g) <= feas_tol (≥ 0).
    max_retries : consecutive evaluation failures tolerated; each one halves the move limit.
    callback : called after every iteration with its :class:`IterationRecord`, whose
        ``state`` attribute is a checkpoint (``record.state.to_dict()``); return True to stop.
    state : an :class:`OptimizerState` to resume from (then the state's move limit is used).
    """
    _check_settings(move=move, kkt_tol=kkt_tol, xtol=xtol, ftol=ftol, feas_tol=feas_tol, max_iter=max_iter,
                    max_retries=max_retries)
    method = _resolve_method(method)
    method.check(problem)
    evaluate = _CountingEvaluator(problem, calls=0 if state is None else state.nfev)
    if state is None:
        if x0 is None:
            raise DesignError("x0 is required unless a state is given")
        x = _start(problem, x0)
        try:
            state = _initial_state(problem, x, method, move, evaluate, feas_tol)
        except EvaluationError as error:
            return _failed_start(problem, x, error, evaluate.calls)
    elif state.method != method.name or state.x.shape != (problem.n,):
        raise SettingsError(f"state of a {state.method} run with n = {state.x.size} does not fit "
                         f"method {method.name} with n = {problem.n}")
    tolerances = {"kkt_tol": kkt_tol, "xtol": xtol, "ftol": ftol}
    status = Status.KKT if _is_kkt_point(state, kkt_tol, feas_tol) else None
    while status is None:
        if state.iteration >= max_iter:
            status = Status.MAX_ITER
            break
        state, succeeded = _iterate(problem, method, state, evaluate, max_retries, feas_tol)
        if not succeeded:
            status = Status.EVALUATION_FAILED
            break
        status = _stopped(state, method, kkt_tol, feas_tol, xtol, ftol)
        if callback is not None and callback(replace(state.history[-1], state=state)) and status is None:
            status = Status.CALLBACK
    message = _stop_message(state, status, max_iter, max_retries, tolerances)
    return _result(problem, state, status, message, kkt_tol, feas_tol)
