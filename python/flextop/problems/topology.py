"""Topology optimization problems on a scene (paper Sections 3.1, 3.2 and 4).

A :class:`TopologyProblem` minimizes one response of the scene's motion (or equilibrium)
over the bar densities, subject to upper bounds on other responses, with ``x_min ≤ x ≤ 1``:

    minimize f(x)   s.t.   r_j(x) ≤ b_j,

seen by the optimizers as ``f0 = f / f_ref`` and ``g_j = r_j / b_j − 1 ≤ 0``, so every
function is of order one. Responses are those of
:meth:`flextop.Simulation.run_with_sensitivities`; each evaluation is one simulation with
exact gradients. One constraint is a floor instead: ``("min_frequency", f_min)`` keeps the
structure's lowest natural frequency at rest (drives locked) above ``f_min`` (Hz), as
``g = 1 − KS/f_min ≤ 0`` with KS the smooth lower bound over the lowest
:data:`FLOOR_MODES` frequencies (:func:`flextop.modal.ks_lowest`, differentiable where
they coincide), each to :data:`FLOOR_RTOL` against the converged structure.

A limit on an aggregate (``("stress", σ_max)``, ``("stress:COMPONENT:OPTIONS", σ_max)``,
``("shear", τ_max)``, ``("buckling", b_max)``) bounds its peak through the adaptive normalization of Le, Norato,
Bruns, Ha and Tortorelli (Struct. Multidisc. Optim. 41, 2010): the response is a p-mean or
KS mean P, below the peak, and the optimizer sees ``g = c P/b − 1``. The factor ``c`` starts
at the start design's ratio peak/P and moves, once per iteration, towards the ratio at the
design accepted (damped by :data:`NORMALIZATION_DAMPING`), so that c P tracks the peak as
the design settles while every iteration, inner ones included, sees fixed functions. The
limit is on the relaxed value ``x^q σ`` (``q = ½`` unless the name says ``q=0``): a bar at
``x < 1`` may carry ``x^{-q}`` times the limit in its solid material. Only an optimizer that
calls :meth:`TopologyProblem.accept` (``flextop.optimize``) moves ``c``; through the scipy and
OpenMDAO adapters it stays at the first design's ratio. The factors live in the problem
(``normalization``, saved by :meth:`TopologyProblem.to_dict`): resume with the same problem,
or one rebuilt by ``from_dict``, not a fresh one. A simulation that fails becomes an :class:`~flextop.optimizers.EvaluationError`, which the
optimizer recovers from.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import astuple
from typing import Any

import numpy as np

from .. import scenes
from ..modal import ks_lowest
from ..errors import DesignError, SettingsError, SettingsWarning, SimulationError
from ..optimizers import Evaluation, EvaluationError, Problem, Trial
from ..responses import PEAK_LIMITED
from ..simulation import Simulation
from ..discretization.refinement import Held
from ..discretization.tolerance import Discretization
from . import filters
from .filters import DensityFilter, SensitivityFilter
from .held import READAPT, Readapt


MIN_FREQUENCY = "min_frequency"
"""The name of the constraint that is a floor (Hz) on the lowest natural frequency."""

FLOOR_MODES = 2
"""Frequencies aggregated by the floor's KS function: the lowest two, so that a double
lowest frequency (a symmetric structure) stays differentiable; a higher mode crossing down
joins them continuously. Six cost five times as much on the arm's tip-deflection optimum
(0.10 s against 0.019 s), whose third and higher modes are bars' own and need 16× the
elements per bar for their tolerance."""

FLOOR_RHO = 50.0
"""The KS parameter: KS lies within ``f_min ln(FLOOR_MODES)/FLOOR_RHO`` (1.4 %) below the lowest."""

FLOOR_RTOL = 1e-3
"""Relative tolerance of the floor's frequencies against the converged structure."""


AGGREGATES = PEAK_LIMITED
"""Responses that are means of point values, reported with their peaks (read from the
engine: :data:`flextop.responses.PEAK_LIMITED`)."""

KEPT_RATIOS = 16
"""Designs whose peak/mean ratios wait for :meth:`TopologyProblem.accept` (an iteration's
trial designs; older ones are dropped)."""

NORMALIZATION_DAMPING = 0.5
"""α of the normalization update ``c ← α peak/P + (1 − α) c`` (Le et al. 2010)."""


def normalized(normalization: dict[str, float], ratios: dict[bytes, dict[str, float]], key: bytes, name: str,
               mean: float, peak: float) -> float:
    """An aggregate limit's factor ``c`` in ``normalization`` (set by the first evaluation),
    the ratio peak/P of the design ``key`` kept in ``ratios`` (at most :data:`KEPT_RATIOS`
    designs) for :func:`renormalized`."""
    ratio = peak / mean if mean > 0 else 1.0
    if key not in ratios and len(ratios) >= KEPT_RATIOS:
        del ratios[next(iter(ratios))]
    ratios.setdefault(key, {})[name] = ratio
    return normalization.setdefault(name, ratio)


def renormalized(normalization: dict[str, float], ratios: Mapping[str, float], names: Sequence[str],
                 evaluation: Evaluation) -> Evaluation:
    """``evaluation`` of the accepted design with each aggregate constraint's ``c`` (the
    constraints ``names``, in order) moved towards the design's ratio peak/P in ``ratios``,
    damped by :data:`NORMALIZATION_DAMPING`, and the constraint rescaled to it."""
    g, dg = evaluation.g.copy(), evaluation.dg.copy()
    for j, name in enumerate(names):
        if name in ratios:
            old = normalization[name]
            new = NORMALIZATION_DAMPING * ratios[name] + (1 - NORMALIZATION_DAMPING) * old
            normalization[name] = new
            g[j] = new / old * (g[j] + 1.0) - 1.0
            dg[j] *= new / old
    return Evaluation(evaluation.f0, g, evaluation.df0, dg)


def is_aggregate(name: str) -> bool:
    """Whether the response ``name`` is a p-mean or KS mean with a peak (stress, shear,
    buckling, a drive's torque, a joint's reaction; not ``torque_rms``, a mean by definition)."""
    return name.split(":", 1)[0] in AGGREGATES


def relation(name: str) -> str:
    """How a constraint of that name bounds its response: ``>=`` for the frequency floor."""
    return ">=" if name == MIN_FREQUENCY else "<="


SUPPORTED_NODES = 3
"""How many of a member's nodes held by joints of their own (pins, rollers: not through a
ring) make a line of supports, whose cells ``solid_at_joints`` takes out of the design."""


def warn_if_supports_hold_cells(simulation: Simulation) -> None:
    """A :class:`SettingsWarning` naming each member whose cells at :data:`SUPPORTED_NODES`
    or more nodes held by joints ``solid_at_joints`` keeps passive solid (rollers along a
    symmetry line make that edge's column solid: a design the user did not ask for), said
    where a design is optimized."""
    spec, cells = simulation.spec, simulation.model.cells()
    held = [name for joint in spec.get("joints", [])
            for name in [*(joint.get(key) for key in ("node", "a", "b")), *joint.get("nodes", [])]
            if isinstance(name, str)]
    index = {name: k for k, name in enumerate(simulation.node_names)}
    member_of, variable = np.asarray(cells["member"]), np.asarray(cells["variable"])
    for k, member in enumerate(spec.get("members", [])):
        if not member.get("solid_at_joints", True) or member.get("fixed", False):
            continue
        nodes = {index[name] for name in held if name.startswith(f"{member['name']}[") and name in index}
        if len(nodes) < SUPPORTED_NODES:
            continue
        touching = np.array([bool(nodes.intersection(corners)) for corners in cells["nodes"]], dtype=bool)
        kept = int(np.count_nonzero((member_of == k) & (variable < 0) & touching))
        if kept:
            warnings.warn(f"member '{member['name']}': joints hold {len(nodes)} of its nodes, and solid_at_joints keeps "
                          f"the {kept} cells touching them passive solid, out of the design (rollers along a symmetry "
                          "line take that edge's column out): give solid_at_joints=False to design those cells",
                          SettingsWarning, stacklevel=3)


class TopologyProblem(Problem):
    """Minimize ``objective`` subject to ``constraints`` (response name → upper bound).

    ``settings`` are run settings (``h``, ``rho_inf``, ...); ``method`` is the sensitivity
    method; ``objective_scale`` is ``f_ref`` (default: the objective at the first design
    evaluated). ``timings`` accumulates the seconds spent in simulations and gradients.

    ``rtol`` (and ``atol``) hold the evaluations to a tolerance (see
    :meth:`Simulation.run_with_sensitivities`), the simulation's own by default. The rule:
    the model changes only between iterations, in :meth:`accept`. A design the optimizer
    accepts that has moved by more than ``readapt`` (in any variable) from the last design
    whose error was measured is re-adapted — its error estimated, the grid refined until
    it meets ``rtol``, starting from the discretization accepted before, so that the
    refinement and the steps only ever grow, and the bars refined for that design (by the
    shares of the error measured there, the default; with ``refine="bars"`` graded by
    their own frequencies, so that a bar that thinned into the band has gained elements,
    one that thickened out of it has given them back) — and its evaluation replaced by the one on
    that grid, which the next iteration builds on. Every other evaluation, an iteration's
    trial and MMA's inner iterations included, runs once on the grid as it is. So each
    iteration compares its designs on one smooth model: measured at the trial designs
    instead, the grid changed under MMA's safeguard at most iterations (163 measurements
    in 278 evaluations for 40 iterations of the arm, 432 s, against 9 in 236 and 229 s, and
    198 and 209 s with the safeguard's start of :func:`~flextop.optimizers.mma.raised_rho`;
    grids re-graded at every design: 233 evaluations), and the values each iteration
    starts from come from a grid measured within ``rtol`` near them. ``readapt=0``
    measures every accepted design. Through the scipy and OpenMDAO adapters, which do not
    call :meth:`accept`, an evaluation that moved by more than ``readapt`` is measured
    itself. The grid is
    chosen on the values of the objective and constraints (``hold_gradients=False``): the
    gradients are the exact derivatives of the values the optimizer sees, which is what its
    convergence needs, and holding them to a tolerance as well drove the space companion to
    16× the elements per bar on optimized designs. Where the accepted discretization is
    ``extrapolated`` (Richardson in the step, :meth:`Simulation.run_with_sensitivities`),
    every evaluation on it is too: the runs at h and 2h combined, gradients alike. A design
    the optimizer may still reject (MMA's trial and its inner iterations: :meth:`trial`)
    reads the values of those runs, and their gradients are made, by the adjoint about the
    same runs, only for the design it keeps: on the arm's optimization below, gradients at
    48 of 188 evaluations (the 40 designs kept and the 8 measured). Without a tolerance the
    same holds on the scene's own grid (a dynamic scene on uniform steps, by the adjoint):
    1.28× less time on the arm at 2× the elements and 1088 steps. The grid refines the bars
    whose measured shares of the error carry it (``refine="shares"``, the default): the
    arm's tip-deflection optimization from the one-element optimum took 44.5 s against
    126.0 s with ``"uniform"`` at ``rtol=1e-2`` (74.0 s with ``refine="bars"`` at the
    commit before), and 117.7 s at 1e-3, to designs within 1.3 % in true d. The design a
    run returns is measured as it ends (:meth:`conclude`) unless it is the design
    measured last: at 1e-3 the value the grid held gave there was 0.84 % off, the
    measurement's is 0.001 % (127.5 s in all; BENCHMARKS.md); the arm's compliance, the spun beam
    and the slider-crank ran the same optimizations under both (BENCHMARKS.md,
    "Optimization to a tolerance"). ``discretization`` is the current one,
    ``refinements`` lists ``(evaluation, discretization)`` at each change and ``measured``
    the evaluations whose error was estimated.

    Start such a problem from a design optimized on the scene's own grid (continuation):
    on the robot arm, MMA from x = 0.4 on any accurate discretization — a converged fixed
    grid or ``rtol = 1e-2`` — ends in a basin whose true d is ten times that of the design
    continuation finds (BENCHMARKS.md, "Optimization to a tolerance").
    """

    def __init__(self, simulation: Simulation, objective: str, constraints: Mapping[str, float] | Sequence[tuple[str, float]] = (),
                 *, settings: Mapping[str, Any] | None = None, method: str = "auto", objective_scale: float | None = None,
                 rtol: float | None = None, atol: float | None = None, readapt: float = READAPT,
                 filter: DensityFilter | SensitivityFilter | None = None) -> None:
        if simulation.n_design == 0:
            raise SettingsError("the scene has no design variables (no bars, or all of them fixed): nothing to optimize")
        self.simulation = simulation
        self.objective = objective
        self.constraints = list(constraints.items()) if isinstance(constraints, Mapping) else [tuple(c) for c in constraints]
        for name, bound in self.constraints:
            if not (np.isfinite(bound) and bound > 0):
                raise SettingsError(f"constraint {name!r}: the bound must be positive and finite, got {bound}")
        names = [name for name, _ in self.constraints]
        if any(is_aggregate(name) and names.count(name) > 1 for name in names):
            raise SettingsError("a stress or buckling limit appears twice; give each response one bound")
        self.settings = dict(settings or {})
        self.method = method
        self.objective_scale = objective_scale
        self.timings = {"simulation": 0.0, "gradients": 0.0}
        self.rtol, self.atol = rtol, atol
        self.rule = Readapt(readapt)
        self.filter = filter
        self.discretization: Discretization | None = None
        self.refinements: list[tuple[int, Discretization]] = []
        self._last_trial: tuple[np.ndarray | None, list[Any]] = (None, [])
        self.measured: list[int] = []
        self.evaluations = 0
        self.normalization: dict[str, float] = {}
        self._ratios: dict[bytes, dict[str, float]] = {}
        n = simulation.n_design
        super().__init__(np.full(n, simulation.x_min), np.ones(n), len(self.constraints), [c[0] for c in self.constraints])
        warn_if_supports_hold_cells(simulation)

    @property
    def responses(self) -> list[str]:
        """What the simulation computes: the objective and the constrained responses."""
        return [self.objective, *(name for name, _ in self.constraints if name != MIN_FREQUENCY)]

    def evaluate(self, x: np.ndarray) -> Evaluation:
        """Objective and constraints with their gradients: one run with sensitivities (of
        the physical densities where a density filter stands between). Held to a
        tolerance, on the grid accepted last; its error is measured here only where no grid
        was chosen yet and, for a caller that never calls :meth:`accept` (the scipy and
        OpenMDAO adapters), where the design has moved by more than ``readapt``."""
        return self._whole(x, measure=self._measures(x))

    def trial(self, x: np.ndarray) -> Trial:
        """:meth:`evaluate` for an optimizer that may reject ``x`` (MMA's inner iterations):
        on the grid held, or on the scene's own, the values now and the gradients, by the
        adjoint method about the same runs, only if it keeps ``x``
        (:class:`~flextop.discretization.refinement.Held`); made whole where the error is
        measured, and for a static scene, local error control or ``method="direct"``."""
        if self._measures(x) if self._holds() else not self._splits():
            return Trial.of(self.evaluate(x))
        self.evaluations += 1
        held = self._values_first(self.densities(x))
        return Trial(held.f0, held.g, lambda: self._through_filter(x, held.evaluation()))

    def _splits(self) -> bool:
        """Whether a run on the scene's own grid can be differentiated after its values are
        read: a dynamic scene on uniform steps, by the adjoint."""
        return self.simulation.analysis == "dynamic" and "local_tol" not in self.settings and self.method != "direct"

    def _whole(self, x: np.ndarray, measure: bool) -> Evaluation:
        """The evaluation at the design ``x``, its error measured or not."""
        return self._through_filter(x, self._evaluate(self.densities(x), measure))

    def _holds(self) -> bool:
        """Whether a tolerance holds the grid."""
        return bool(self.rtol or self.simulation.rtol)

    def _measures(self, x: np.ndarray) -> bool:
        """Whether an evaluation at ``x`` measures its error (:meth:`Readapt.in_evaluate`)."""
        return self.rule.in_evaluate(self.densities(x), held=self.discretization is not None)

    def _through_filter(self, x: np.ndarray, e: Evaluation) -> Evaluation:
        """The evaluation ``e`` at the physical densities as seen from the design ``x``: its
        gradients chained through the density filter, or the sensitivity filter's."""
        if isinstance(self.filter, DensityFilter):
            return Evaluation(e.f0, e.g, self.filter.chain(x, e.df0), self.filter.chain(x, e.dg))
        if isinstance(self.filter, SensitivityFilter):
            return Evaluation(e.f0, e.g, self.filter.filtered(x, e.df0), e.dg)
        return e

    def _evaluate(self, x: np.ndarray, measure: bool) -> Evaluation:
        """The evaluation at the physical densities ``x``: on the grid held, or measured to
        the tolerance (``measure``), or on the scene's own grid."""
        self.evaluations += 1
        if self._holds() and not measure:
            return self._values_first(x).evaluation()
        tolerance = {"rtol": self.rtol, "atol": self.atol, "start": self.discretization, "made": self._trial_runs(x)} \
            if self._holds() else {}
        try:
            out = self.simulation.run_with_sensitivities(x, self.responses, method=self.method, hold_gradients=False,
                                                         **tolerance, **self.settings)
        except SimulationError as error:
            raise EvaluationError(str(error), x) from error
        if tolerance:
            self.measured.append(self.evaluations)
            self.rule.measured(x)
        if out.discretization is not None and out.discretization != self.discretization:
            self.discretization = out.discretization
            self.refinements.append((self.evaluations, out.discretization))
        self._timed(out.timings)
        f, dfdx = out
        scale = self._scale(f[0])
        g, dg = self._constraints(x, f[1:], out.peaks)
        return Evaluation(f[0] / scale, g, dfdx[0] / scale, dg(dfdx[1:]))

    def _trial_runs(self, x: np.ndarray) -> list[Any]:
        """The runs of the last trial, if it was at the physical densities ``x`` (a kept
        trial that :meth:`accept` measures: the measurement reads them where its candidates
        run the grid held)."""
        at, runs = self._last_trial
        return list(runs) if at is not None and np.array_equal(at, x) else []

    def _values_first(self, x: np.ndarray) -> Trial:
        """The evaluation at the physical densities ``x`` on the grid held, graded for the
        design measured last, or without a tolerance on the scene's own grid
        (:class:`~flextop.discretization.refinement.Held`): the values now, the gradients
        when asked."""
        sim = self.simulation
        try:
            if self._holds():
                held = Held.on(sim, x, self.responses, self.discretization, self.rule.at, {"method": self.method, **self.settings})
            else:
                held = Held(sim, sim._design(x), self.responses, [sim._settings(**self.settings)], self.method)
        except SimulationError as error:
            raise EvaluationError(str(error), x) from error
        self._timed({"simulation": held.seconds})
        self._last_trial = (np.array(x, dtype=float), held.runs)
        f = held.values
        scale = self._scale(f[0])
        g, dg = self._constraints(x, f[1:], held.peaks)

        def gradients() -> Evaluation:
            try:
                out = held.sensitivities()
            except SimulationError as error:
                raise EvaluationError(str(error), x) from error
            self._timed({"gradients": out.timings["gradients"]})
            return Evaluation(f[0] / scale, g, out.gradients[0] / scale, dg(out.gradients[1:]))

        return Trial(f[0] / scale, g, gradients)

    def _timed(self, timings: Mapping[str, float]) -> None:
        for key, seconds in timings.items():
            self.timings[key] += seconds

    def _scale(self, f0: float) -> float:
        """The objective's scale, set by the first evaluation (``|f0|``, or 1 where 0)."""
        if self.objective_scale is None:
            self.objective_scale = abs(f0) if f0 != 0 else 1.0
        return self.objective_scale

    def _normalized(self, x: np.ndarray, name: str, mean: float, peak: float) -> float:
        """The factor ``c`` of an aggregate's limit (set by the first evaluation), with the
        ratio peak/P of these densities (the physical ones) kept for :meth:`accept`."""
        return normalized(self.normalization, self._ratios, x.tobytes(), name, mean, peak)

    accepts_trials = True

    def accept(self, x: np.ndarray, evaluation: Evaluation | Trial) -> Evaluation:
        """The functions of the next iteration. Held to a tolerance: where the accepted
        design has moved by more than ``readapt`` from the one measured last, its error is
        measured and ``evaluation`` replaced by the one on the grid accepted there (raises
        :class:`~flextop.optimizers.EvaluationError` if that fails); a kept :class:`Trial`'s
        gradients are made only where it is not replaced (on the arm's optimization at
        rtol 1e-2, 7 of 40). Then each aggregate's ``c`` moves towards the ratio peak/P at
        the design and its constraint is rescaled to the new ``c``."""
        moved = self.rule.in_accept(self.densities(x))
        if (self.rtol or self.simulation.rtol) and moved:
            evaluation = self._whole(x, measure=True)
        elif isinstance(evaluation, Trial):
            evaluation = evaluation.evaluation()
        ratios, self._ratios = self._ratios.get(self.densities(x).tobytes(), {}), {}
        return renormalized(self.normalization, ratios, [name for name, _ in self.constraints], evaluation)

    def conclude(self, x: np.ndarray, evaluation: Evaluation) -> Evaluation:
        """The evaluation a run reports at the design ``x`` it returns. Held to a
        tolerance, where ``x`` is not the design measured last, its error is measured from
        the grid held and ``evaluation`` replaced by the one on the grid that meets ``rtol``
        there (raises :class:`~flextop.optimizers.EvaluationError` if that fails); the
        aggregates' ``c`` do not move."""
        if self._holds() and self.rule.in_conclude(self.densities(x)):
            return self._whole(x, measure=True)
        return evaluation

    def _constraints(self, x: np.ndarray, r: np.ndarray,
                     peaks: Mapping[str, float]) -> tuple[np.ndarray, Callable[[np.ndarray], np.ndarray]]:
        """``g_j`` in the constraints' order — ``r/b − 1`` for an upper bound, ``c r/b − 1``
        for an aggregate, ``1 − KS/f_min`` for the frequency floor — and the map from the
        responses' gradients ``drdx`` to theirs."""
        g, rows, k, modes = [], [], 0, None
        for name, bound in self.constraints:
            if name == MIN_FREQUENCY:
                if modes is None:
                    try:
                        modes = self.simulation.modes(FLOOR_MODES, x, rtol=FLOOR_RTOL)
                    except SimulationError as error:
                        raise EvaluationError(str(error), x) from error
                ks, dks = ks_lowest(modes, bound, FLOOR_RHO)
                g.append(1.0 - ks / bound)
                rows.append(lambda drdx, row=-dks / bound: row)
            else:
                c = self._normalized(x, name, r[k], peaks[name]) if is_aggregate(name) else 1.0
                g.append(c * r[k] / bound - 1.0)
                rows.append(lambda drdx, k=k, factor=c / bound: factor * drdx[k])
                k += 1
        return np.array(g), lambda drdx: np.array([row(drdx) for row in rows]).reshape(len(g), len(x))

    @property
    def description(self) -> str:
        """What is minimized, in words."""
        return self.objective

    @property
    def bounded(self) -> list[tuple[str, float]]:
        """The constraints by name with their bounds (upper bounds, but the floor of
        :data:`MIN_FREQUENCY`: see :func:`relation`)."""
        return list(self.constraints)

    def densities(self, x: np.ndarray) -> np.ndarray:
        """The densities the scene is run with at design ``x`` (a vector within the bounds:
        :meth:`~flextop.optimizers.Problem.design`): the density filter's physical ones where
        it stands between, ``x`` otherwise."""
        x = self.design(x)
        return self.filter.physical(x) if isinstance(self.filter, DensityFilter) else x

    def start(self, x: Any) -> np.ndarray:
        """The design ``x`` of the scene (one number or one per variable) as a design of
        this problem."""
        xv = self.simulation._design(x)
        if xv is None:
            raise DesignError("start needs a design of the scene")
        return xv

    def unscaled(self, f0: float, g: np.ndarray | None = None) -> float:
        """The objective in the response's units from the optimizer's ``f0 = f / f_ref``
        (``g`` is not needed here; scenario problems take it)."""
        return f0 * (1.0 if self.objective_scale is None else self.objective_scale)

    def physical(self, evaluation: Evaluation) -> tuple[float, np.ndarray, np.ndarray]:
        """``f``, the constrained responses ``rⱼ`` (beside their bounds ``bⱼ``; an aggregate's
        normalized ``c P``) and ``∇f``, in the responses' units."""
        bounds = np.array([b for _, b in self.constraints])
        floor = np.array([name == MIN_FREQUENCY for name, _ in self.constraints], bool)
        values = np.where(floor, 1.0 - evaluation.g, evaluation.g + 1.0) * bounds
        scale = 1.0 if self.objective_scale is None else self.objective_scale
        return self.unscaled(evaluation.f0), values, evaluation.df0 * scale

    def to_dict(self) -> dict:
        """What rebuilds this problem on the same scene (for checkpoints)."""
        return {"objective": self.objective, "constraints": [list(c) for c in self.constraints], "settings": self.settings,
                "method": self.method, "objective_scale": self.objective_scale, "rtol": self.rtol, "atol": self.atol,
                "discretization": None if self.discretization is None else list(astuple(self.discretization)),
                "normalization": dict(self.normalization), **self.rule.to_dict(),
                "filter": None if self.filter is None else self.filter.to_dict()}

    @classmethod
    def from_dict(cls, simulation: Simulation, data: Mapping[str, Any]) -> TopologyProblem:
        problem = cls(simulation, data["objective"], [tuple(c) for c in data["constraints"]], settings=data["settings"],
                      method=data["method"], objective_scale=data["objective_scale"], rtol=data.get("rtol"), atol=data.get("atol"),
                      readapt=data.get("readapt", READAPT), filter=filters.from_dict(simulation, data.get("filter")))
        if data.get("discretization"):
            problem.discretization = Discretization(*data["discretization"])
        problem.rule = Readapt.from_dict(data)
        problem.normalization = dict(data.get("normalization", {}))
        return problem


def per_bar_limits(simulation: Simulation, bound: float, measure: str = "stress", options: str = "") -> list[tuple[str, float]]:
    """One limit per designed bar, ``("MEASURE:BAR[:OPTIONS]", bound)``: local constraints,
    each a mean over its bar, normalized to the bar's peak like any aggregate limit. A
    bar's own mean is close to its peak, so its factor stays near 1; the price is one
    adjoint solve per bar (the direct method once there are more limits than variables)."""
    suffix = f":{options}" if options else ""
    return [(f"{measure}:{name}{suffix}", bound) for name, variable in zip(simulation.bars.name, simulation.bars.variable)
            if variable >= 0]


def tightened(problem: TopologyProblem, x: np.ndarray, rtol: float = 3e-3, targets: Mapping[str, float] | None = None,
              margin: float = 0.0) -> tuple[TopologyProblem, dict[str, float]]:
    """The problem with each stress or buckling limit set to ``target/(κ(1 + margin))`` and
    a frequency floor to ``target·(1 + margin)``, and the ``κ`` by name.

    ``κ`` is the ratio of the design's peak on a discretization whose peaks meet ``rtol``
    (a run to a tolerance holds peaks to it) to its peak on the problem's own. A peak is a maximum over samples in time and along the
    bars, and the scene's grid reads it low (by 3–4 % on the arm's optima measured,
    BENCHMARKS.md): optimizing on, from ``x``, with the tightened limits ends nearer the
    limit on the converged structure. The floor's frequencies already meet their own
    tolerance, so it takes the margin only: where it competes with a stress limit the
    optimizer ends a little short of it (0.04 % on the arm). The targets are the
    problem's own bounds unless given: a later stage passes the first problem's, so that
    ``κ``, which moves with the design (0.2 % between the arm's stages), is measured again
    rather than compounded; ``margin`` covers that movement and the optimizer's shortfall
    in one stage. The normalization carries over."""
    if not (isinstance(margin, (int, float)) and 0.0 <= margin < 1.0):
        raise SettingsError(f"margin must be a number in [0, 1), got {margin!r}")
    names = [name for name, _ in problem.constraints if is_aggregate(name)]
    sim, kappa = problem.simulation, {}
    if names:
        try:
            model = sim.run(x, responses=names, **problem.settings)
            fine = sim.run(x, responses=names, rtol=rtol, **problem.settings)
        except SimulationError as error:
            raise EvaluationError(str(error), x) from error
        kappa = {name: fine.peak(name) / model.peak(name) if min(fine.peak(name), model.peak(name)) > 0 else 1.0
                 for name in names}
    targets = targets or {}

    def limit(name: str, bound: float) -> float:
        goal = targets.get(name, bound)
        if name == MIN_FREQUENCY:
            return goal * (1.0 + margin)
        return goal / (kappa[name] * (1.0 + margin)) if name in kappa else goal

    out = TopologyProblem(sim, problem.objective, [(name, limit(name, bound)) for name, bound in problem.constraints],
                          settings=problem.settings, method=problem.method, objective_scale=problem.objective_scale,
                          rtol=problem.rtol, atol=problem.atol)
    out.normalization = dict(problem.normalization)
    return out, kappa


def volume_constraints(simulation: Simulation, fraction: float, *, per_component: bool = True) -> list[tuple[str, float]]:
    """Upper bounds ``V ≤ fraction · V_full`` (paper Eq. 38), one per component (Eq. 41)
    that has design variables (a component of fixed bars or cells would give a constant),
    or on the whole structure; bars and continuum members' cells alike."""
    if not 0.0 < fraction <= 1.0:
        raise SettingsError(f"volume fraction must lie in (0, 1], got {fraction}")
    cells = simulation.model.cells()
    volume = np.concatenate([simulation.bars.volume, cells["volume"]])
    fixed = np.concatenate([simulation.bars.variable, cells["variable"]]).astype(int) < 0
    owner = {name: k for k, name in enumerate(simulation.components)}
    component = np.concatenate([simulation.bars.component,
                                [owner[cells["members"][m]] for m in cells["member"]]]).astype(int)
    if not per_component:
        return [("volume", fraction * volume[~fixed].sum() + volume[fixed].sum())]
    return [(f"volume:{name}", fraction * volume[(component == k) & ~fixed].sum() + volume[(component == k) & fixed].sum())
            for k, name in enumerate(simulation.components) if ((component == k) & ~fixed).any()]


def static_truss_problem(objective: str = "compliance", volume_fraction: float = 0.4, *, accuracy: str | None = None,
                         **scene: Any) -> TopologyProblem:
    """Paper Section 3.1: the truss of Fig. 4, compliance under the tip load, V ≤ 0.4 V_full."""
    sim = Simulation(scenes.static_truss(**scene), accuracy=accuracy)
    return TopologyProblem(sim, objective, volume_constraints(sim, volume_fraction, per_component=False))


def robot_arm_problem(objective: str = "tip_deflection", volume_fraction: float = 0.4, *, settings: Mapping[str, Any] | None = None,
                      accuracy: str | None = None, **scene: Any) -> TopologyProblem:
    """Paper Section 4: the two-link robot arm, mean squared tip deflection (Eq. 40) or mean
    compliance (Eq. 39) over the motion, V_i ≤ 0.4 V_full,i for each link (Eq. 41)."""
    sim = Simulation(scenes.robot_arm(**scene), accuracy=accuracy)
    return TopologyProblem(sim, objective, volume_constraints(sim, volume_fraction), settings=settings)


TEN_BAR_ALLOWABLE = 25 * scenes.KSI
"""The literature's allowable stress of every member of the ten-bar truss (Pa)."""


def ten_bar_truss_problem(allowable: float = TEN_BAR_ALLOWABLE, **scene: Any) -> TopologyProblem:
    """Minimum volume of :func:`flextop.scenes.ten_bar_truss` with ``|σ| ≤ allowable`` in
    every member (the true stress, ``q = 0``, as in the literature): a stress-constrained
    problem with a known optimum, 1593.2 lb at 0.1 lb/in³ (Haftka and Gürdal 1992), for the
    literature's linear analysis. At the literature's E the co-rotational model's geometric
    nonlinearity moves it to 1590.6 lb; ``E`` 1e5 times larger gives 1593.18 lb."""
    sim = Simulation(scenes.ten_bar_truss(**scene))
    return TopologyProblem(sim, "volume", [(f"stress:{c}:q=0", allowable) for c in sim.components])
