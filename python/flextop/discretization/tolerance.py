"""Accuracy on demand: the discretization whose responses meet a stated tolerance.

A discretization is a pair: a refinement ``r`` of the scene's meshing (the bars that need
it most get ``r`` times the elements the scene gives them, the others fewer, graded by
each bar's own frequency in :mod:`.indicator`; every bar of a static scene gets ``r``
times) and a uniform number of steps over ``[0, t_end]`` (none for a static scene). Its
error on a response ``f`` is estimated by step doubling in time and in space, from three
companion runs (``2r`` below: twice the elements of *every* bar of ``r``, so that the bars
the grading leaves alone are measured too):

    a = |f(r, h) − f(r, 2h)|,  b = |f(r, 2h) − f(r, 4h)|,  ρ = b / a (the observed contraction)
    e_time  = a / (min(ρ, 4) − 1)                Richardson with the observed order, never
                                                 above generalized-α's second order; 2a
                                                 when ρ < 1.5 or ρ > 6 (not asymptotic)
    e_space = 2 |f(2r, 2h) − f(r, 2h)|           beams converge at least to first order in
                                                 1/m (measured orders 1.1 to 2.8,
                                                 benches/results/material_law.md)

and the run passes when ``e_time + e_space ≤ rtol·|f| + atol`` for every response asked for
(and, when gradients are asked for, ``≤ GRADIENT_FACTOR·rtol·‖∇f‖`` for each gradient, the
same estimates taken on the vectors in the 2-norm). The observed order matters before the
asymptotic range: on the full-density arm, 66 → 132 steps only halves the error, and the
second-order formula would understate it 2.5×.

Below ``CONFIRMED_BELOW`` (rtol 1e-2) a dynamic candidate that passes is confirmed by a
second space companion with four times the elements of every bar: with ``a`` and ``b`` the
changes from ``r`` to ``2r`` and from ``2r`` to ``4r`` (both on 2h), ``e_space = max(2a, a +
2b)``, the same where the convergence is at least first order and first order assumed from
``2r`` on where it is not. A bar near resonance, its own frequency still moving with its
elements, can change d less from ``r`` to ``2r`` than the error it leaves (the arm's last
design of an rtol 1e-3 optimization: 8e-5, 1.1e-3 and 5.4e-3 from 1× to 8×).

Otherwise the steps are multiplied by the power of two that the second-order rate says
brings ``e_time`` under half the budget, and the refinement doubles (twice where the
second order in space asks for it) where ``e_space`` exceeds the other half (on the bars
the grading picks at the new ``r``). A refined candidate's companions reuse the runs already made. The
run that passes is an ordinary fixed-step run on one grid, so its gradients are exact for
the scheme that ran.

The space companion runs on the time companion's steps (2h), where the errors in time and
in space add up as they do at h, and ``f(r, 2h)`` is already there: it costs half of a run
at 2r (about 1.3 runs of the candidate on the x = 0.4 arm, where 2r has six times the unknowns)
instead of a whole one. Over the 22 designs of the benchmark family it gave the same
worst errors and the same worst under-estimate (1.6×) as a companion at h, in 20 % less
time (BENCHMARKS.md, "Tolerances across designs"). (A design whose 230 % gradient error
first went unseen had that error in time, not in space; the distrust of contractions
above 6 is what catches it.)

The companions stop Newton at :func:`companion_newton_tol` (1e-6 rather than the run's
1e-10): they measure differences of order ``rtol``, and the candidate, whose values and
gradients are returned, keeps the run's own tolerance. Over the family both changes kept
every worst error and under-estimate and cut the time of the runs to a tolerance by 43–52 %.
Forward companions also run modified Newton (the step's first factorization kept while
the residual falls tenfold per iteration), and the space companion starts each step's
Newton from the time companion's states carried to twice the elements per bar
(``Prolongation`` in the engine) plus the difference the two runs already have: on the
arm's x = 0.4, full-density, random and optimized designs its time falls by 38–50 %; on
uniformly light designs (x ≤ 0.1), whose refined bars move unlike the coarse ones, it
rises by up to a third. Where a guided or modified companion fails, the plain run decides.

With ``extrapolate`` (runs with gradients), a candidate whose steps divide by 8 is also
judged on Richardson's extrapolation in the step, ``R(h) = (4 f(h) − f(2h))/3``, which
removes generalized-α's h² term. Its own time error comes from the extrapolated values of
three step sizes (:func:`extrapolated_estimate`, runs at 4h and 8h: an eighth of a run
more), its space error is the grid's; where its estimate is the smaller, the candidate is
accepted or refined on it (steps doubled at third order). On the arm's optimized designs R
is 20–600× more accurate than f(h) from 544 steps on (benches/results/richardson.md); before
its asymptotic range the contraction of R is outside ``TRUSTED_EXTRAPOLATION`` and f(h) is
judged alone.

Where the gradients are held and made by the adjoint method, the candidate's own backward
sweep also estimates each value's time error, ``f(h) − f`` to leading order: the steps'
local errors weighted by the adjoint variables (``Simulation.time_errors``, at no measurable
cost beside the sweep). Alone it is not honest before the asymptotic range (on optimized
arm designs at the scene's 68 steps it had the wrong sign); where it agrees with the
half-steps run's ``(f(2h) − f(h))/3`` within :data:`AGREEMENT`, the candidate is judged raw
on it (:func:`agreed_time`) and needs no run at 4h (``time_estimate="doubling"`` keeps step
doubling alone). A candidate refined in space only on steps whose time error took at most
half the budget is first judged on its space companion alone (:func:`_space_over`): if that
is over budget no estimate of the candidate can pass, and its own run is not made.

Step doubling is preferred here to a local error estimator of generalized-α alone because
it measures what the user asks for, the error of a response, including the spatial part and
the effect of ρ∞'s numerical damping. Its cost over the run itself: half a run in the time
companion (the quarter-steps run only when the slowest contraction, 1.5, would fail the
budget), and half a run at twice the elements per bar in space (skipped while the time
error alone is clearly over budget), both with a looser Newton tolerance.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from ..errors import SettingsError, SimulationError, ToleranceError

TIME_ORDER = 2
"""Order of generalized-α in h (Chung & Hulbert), assumed by ``e_time``."""

PEAK_ORDER = 1
"""Order in h assumed for a peak's time error: a peak after a drive's kink converges at
first order (index-3 generalized-α's transient, BENCHMARKS.md "Reactions after a kink"),
and a peak riding on a flexible link's vibration moves with each halving of the step as
the scheme's damping of those modes changes (the slider-crank's hinge force at 800, 1600,
3200 and 6400 steps: 380.1, 382.1, 380.9, 380.1 N), so a faster contraction there is
chance, not convergence."""

SPACE_ORDER = 1
"""Order in 1/m assumed by ``e_space``: the lowest measured, so the estimate errs high."""

GRADIENT_FACTOR = 5.0
"""Gradients are held to ``GRADIENT_FACTOR · rtol`` in the relative 2-norm (and to no
absolute tolerance): an optimizer needs their direction, not their last digit."""

EXTRAPOLATED_ORDER = 3
"""Order in h assumed for the error of the extrapolated value (:func:`richardson`): the h²
term removed, generalized-α's h³ term left. Observed: 3.8 to 4.5 on the arm's optimized
designs (benches/results/richardson.md), so the estimate errs high by up to 2×."""

TRUSTED_EXTRAPOLATION = (3.0, 32.0)
"""Contractions ``|R(2h) − R(4h)| / |R(h) − R(2h)|`` of the extrapolated values between which
the estimate of ``R(h)``'s error is trusted: below, R is not yet in its asymptotic range
(136 steps on an optimized arm: R no better than the raw value); above, ``R(h) − R(2h)``
may have vanished by chance rather than by convergence."""

SLOWEST = 1.5
"""The contraction assumed when the observed one is slower, or faster than 1.5× the
second-order rate (the quarter-steps run is then outside the asymptotic range: on an
optimized design, 17 steps gave twice the d of 34 and 68, a contraction of 24)."""

TIME_ESTIMATES = ("adjoint", "doubling")
"""How a run to a tolerance estimates a candidate's time error: by its adjoint where that
agrees with its half steps (:func:`agreed_time`), or by step doubling alone."""

AGREEMENT = (2.0 / 3.0, 1.5)
"""Ratios of a value's time error estimated by the adjoint of the candidate's run (the
steps' local errors weighted by its adjoint variables: the sweep that makes the gradients
makes it too) to step doubling's second-order reading ``(f(2h) − f(h))/3`` within which the
run is taken to be in its asymptotic range in time. On the arm's 33 designs at 68 to 1088
steps (BENCHMARKS.md, "The time error from the adjoint"), wherever the two agreed so the
adjoint's estimate was 0.78–2.7 of the true error; before the asymptotic range (the scene's
68 steps on an optimized design) it was of the wrong sign on 7 designs and under by more
than 2× on 9, and the two then disagree."""

AGREED_CONTRACTION = 3.0
"""The contraction from 2h to h assumed for a gradient's (and any value's) time error where
the values' estimates agree (:data:`AGREEMENT`): generalized-α's 4 read at the band's
edge, ``4 / (4/3)``, so that ``e = a/2`` — a gradient has no adjoint estimate of its own."""

MIN_RTOL = 1e-6
"""Smallest ``rtol`` accepted: step doubling cannot resolve differences near Newton's
tolerance (1e-10 of the forces) and the round-off of long runs."""

MAX_REFINEMENT = 128
"""Largest factor on a bar's elements in the scene: a soft bar's own modes may need that
many (a 1 m stay at x = 0.1 in a frame of solid 4 cm bars: its gradient within 5 % at
128), and the limit on all the scene's elements bounds the cost."""

MAX_ELEMENTS_FACTOR = 16
"""Largest factor on the scene's number of elements: a candidate's model (its space
companion has twice as many)."""

MAX_STEPS = 1 << 20
"""Most steps a run to a tolerance may take."""

STALLED = 0.5
"""A refinement graded bar by bar that leaves the space error above this share of what it
was has missed where the error is (bars of little need by mass and frequency, such as
void bars whose own gradients the chords' refinement does not touch): from then on the
least factor of every bar doubles (up to the refinement). Judged only on a candidate whose
time error is within half the budget: the space companion runs at twice the step, where a
soft bar's own modes, which its refinement brings into the model, are damped out (the
stayed frame's stay at 16 and 64 elements: a space error of 2.6 and 1.3 budgets at 960
steps, 8.1 and 1.0 at 1920), so a step still too coarse says little about where the
error is."""

UNMOVED = 0.9
"""A raised floor that leaves the space error above this share of what it was has missed
the error as well: the bars that need most are still before their asymptotic range (a
soft bar whose own higher modes come into the band as its elements double, its gradient
changing sign between 4, 8 and 16 elements), so the floor goes back and those bars are
refined further — the refinement, not the floor, even where the floor it goes back to is
above 1 (raising it again went round in a circle: the arm at x = 0.12, floors 2 and 4 at
4×, for ever)."""

CONFIRMED_BELOW = 1e-2
"""``rtol`` below which the space estimate of a dynamic candidate that passes is confirmed
by a second space companion (:func:`_confirmed`). At rtol 1e-2 the arm's family is honest
without it (worst under-estimate 1.65) and it would cost 70 % more work; at 1e-3 three of
its 30 designs under-read by 2.3–14.5× without it (bars near resonance converge
irregularly in their elements), none by more than 1.21 with it (BENCHMARKS.md, "Runs to
rtol 1e-3")."""

MAX_CANDIDATES = 64
"""Most candidates a run to a tolerance judges: every refinement grows the steps, the
refinement or the floor, so the limits above end it well before this; the bound names the
failure should a rule ever go round in a circle again."""

MAX_FAILED_REFINEMENTS = 3
"""Refinements in a row whose runs fail (more steps, or elements, each time) before a run
to a tolerance gives up with the failure."""


@dataclass(frozen=True, order=True)
class Discretization:
    """``refinement``: factor on the elements of the bars that need them most (a dynamic
    scene's bars with the lowest own frequencies, graded down to ``floor`` on the others by
    :mod:`.indicator`; every bar of a static scene); ``steps``: uniform steps over
    ``[0, t_end]``, 0 for a static scene; ``uniform``: a further factor on every bar's
    elements (2 in the space companion); ``floor``: the least factor of any bar (raised
    where the grading missed where the error is)."""

    refinement: int
    steps: int
    uniform: int = 1
    floor: int = 1
    extrapolated: bool = False
    """Whether the values are Richardson's extrapolation ``(4 f(h) − f(2h))/3`` from this
    grid and its half steps rather than this grid's own (:func:`richardson`)."""
    factors: tuple[int, ...] = ()
    """Each bar's factor on its elements where measured shares of the error set them
    (``refine="shares"``, :func:`flextop.discretization.refinement.marks`); empty: graded
    by the a-priori need."""
    unit: str = field(default="bar", compare=False)
    """What the scene's elements are refined per, in the description: ``"bar"``, ``"member
    cell"`` (a continuum member's cells, split along each side) or both; not part of the
    grid's identity."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "factors", tuple(int(f) for f in self.factors))  # a list from a checkpoint

    @property
    def grid(self) -> Discretization:
        """The grid that runs: this discretization without the extrapolation."""
        return replace(self, extrapolated=False)

    @property
    def half_steps(self) -> Discretization:
        """The time companion: half as many steps (a static scene has none to halve)."""
        return replace(self.grid, steps=self.steps // 2)

    @property
    def quarter_steps(self) -> Discretization:
        """The second time companion: a quarter of the steps."""
        return replace(self.grid, steps=self.steps // 4)

    @property
    def eighth_steps(self) -> Discretization:
        """The third time companion, which the extrapolated value's estimate needs: an
        eighth of the steps."""
        return replace(self.grid, steps=self.steps // 8)

    @property
    def split(self) -> Discretization:
        """The space companion: twice the elements of every bar on the time companion's
        steps."""
        return replace(self.grid, steps=self.steps // 2, uniform=2 * self.uniform)

    @property
    def split_twice(self) -> Discretization:
        """The second space companion, which confirms the first: four times the elements of
        every bar on the time companion's steps."""
        return replace(self.grid, steps=self.steps // 2, uniform=4 * self.uniform)

    def __str__(self) -> str:
        steps = f" and {self.steps} steps" if self.steps else ""
        if self.factors:
            refined = sum(f > 1 for f in self.factors)
            every = f", times {self.uniform} on every {self.unit}" if self.uniform != 1 else ""
            extrapolated = ", extrapolated from half the steps" if self.extrapolated else ""
            return (f"up to {max(self.factors)}× the scene's elements on the {refined} of {len(self.factors)} bars that "
                    f"measured shares of the error refined{every}{steps}{extrapolated}")
        most = "up to " if self.refinement > self.floor else ""  # graded: the bars that need them most
        least = f" (at least {self.floor}×)" if 1 < self.floor < self.refinement else ""
        every = f", times {self.uniform} on every {self.unit}" if self.uniform != 1 else ""
        extrapolated = ", extrapolated from half the steps" if self.extrapolated else ""
        return f"{most}{self.refinement}× the scene's elements per {self.unit}{least}{every}{steps}{extrapolated}"


def start(steps: int) -> Discretization:
    """The first candidate of a dynamic scene whose own step gives ``steps`` steps: rounded
    up to a multiple of 4, so that the time companions divide it exactly."""
    return Discretization(1, 4 * max(1, math.ceil(steps / 4)))


@dataclass(frozen=True)
class ErrorEstimate:
    """Estimated errors of quantities — a response (a scalar) or its gradient (a vector,
    measured in the 2-norm) — in their own units, one entry per quantity."""

    size: np.ndarray
    time: np.ndarray
    space: np.ndarray

    @property
    def total(self) -> np.ndarray:
        return self.time + self.space

    @property
    def relative(self) -> np.ndarray:
        """``total / |q|`` (infinite where ``q`` is zero and the error is not)."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(self.total == 0.0, 0.0, self.total / self.size)


Quantities = list[np.ndarray]
"""What a run is judged on: responses (arrays of one value) and gradients (vectors)."""


def estimate(fine: Quantities, half: Quantities | None, quarter: Quantities | None, split: Quantities,
             orders: np.ndarray | None = None) -> ErrorEstimate:
    """The error of ``fine`` from its companions' quantities: ``half`` and ``quarter`` on
    its steps merged in pairs and fours (``None`` for a static scene; ``quarter`` alone
    ``None``: the slowest contraction is assumed), ``split`` on twice the elements per bar;
    ``orders`` the order in h of each quantity's time error (``TIME_ORDER`` if not given)."""
    if half is None:
        time = np.zeros(len(fine))
    else:
        a = _distances(fine, half)
        b = np.zeros_like(a) if quarter is None else _distances(half, quarter)
        with np.errstate(divide="ignore", invalid="ignore"):
            observed = np.where(a == 0.0, np.inf, b / a)
        ceiling = 2.0 ** (TIME_ORDER if orders is None else orders)
        trusted = (observed >= SLOWEST) & (observed <= 1.5 * ceiling)
        time = a / (np.where(trusted, np.minimum(observed, ceiling), SLOWEST) - 1.0)
    space = _distances(split, fine if half is None else half) / (1.0 - 2.0**-SPACE_ORDER)
    return ErrorEstimate(_sizes(fine), time, space)


def richardson(fine: Quantities, half: Quantities) -> Quantities:
    """Richardson's extrapolation in the step, ``R(h) = (4 f(h) − f(2h))/3``: generalized-α's
    h² term removed. A gradient extrapolated so is the exact gradient of the extrapolated
    value, since each run's gradient is exact for its grid."""
    return [(4.0 * f - h) / 3.0 for f, h in zip(fine, half)]


def extrapolated_estimate(fine: Quantities, half: Quantities, quarter: Quantities, eighth: Quantities,
                          space: np.ndarray) -> ErrorEstimate:
    """The error of ``R(h)`` (:func:`richardson`) from the runs at h, 2h, 4h and 8h. In time,
    from the extrapolated values of three step sizes:

        A = |R(h) − R(2h)|,  B = |R(2h) − R(4h)|,  σ = B / A
        e_time = A / (min(σ, 2³) − 1)            infinite where σ is outside TRUSTED_EXTRAPOLATION

    (under an h³ term alone exact, under an h⁴ term alone twice the error); in space
    ``space``, the grid's, which ``f(h)`` and ``f(2h)`` share and R keeps."""
    now, before, earlier = richardson(fine, half), richardson(half, quarter), richardson(quarter, eighth)
    a, b = _distances(now, before), _distances(before, earlier)
    with np.errstate(divide="ignore", invalid="ignore"):
        observed = np.where(a == 0.0, np.inf, b / a)
        low, high = TRUSTED_EXTRAPOLATION
        time = np.where(a == 0.0, 0.0, np.where((observed >= low) & (observed <= high),
                                                a / (np.minimum(observed, 2.0**EXTRAPOLATED_ORDER) - 1.0), np.inf))
    return ErrorEstimate(_sizes(now), time, space)


def agreed_time(fine: Quantities, half: Quantities, adjoint: np.ndarray, orders: np.ndarray) -> np.ndarray | None:
    """The time errors of ``fine`` where the adjoint's estimates ``adjoint`` of its first
    ``len(adjoint)`` quantities (the responses' values) each lie within :data:`AGREEMENT` of
    ``(f(2h) − f(h))/3`` from ``half``; ``None`` where one does not. Then each value's error
    is the larger of its adjoint's and that reading, a gradient's ``a/2`` at
    :data:`AGREED_CONTRACTION` (``a`` the 2-norm of its change from 2h), a first-order
    quantity's (a peak) ``2a`` at the :data:`SLOWEST` contraction: no run at 4h is needed."""
    n = len(adjoint)
    doubled = np.array([(h - f).item() for f, h in zip(fine[:n], half[:n])]) / 3.0
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(doubled == 0.0, np.where(adjoint == 0.0, 1.0, np.inf), adjoint / doubled)
    low, high = AGREEMENT
    if not (np.all(np.isfinite(adjoint)) and np.all((ratio >= low) & (ratio <= high))):
        return None
    a = _distances(fine, half)
    time = a / (np.where(orders >= TIME_ORDER, AGREED_CONTRACTION, SLOWEST) - 1.0)
    time[:n] = np.maximum(np.abs(adjoint), a[:n] / (2.0**TIME_ORDER - 1.0))
    return time


def _distances(p: Quantities, q: Quantities) -> np.ndarray:
    """``|p − q|`` per quantity (the 2-norm of a gradient's difference)."""
    return np.array([np.linalg.norm(x - y) for x, y in zip(p, q)])


def _sizes(quantities: Quantities) -> np.ndarray:
    return np.array([np.linalg.norm(q) for q in quantities])


Values = Callable[[Discretization, bool], Quantities]
"""``values(d, companion)``: the quantities of the run at ``d``, a companion run (whose
Newton iterations may stop at :func:`companion_newton_tol`) or a candidate."""

Adjoint = Callable[[Discretization], "np.ndarray | None"]
"""``adjoint(d)``: the time errors of the responses' values of the candidate ``d`` (made
already) as the adjoint sweep of its run estimated them, ``None`` where no sweep made them
(:func:`agreed_time`)."""


def companion_newton_tol(rtol: float) -> float:
    """Newton's relative tolerance for the companion runs: ``min(1e-6, 1e-4·rtol)``. A
    companion only measures a difference of order ``rtol``; on the x = 0.4 arm Newton at
    1e-6 moves d by 6e-7 relative and saves a quarter of the iterations (3.9 → 3.0 per
    step at 2m). The candidate keeps the run's own tolerance (1e-10): its values and
    gradients are the result."""
    return min(1e-6, 1e-4 * rtol)


@dataclass(frozen=True)
class Tolerance:
    """Per quantity: its name, relative and absolute tolerance, and the order in h its time
    error is estimated at."""

    names: Sequence[str]
    rtol: np.ndarray
    atol: np.ndarray
    orders: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.orders is None:
            object.__setattr__(self, "orders", np.full(len(self.names), float(TIME_ORDER)))

    def budget(self, est: ErrorEstimate) -> np.ndarray:
        return self.rtol * est.size + self.atol


Marks = Callable[[Discretization, bool, np.ndarray], "Discretization | None"]
"""For a candidate whose space error is over budget, given whether the last marking missed
where the error is and each quantity's space error over its budget: the refinement of the
next candidate (its steps aside), from the candidate's measured shares of that error
(``refine="shares"``); ``None`` where the a-priori grading decides (no frame bar can be
refined, or only a gradient's or a peak's error is over and no bar was marked yet)."""


def resolve(values: Values, first: Discretization, tol: Tolerance,
            elements: Callable[[Discretization], float] = lambda d: d.refinement,
            extrapolate: bool = False, mark: Marks | None = None,
            adjoint: Adjoint | None = None) -> tuple[Discretization, ErrorEstimate]:
    """The first candidate from ``first`` on whose estimate meets ``rtol·|q| + atol`` for
    every quantity, and that estimate. A :class:`SimulationError` in a run counts as an
    infinite error of that run. A candidate whose time error alone is clearly over budget
    is refined without running its space companion.

    With ``adjoint``, a dynamic candidate whose values' adjoint time errors agree with its
    half-steps run (:func:`agreed_time`) and are within budget is judged raw on them, with
    no run at 4h or 8h; where that fails and the candidate could be extrapolated, it is
    judged as follows too. After a candidate whose time error took at most half the budget,
    one refined in space only on the same steps is first judged on its space companion
    alone (:func:`_space_over`).

    With ``extrapolate``, a dynamic candidate whose steps divide by 8 is judged on its
    Richardson extrapolation too (:func:`extrapolated_estimate`, from its time companions
    at 2h, 4h and 8h), and where that estimate is the smaller, the candidate returned is
    ``extrapolated`` and the estimate is the extrapolated value's.

    ``elements(d)`` is the number of elements of a candidate over the scene's. With
    ``mark``, a candidate whose space error takes more than half the budget is refined as
    ``mark`` says (:class:`Marks`) instead of by the a-priori grading.

    Raises :class:`ToleranceError` after ``MAX_CANDIDATES`` candidates, when the tolerance needs more than ``MAX_REFINEMENT``
    times a bar's elements, ``MAX_ELEMENTS_FACTOR`` times the scene's or ``MAX_STEPS`` steps, naming the quantity and the error
    reached, or when the runs still fail after ``MAX_FAILED_REFINEMENTS`` refinements in a
    row, with the last failure.
    """
    failures: list[SimulationError] = []

    def recorded(d: Discretization, companion: bool) -> Quantities:
        try:
            return values(d, companion)
        except SimulationError as error:
            failures.append(error)
            raise

    d, failed, before, settled = first.grid, 0, None, None
    for _ in range(MAX_CANDIDATES):
        space_first = settled is not None and d.steps > 0 and d.steps == settled.steps and d != settled
        verdict = (space_first and _space_over(recorded, d, tol)) or _judge(recorded, d, tol, extrapolate, adjoint)
        if verdict.passed:
            return replace(d, extrapolated=verdict.extrapolated), verdict.estimate
        failed = failed + 1 if verdict.failed else 0
        if failed > MAX_FAILED_REFINEMENTS and failures:
            raise ToleranceError(f"the runs still fail after {MAX_FAILED_REFINEMENTS} refinements, at {d}: {failures[-1]}") from failures[-1]
        back = (before is not None and d.floor > before[0].floor and d.refinement == before[0].refinement
                and verdict.worst_space > UNMOVED * before[1])
        if back:
            d = replace(d, floor=before[0].floor)  # the floor missed the error too: back to the bars that need most
        stalled = (before is not None and d.refinement > before[0].refinement and verdict.worst_space > STALLED * before[1]
                   and verdict.worst_time <= 0.5)
        marks = None
        if mark is not None and verdict.estimate is not None and verdict.worst_space > 0.5:
            missed = before is not None and bool(before[0].factors) and verdict.worst_space > UNMOVED * before[1]
            est = verdict.estimate
            with np.errstate(divide="ignore", invalid="ignore"):
                ratios = np.where(est.space == 0.0, 0.0, est.space / tol.budget(est))
            marks = mark(d, missed, ratios)
        if marks is not None:
            refined = replace(marks, steps=_more_steps(d.steps, verdict))
        else:
            refined = _refine(d, verdict, everywhere=not back and (stalled or d.floor > 1))
        before = (d, verdict.worst_space)
        settled = d if verdict.estimate is not None and verdict.worst_time <= 0.5 and refined.steps == d.steps else None
        if max((refined.refinement, *refined.factors)) > MAX_REFINEMENT or refined.steps > MAX_STEPS \
                or elements(refined) > MAX_ELEMENTS_FACTOR:
            raise _beyond_limits(d, verdict.estimate, tol)
        d = refined
    raise ToleranceError(f"no discretization met the tolerance within {MAX_CANDIDATES} candidates (the last: {d})")


@dataclass(frozen=True)
class Verdict:
    """A candidate judged: its estimate (``None`` if a run failed), the largest shares of
    the budget the time error, the space error and their sum take, and whether the
    candidate's own run failed."""

    estimate: ErrorEstimate | None
    worst_time: float
    worst_space: float
    worst_total: float = np.inf
    failed: bool = False
    """Whether the candidate's own run failed (not only a companion)."""
    extrapolated: bool = False
    """Whether the estimate is that of the candidate's extrapolated values."""
    extrapolable: bool = False
    """Whether a candidate with more steps is judged on its extrapolated values too."""

    @property
    def passed(self) -> bool:
        return self.estimate is not None and self.worst_total <= 1.0

    @property
    def time_order(self) -> int:
        """The order in h at which the time error falls from this candidate to one with more
        steps: that of extrapolated values where these are extrapolated, or where the next
        will be and the space needs no refinement (a space error measured on too few steps
        is trusted for the next candidate only with the steps the raw order asks for)."""
        return EXTRAPOLATED_ORDER if self.extrapolated or (self.extrapolable and self.worst_space <= 0.5) else TIME_ORDER


def _judge(values: Values, d: Discretization, tol: Tolerance, extrapolate: bool = False,
           adjoint: Adjoint | None = None) -> Verdict:
    """Runs ``d`` and its half-steps companion. Where the adjoint's time errors of ``d``
    agree with it (:func:`agreed_time`) and are within budget, judges ``d`` raw on them
    (:func:`_judge_agreed`), and that verdict stands unless it fails where the values could
    be extrapolated. Otherwise (with ``extrapolate`` and steps that divide by 8, the
    quarter- and eighth-steps companions too), unless the time error alone is clearly over
    budget, the space companion; then the quarter-steps companion if the estimate without
    it fails. The extrapolated values are judged where their estimate is the smaller; the
    grid's own values are never accepted on a time error below the adjoint's where it agreed
    (:func:`_floored`; the steps foreseen read step doubling's)."""
    dynamic = d.steps > 0
    fine = _try(values, d)
    half = _try(values, d.half_steps, companion=True) if dynamic else None
    if fine is None or (dynamic and half is None):  # more steps if there are steps, else more elements
        return Verdict(None, np.inf, 0.0, failed=fine is None) if dynamic else Verdict(None, 0.0, np.inf, failed=True)
    read = None if adjoint is None or half is None else adjoint(d)
    estimated = None if read is None else np.atleast_1d(np.asarray(read, float))
    agreed = None if estimated is None else agreed_time(fine, half, estimated, tol.orders)
    if agreed is not None and half is not None \
            and _ratio(agreed, tol.budget(ErrorEstimate(_sizes(fine), agreed, agreed))) <= 1.0:
        verdict = _judge_agreed(values, d, tol, fine, half, agreed)
        if verdict.passed or not (extrapolate and d.steps % 8 == 0):
            return verdict  # else the extrapolated values may pass: judged below, the runs made kept
    quarter = eighth = None
    if dynamic and extrapolate and d.steps % 8 == 0:
        quarter, eighth = _try(values, d.quarter_steps, companion=True), _try(values, d.eighth_steps, companion=True)
    extrapolation = (lambda space: extrapolated_estimate(fine, half, quarter, eighth, space)) \
        if quarter is not None and eighth is not None else None
    if dynamic:
        rates = 2.0**tol.orders  # each quantity's fastest contraction, no space error
        least = estimate(fine, half, [h + c * (h - f) for f, h, c in zip(fine, half, rates)], half, tol.orders)
        candidates = [(least, False)] + ([] if extrapolation is None else [(extrapolation(least.space), True)])
        best, extrapolated = min(candidates, key=lambda c: _ratio(c[0].time, tol.budget(c[0])))
        if _ratio(best.time, tol.budget(best)) > 2.0:
            return Verdict(best, _ratio(best.time, tol.budget(best)), 0.0, extrapolated=extrapolated, extrapolable=extrapolate)
    split = _try(values, d.split, companion=True)
    if split is None:  # the finer model failed where this one ran: more steps first
        return Verdict(None, np.inf, 0.0) if dynamic else Verdict(None, 0.0, np.inf)
    values_agreed = None if agreed is None or estimated is None else agreed[:len(estimated)]
    est = _floored(estimate(fine, half, quarter, split, tol.orders), values_agreed)  # no quarter: the slowest contraction
    if dynamic and quarter is None and _ratio(est.total, tol.budget(est)) > 1.0:
        quarter = _try(values, d.quarter_steps, companion=True)
        est = est if quarter is None else _floored(estimate(fine, half, quarter, split, tol.orders), values_agreed)
    extrapolated = False
    if extrapolation is not None:
        other = extrapolation(est.space)
        if _ratio(other.total, tol.budget(other)) < _ratio(est.total, tol.budget(est)):
            est, extrapolated = other, True
    budget = tol.budget(est)
    verdict = Verdict(est, _ratio(est.time, budget), _ratio(est.space, budget), _ratio(est.total, budget),
                      extrapolated=extrapolated, extrapolable=extrapolate and dynamic)
    if verdict.passed and dynamic and tol.rtol.min() < CONFIRMED_BELOW:
        return _confirmed(values, d, verdict, tol, half, split)
    return verdict


def _floored(est: ErrorEstimate, agreed: np.ndarray | None) -> ErrorEstimate:
    """``est`` of the grid's own values, each value's time error at least the adjoint's
    estimate that ``agreed`` with the half steps (:func:`agreed_time`, its first entries):
    step doubling's reading from more runs may be the smaller, but not the one believed. A
    gradient's or a peak's has no estimate of its own there, and step doubling's measured
    contraction stands."""
    if agreed is None:
        return est
    time = est.time.copy()
    time[:len(agreed)] = np.maximum(time[:len(agreed)], agreed)
    return replace(est, time=time)


def _space_over(values: Values, d: Discretization, tol: Tolerance) -> Verdict | None:
    """The verdict on ``d`` from its space companion alone where its space error is over
    budget, else ``None``: ``d``'s half-steps run and the space companion, which its full
    judgement reads too, without the run at ``d`` itself and the time companions below it.
    Every estimate of ``d`` (raw, agreed, extrapolated) carries that space error, so ``d``
    cannot pass. For a candidate refined in space only after one whose time error was
    within half the budget on the same steps: it is refined again at once, the steps kept."""
    half = _try(values, d.half_steps, companion=True)
    split = None if half is None else _try(values, d.split, companion=True)
    if half is None or split is None:
        return None
    sizes = _sizes(half)
    est = ErrorEstimate(sizes, np.zeros(len(sizes)), _distances(split, half) / (1.0 - 2.0**-SPACE_ORDER))
    worst = _ratio(est.space, tol.budget(est))
    return Verdict(est, 0.0, worst) if worst > 1.0 else None


def _judge_agreed(values: Values, d: Discretization, tol: Tolerance, fine: Quantities, half: Quantities,
                  time: np.ndarray) -> Verdict:
    """``d`` judged raw on the time errors ``time`` (:func:`agreed_time`) and, unless they are
    clearly over budget, the space companion's estimate (confirmed below
    :data:`CONFIRMED_BELOW`, as :func:`_judge` does). More steps are foreseen at the raw
    second order."""
    sizes = _sizes(fine)
    budget = tol.budget(ErrorEstimate(sizes, time, np.zeros_like(time)))
    if _ratio(time, budget) > 2.0:
        return Verdict(ErrorEstimate(sizes, time, np.zeros_like(time)), _ratio(time, budget), 0.0)
    split = _try(values, d.split, companion=True)
    if split is None:  # the finer model failed where this one ran: more steps first
        return Verdict(None, np.inf, 0.0)
    est = ErrorEstimate(sizes, time, _distances(split, half) / (1.0 - 2.0**-SPACE_ORDER))
    verdict = Verdict(est, _ratio(est.time, budget), _ratio(est.space, budget), _ratio(est.total, budget))
    if verdict.passed and tol.rtol.min() < CONFIRMED_BELOW:
        return _confirmed(values, d, verdict, tol, half, split)
    return verdict


def _confirmed(values: Values, d: Discretization, verdict: Verdict, tol: Tolerance, coarse: Quantities,
               split: Quantities) -> Verdict:
    """``verdict`` of a dynamic candidate that passes, its space error confirmed by the second
    space companion (:attr:`Discretization.split_twice`). With ``a`` the change from ``coarse``
    (the candidate's elements on the space companion's steps) to ``split`` and ``b`` the
    change from there to four times the elements, the space error is taken as

        e_space = max(2a, a + 2b)

    the estimate's own where ``a ≥ 2b``, and where the change grows with the elements (a bar
    near resonance, its own frequency still moving: the arm's last design of an rtol 1e-3
    optimization changed by 8e-5, 1.1e-3 and 5.4e-3 relative with every bar at 2×, 4×, 8×)
    first order assumed from the split on. If the second companion fails, the verdict
    stands."""
    twice, est = _try(values, d.split_twice, companion=True), verdict.estimate
    if twice is None or est is None:
        return verdict
    a = _distances(split, coarse)
    confirmed = ErrorEstimate(est.size, est.time, np.maximum(est.space, a + 2.0 * _distances(twice, split)))
    budget = tol.budget(confirmed)
    return replace(verdict, estimate=confirmed, worst_space=_ratio(confirmed.space, budget),
                   worst_total=_ratio(confirmed.total, budget))


def _beyond_limits(d: Discretization, est: ErrorEstimate | None, tol: Tolerance) -> ToleranceError:
    limits = (f"the next refinement passes the limits ({MAX_REFINEMENT}× a bar's elements, {MAX_ELEMENTS_FACTOR}× the "
              f"scene's elements, {MAX_STEPS} steps)")
    if est is None:
        return ToleranceError(f"the tolerance cannot be met: the runs fail with {d}, and {limits}")
    k = int(np.argmax(np.nan_to_num(est.total / np.maximum(tol.budget(est), 1e-300), nan=np.inf)))
    return ToleranceError(f"rtol = {tol.rtol[k]:g} cannot be met for {tol.names[k]}: estimated relative error "
                          f"{est.relative[k]:.3g} with {d}, and {limits}")


def check_tolerance(rtol: float, atol: float) -> None:
    """``rtol`` in ``[MIN_RTOL, 1)`` and ``atol`` ≥ 0, both finite, or a :class:`SettingsError`."""
    if isinstance(rtol, bool) or isinstance(atol, bool):
        raise SettingsError("rtol and atol must be numbers")
    if not (isinstance(rtol, (int, float)) and math.isfinite(rtol) and MIN_RTOL <= rtol < 1.0):
        raise SettingsError(f"rtol must be a number in [{MIN_RTOL:g}, 1), got {rtol!r}")
    if not (isinstance(atol, (int, float)) and math.isfinite(atol) and atol >= 0.0):
        raise SettingsError(f"atol must be a finite number ≥ 0, got {atol!r}")


def tolerance_of(names: Sequence[str], rtol: float, atol: float, gradients: bool, peaked: Sequence[str] = ()) -> Tolerance:
    """Responses ``names`` to ``rtol·|f| + atol``, then, with ``gradients``, their gradients
    to ``GRADIENT_FACTOR·rtol`` relative, then the peaks of the responses ``peaked`` to
    ``rtol·|peak| + atol``, their time errors at ``PEAK_ORDER``."""
    graded = list(names) + ([f"the gradient of {n}" for n in names] if gradients else [])
    rtols = [rtol] * len(names) + ([GRADIENT_FACTOR * rtol] * len(names) if gradients else [])
    atols = [atol] * len(names) + ([0.0] * len(names) if gradients else [])
    orders = [float(TIME_ORDER)] * len(graded) + [float(PEAK_ORDER)] * len(peaked)
    return Tolerance([*graded, *(f"the peak of {n}" for n in peaked)], np.array(rtols + [rtol] * len(peaked)),
                     np.array(atols + [atol] * len(peaked)), np.array(orders))


def _try(values: Values, d: Discretization, companion: bool = False) -> Quantities | None:
    try:
        out = [np.atleast_1d(np.asarray(q, dtype=float)) for q in values(d, companion)]
    except SimulationError:
        return None
    return out if all(np.isfinite(q).all() for q in out) else None


def _ratio(error: np.ndarray, budget: np.ndarray) -> float:
    """The largest ``error / budget``: 0 where both vanish, infinite where the error is
    not finite."""
    error = np.where(np.isfinite(error), error, np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(error == 0.0, 0.0, error / budget)
    return float(np.max(ratio, initial=0.0))


def _refine(d: Discretization, verdict: Verdict, everywhere: bool = False) -> Discretization:
    """More steps where the time error takes more than half the budget (by the power of two
    the rate of the values judged asks for, at least one doubling), a refinement doubled
    once or twice (:func:`doublings`) where the space error does, or, ``everywhere``, the
    floor of every bar's factor doubled (up to the refinement; then both). Measured
    ``factors`` are kept (only the steps change where a marking decides the space)."""
    steps, refinement, floor = d.steps, d.refinement, d.floor
    worst_time, worst_space = verdict.worst_time, verdict.worst_space
    if worst_time > 0.5 or (worst_space <= 0.5 and steps):
        steps = _more_steps(steps, verdict) if worst_time > 0.5 else 2 * steps
    if worst_space > 0.5 or not steps:
        if not everywhere:
            refinement *= 2 ** doublings(worst_space)
        elif floor < refinement:
            floor *= 2
        else:
            refinement, floor = 2 * refinement, 2 * floor
    return replace(d, refinement=refinement, steps=steps, floor=floor, extrapolated=False)  # of d's kind


def _more_steps(steps: int, verdict: Verdict) -> int:
    """``steps`` times the power of two that brings a time error over half the budget under
    it at the verdict's :attr:`~Verdict.time_order` (at least one doubling)."""
    worst = verdict.worst_time
    if worst <= 0.5:
        return steps
    return steps * 2 ** (1 if not math.isfinite(worst) else max(1, math.ceil(math.log2(worst / 0.5) / verdict.time_order)))


def dorfler(shares: np.ndarray, theta: float = 0.8) -> np.ndarray:
    """The fewest bars whose shares ``|η|`` carry ``theta`` of their sum (Dörfler's marking),
    as a mask."""
    order = np.argsort(-shares, kind="stable")
    carried = np.cumsum(shares[order])
    count = int(np.searchsorted(carried, theta * carried[-1])) + 1 if carried[-1] > 0 else len(shares)
    mask = np.zeros(len(shares), bool)
    mask[order[:count]] = True
    return mask


def doublings(worst_space: float) -> int:
    """Doublings of the refinement that bring a space error ``worst_space`` times the
    budget under half of it at the second order the bars converge at (3.5–4.5× per
    doubling, measured on clamped bars): at least one, at most two, since the refined
    model grows with them."""
    if not math.isfinite(worst_space) or worst_space <= 0.5:
        return 1
    return min(2, max(1, math.ceil(math.log2(worst_space / 0.5) / 2)))
