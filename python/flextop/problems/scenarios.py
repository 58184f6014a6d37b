"""Designs for several motions, payloads or load cases at once.

A :class:`Scenario` is one variant of a machine's scene (a drive law, a payload, a load
case) with a weight. Scenarios share the design variables: their scenes differ in what
moves and what is carried, not in the bars. A :class:`ScenarioProblem` minimizes, over
the shared densities,

    the weighted sum     F(x) = Σₛ wₛ fₛ(x)                        (``Aggregate.SUM``)
    or the worst case    max_s wₛ fₛ(x)                            (``Aggregate.WORST``)

of one response ``f`` of every scenario, subject to upper bounds on responses of each
scenario, or of all. The worst case is a bound formulation in logarithms: an extra
variable ``β`` (the last one) is minimized subject to

    ln(wₛ fₛ(x) / f_ref) ≤ β        for every scenario,

so that every function stays smooth and any optimizer of :mod:`flextop.optimizers`
solves it. The logarithm is what makes it work: a tip deflection falls by three orders of
magnitude from a uniform design to an optimum, and with the constraints ``wₛfₛ/f_ref ≤ β``
MMA stalled on the arm's six loaded scenarios at a worst d twelve times that of the
weighted sum's optimum, while in logarithms it converges in about 15 iterations to a worst
d below it (measured while building this, with the fast motion at h = 0.02 s). It needs
positive objectives (deflections, compliances). Values are scaled by ``f_ref``, the
aggregate at the first design evaluated, as in :class:`~flextop.TopologyProblem`.

Start the worst case from the weighted-sum optimum (continuation): on the nine scenarios
of :func:`robust_robot_arm`, MMA from x = 0.4 ends at a worst d of 2.2e-4 m² after 80
iterations, from the weighted-sum optimum at 1.75e-5 m², 28 % below the weighted sum's own
worst case and 2.5 times below that of the paper's single-scenario optimum
(BENCHMARKS.md, "Scenarios and batches").

The scenes are planar or spatial (:class:`~flextop.spatial.SpatialSimulation`), all of one
dimension: a spatial scenario's run is its responses with their adjoint gradients to the
densities (:func:`flextop.spatial.perform`), held to a tolerance, gradients included, as a
:class:`~flextop.problems.SpatialProblem` is.

Each evaluation runs one simulation with sensitivities per scenario on an executor
(:mod:`flextop.execution`): the scene and the design cross to the worker, the values and
gradients come back, and their sum is taken here, in the scenarios' order, so the result
is the same bits on any executor. :func:`evaluate` does the same for a batch of designs.
"""

from __future__ import annotations

import enum
import math
import numbers
import os
from collections.abc import Iterable, Mapping, Sequence
from concurrent.futures import Executor
from dataclasses import astuple, dataclass
from typing import Any

import numpy as np

from .. import execution, scenes, spatial
from ..checks import number
from ..errors import DesignError, FlextopError, SceneError, SettingsError, SimulationError
from ..optimizers import Evaluation, EvaluationError, Problem
from ..results import Sensitivities
from ..scenes import Scene
from ..scenes.builder import SceneDict, read_toml
from ..scenes.spatial import is_spatial
from ..simulation import Simulation, Task, design_vectors, perform, remember
from ..spatial import SpatialSensitivities, SpatialSimulation
from ..discretization import spatial as spatial_tolerance
from ..discretization.spatial import EveryBeam
from ..discretization.tolerance import Discretization
from .held import READAPT, Readapt
from .topology import is_aggregate

WORST_CASE_RANGE = (-20.0, 1.0)
"""Bounds of the worst-case variable ``β = ln(max wₛfₛ / f_ref)``: from a factor e⁻²⁰ (2e-9)
below the worst case at the start design (where ``β = 0``) to e (2.7) above it."""

DESIGN_ONLY = ("volume", "mass")
"""Responses that depend on the design alone: constrained once, not per scenario (``mass``,
a spatial scene's beams' and bars', as :meth:`~flextop.spatial.SpatialSimulation.mass`)."""


class Aggregate(enum.Enum):
    """How the scenarios' objectives combine."""

    SUM = "sum"
    """The weighted sum ``Σ wₛ fₛ``."""
    WORST = "worst"
    """The largest ``wₛ fₛ``, by the bound formulation in logarithms."""


@dataclass(frozen=True)
class Scenario:
    """One variant of the machine: its ``name``, its scene (a :class:`Scene` or
    :class:`~flextop.scenes.spatial.SpatialScene`, a scene dict or a TOML path) and its
    ``weight`` in the objective."""

    name: str
    scene: SceneDict | dict | str | os.PathLike
    weight: float = 1.0

    def spec(self) -> dict:
        """The scene as a dict."""
        if isinstance(self.scene, SceneDict):
            return self.scene.to_dict()
        if isinstance(self.scene, dict):
            return self.scene
        if not isinstance(self.scene, (str, os.PathLike)):
            raise SceneError(f"scenario {self.name!r}: its scene is a {type(self.scene).__name__}; give a Scene, a "
                             "SpatialScene, a scene dict or a TOML file's path")
        spec = read_toml(self.scene)
        return spec if is_spatial(spec) else Scene.from_dict(spec).to_dict()


def _simulations(scenarios: Sequence[Scenario], options: dict[str, Any]) -> list[Simulation | SpatialSimulation]:
    """Each scenario's :class:`Simulation` (or, a spatial scene's,
    :class:`~flextop.spatial.SpatialSimulation`) in this process, checked to share the
    design and the dimension."""
    if not scenarios:
        raise SceneError("scenarios: give at least one")
    strange = next((s for s in scenarios if not isinstance(s, Scenario)), None)
    if strange is not None:
        raise SceneError(f"scenarios: give Scenario(name, scene, weight) entries, got {strange!r}")
    names = [s.name for s in scenarios]
    if len(set(names)) != len(names):
        raise SceneError(f"scenarios: names must differ, got {names}")
    sims: list[Simulation | SpatialSimulation] = []
    for s in scenarios:
        if isinstance(s.weight, bool) or not (isinstance(s.weight, numbers.Real) and math.isfinite(s.weight) and s.weight > 0):
            raise SceneError(f"scenario {s.name!r}: the weight must be a positive number, got {s.weight!r}")
        spec = s.spec()
        if sims and is_spatial(spec) != isinstance(sims[0], SpatialSimulation):
            raise SceneError(f"scenario {s.name!r}: its scene is {'spatial' if is_spatial(spec) else 'planar'}, "
                             f"that of {scenarios[0].name!r} is not; scenarios share one design")
        try:
            sims.append(SpatialSimulation(spec, **options) if is_spatial(spec) else Simulation(spec, **options))
        except SceneError as error:
            raise type(error)(f"scenario {s.name!r}: {error}") from None
        if _variables(sims[-1]) != _variables(sims[0]) or sims[-1].x_min != sims[0].x_min:
            raise SceneError(f"scenario {s.name!r}: its design variables (or their x_min) differ from those of "
                             f"{scenarios[0].name!r}; scenarios share one design")
        remember(sims[-1])
    return sims


def _listed(what: str, given: Any, error: type[FlextopError]) -> list:
    """``given`` as a list, or ``error`` naming ``what`` where it is no sequence."""
    try:
        return list(given)
    except TypeError:
        raise error(f"{what}: give a list, got {given!r}") from None


def _variables(sim: Simulation | SpatialSimulation) -> tuple[str, ...]:
    """A simulation's design variables' names."""
    return tuple(sim.variables if isinstance(sim, SpatialSimulation) else sim.variable_names)


def _perform(task: Task) -> Sensitivities | SpatialSensitivities:
    """A scenario's run, on its planar or spatial scene (:func:`flextop.simulation.perform`,
    :func:`flextop.spatial.perform`)."""
    return spatial.perform(task) if is_spatial(task.scene) else perform(task)


class ScenarioProblem(Problem):
    """Minimize the ``aggregate`` (``"sum"`` or ``"worst"``) of ``objective`` over
    ``scenarios`` subject to ``constraints``: ``(response, bound)`` for every scenario
    (once for a response of the design alone, such as ``volume:link1``) or ``(scenario,
    response, bound)`` for one. Constraints are named ``"SCENARIO: response"``.

    ``executor`` runs the scenarios of an evaluation, ``chunksize`` to a task
    (:mod:`flextop.execution`; ``None``: here, in turn). ``settings``, ``method``, ``rtol``, ``atol`` and ``objective_scale`` are
    those of :class:`~flextop.TopologyProblem`, with the discretization chosen per scenario
    (``discretizations``); held to a tolerance, the problem follows the same rule
    (:mod:`.held`, ``readapt``): every scenario's error is measured at an accepted design
    that moved by more than ``readapt``, and every other evaluation runs each scenario on its
    grid held (``measured`` lists the evaluations that measured). A failed scenario run becomes an
    :class:`~flextop.optimizers.EvaluationError` naming it, which the optimizer recovers
    from; a worker lost is an :class:`~flextop.errors.ExecutionError`.

    With the worst case, designs have one more entry than the scenes' design variables:
    ``β`` last; :meth:`start` appends it to a design.
    """

    def __init__(self, scenarios: Sequence[Scenario], objective: str,
                 constraints: Iterable[tuple[str, float] | tuple[str, str, float]] = (), *, aggregate: str | Aggregate = "sum",
                 executor: Executor | None = None, chunksize: int = 1, settings: Mapping[str, Any] | None = None,
                 method: str = "auto", objective_scale: float | None = None, rtol: float | None = None,
                 atol: float | None = None, accuracy: str | None = None, readapt: float = READAPT) -> None:
        self.scenarios = _listed("scenarios", scenarios, SceneError)
        self.simulations = _simulations(self.scenarios, {"accuracy": accuracy})
        if not isinstance(objective, str):
            raise SettingsError(f"objective: a response's name, got {objective!r}")
        if objective_scale is not None:
            number("objective_scale", objective_scale, 0.0, math.inf, "()")
        if not (settings is None or isinstance(settings, Mapping)):
            raise SettingsError(f"settings: give a run's settings by name, got {settings!r}")
        self.objective = objective
        try:
            self.aggregate = Aggregate(aggregate)
        except ValueError:
            raise SettingsError(f"aggregate must be one of {', '.join(a.value for a in Aggregate)}, got {aggregate!r}") from None
        self.executor, self.chunksize = executor, chunksize
        self.settings = dict(settings or {})
        self.method, self.objective_scale = method, objective_scale
        self.rtol, self.atol, self.accuracy = rtol, atol, accuracy
        self.discretizations: dict[str, Discretization] = {}
        self.rule = Readapt(readapt)
        self.measured: list[int] = []
        self.evaluations = 0
        self.timings = {"simulation": 0.0, "gradients": 0.0}
        self.given = [tuple(c) if isinstance(c, (tuple, list)) else c for c in _listed("constraints", constraints, SettingsError)]
        self.constraints = self._constraints(self.given)
        self.n_design = self.simulations[0].n_design
        worst = self.aggregate is Aggregate.WORST
        lower = np.append(np.full(self.n_design, self.simulations[0].x_min), [WORST_CASE_RANGE[0]] if worst else [])
        upper = np.append(np.ones(self.n_design), [WORST_CASE_RANGE[1]] if worst else [])
        names = ([f"{s.name}: {objective} (worst case)" for s in self.scenarios] if worst else []) + [c[2] for c in self.constraints]
        super().__init__(lower, upper, len(names), names)

    def _constraints(self, given: Iterable[tuple]) -> list[tuple[int | None, str, str, float]]:
        """``(scenario index or None for a design-only response, response, name, bound)``."""
        index = {s.name: k for k, s in enumerate(self.scenarios)}
        out: list[tuple[int | None, str, str, float]] = []
        for entry in given:
            if not (isinstance(entry, tuple) and len(entry) in (2, 3)):
                raise SettingsError(f"constraint {entry!r}: give (response, bound) or (scenario, response, bound)")
            *where, response, bound = entry
            if isinstance(bound, bool) or not (isinstance(bound, numbers.Real) and math.isfinite(bound) and bound > 0):
                raise SettingsError(f"constraint {response!r}: the upper bound must be positive and finite, got {bound!r}")
            if is_aggregate(response):
                raise SettingsError(f"constraint {response!r}: stress and buckling limits are normalized to their peaks "
                                    "in a TopologyProblem; a ScenarioProblem does not normalize them")
            if where and where[0] not in index:
                raise SceneError(f"constraint {response!r}: no scenario named {where[0]!r} ({', '.join(index)})")
            if response.split(":")[0] in DESIGN_ONLY and not where:
                out.append((None, response, response, float(bound)))
                continue
            for k in [index[where[0]]] if where else range(len(self.scenarios)):
                out.append((k, response, f"{self.scenarios[k].name}: {response}", float(bound)))
        return out

    @property
    def description(self) -> str:
        """What is minimized, in words."""
        how = "the worst" if self.aggregate is Aggregate.WORST else "the weighted sum of"
        return f"{how} {self.objective} over the scenarios"

    @property
    def bounded(self) -> list[tuple[str, float]]:
        """The constraints with an upper bound, by name (the worst case's rows have none)."""
        return [(name, bound) for _, _, name, bound in self.constraints]

    def densities(self, x: np.ndarray) -> np.ndarray:
        """The densities the scenes are run with at design ``x``: its scenes' variables."""
        return np.asarray(x, dtype=float)[: self.simulations[0].n_design]

    def start(self, x: Any) -> np.ndarray:
        """The design ``x`` of the scenes (one number or one per variable) as a design of
        this problem (``β = 0`` appended for the worst case: the scaled worst case at the
        start design is 1)."""
        x = self.simulations[0]._design(x)
        if x is None:
            raise DesignError("start needs a design of the scenes")
        x = np.asarray(x, dtype=float)
        return np.append(x, 0.0) if self.aggregate is Aggregate.WORST else x

    def unscaled(self, f0: float, g: np.ndarray | None = None) -> float:
        """The aggregate in the response's units from the optimizer's objective ``f0`` (and,
        for the worst case, its constraints ``g``: the largest scenario row, which β bounds
        from above once feasible)."""
        scale = 1.0 if self.objective_scale is None else self.objective_scale
        if self.aggregate is not Aggregate.WORST:
            return scale * f0
        rows = len(self.scenarios)
        return scale * math.exp(f0 + (float(np.max(g[:rows])) if g is not None else 0.0))

    def responses(self, k: int) -> list[str]:
        """What scenario ``k`` computes: the objective, its constraints' responses, and (the
        first scenario) the design-only ones."""
        own = [r for j, r, _, _ in self.constraints if j == k or (j is None and k == 0)]
        return [self.objective, *dict.fromkeys(own)]

    def physical(self, evaluation: Evaluation) -> tuple[float, np.ndarray, np.ndarray]:
        """The aggregate, the constrained quantities — with the worst case, first each
        scenario's ``wₛfₛ``, then the bounded responses — and the aggregate's gradient (with
        the worst case, that of the scenario at the top, and 0 for ``β``), in the
        responses' units."""
        scale = 1.0 if self.objective_scale is None else self.objective_scale
        bounds = np.array([b for *_, b in self.constraints])
        rows = len(self.scenarios) if self.aggregate is Aggregate.WORST else 0
        bounded = (evaluation.g[rows:] + 1.0) * bounds
        if not rows:
            return self.unscaled(evaluation.f0), bounded, evaluation.df0 * scale
        values = scale * np.exp(evaluation.g[:rows] + evaluation.f0)
        top = int(np.argmax(values))
        jac = np.append(evaluation.dg[top, :-1] * values[top], 0.0)
        return float(values[top]), np.concatenate([values, bounded]), jac

    def evaluate(self, x: np.ndarray) -> Evaluation:
        """Objective and constraints with gradients: one run with sensitivities per scenario."""
        x = np.asarray(x, dtype=float)
        if x.shape != (self.n,):
            raise DesignError(f"the design has shape {x.shape}; this problem has {self.n} variables"
                              + (" (the scenes' and β: use start(x))" if self.aggregate is Aggregate.WORST else ""))
        return self._combined(x, measure=self.rule.in_evaluate(x[: self.n_design], held=bool(self.discretizations)))

    def accept(self, x: np.ndarray, evaluation: Evaluation) -> Evaluation:
        """Held to a tolerance: where the accepted design moved by more than ``readapt``
        from the one measured last, every scenario's error is measured there and
        ``evaluation`` replaced by the one on the grids accepted (:mod:`.held`)."""
        x = np.asarray(x, dtype=float)
        moved = self.rule.in_accept(x[: self.n_design])
        return self._combined(x, measure=True) if self._to_tolerance() and moved else evaluation

    def conclude(self, x: np.ndarray, evaluation: Evaluation) -> Evaluation:
        """Held to a tolerance: the design a run returns, where it is not the design
        measured last, has every scenario's error measured and ``evaluation`` replaced by
        the one on the grids accepted there (:mod:`.held`)."""
        x = np.asarray(x, dtype=float)
        return self._combined(x, measure=True) if self._to_tolerance() and self.rule.in_conclude(x[: self.n_design]) \
            else evaluation

    def _to_tolerance(self) -> bool:
        """Whether the evaluations are held to a tolerance (the problem's or a scenario's)."""
        return bool(self.rtol or any(sim.rtol for sim in self.simulations))

    def _combined(self, x: np.ndarray, measure: bool) -> Evaluation:
        """The evaluation at ``x`` from its scenarios' runs, each scenario's error measured
        or its grid held."""
        runs = self._run(x[: self.n_design], measure)
        row = [{name: i for i, name in enumerate(run.names)} for run in runs]
        value = lambda k, name: runs[k].values[row[k][name]]  # noqa: E731
        grad = lambda k, name: runs[k].gradients[row[k][name]]  # noqa: E731
        w = np.array([s.weight for s in self.scenarios])
        f = np.array([w[k] * value(k, self.objective) for k in range(len(runs))])
        df = np.array([w[k] * grad(k, self.objective) for k in range(len(runs))])
        worst = self.aggregate is Aggregate.WORST
        if self.objective_scale is None:
            total = float(np.max(f)) if worst else float(np.sum(f))
            self.objective_scale = abs(total) if total != 0 else 1.0
        scale = self.objective_scale
        g, dg = [], []
        for j, response, _, bound in self.constraints:
            k = 0 if j is None else j
            g.append(value(k, response) / bound - 1.0)
            dg.append(grad(k, response) / bound)
        g_arr, dg_arr = np.array(g).reshape(-1), np.array(dg).reshape(-1, self.n_design)
        if not worst:
            return Evaluation(float(np.sum(f)) / scale, g_arr, np.sum(df, axis=0) / scale, dg_arr)
        if np.any(f <= 0):
            k = int(np.argmin(f))
            raise SettingsError(f"the worst case takes the logarithm of each scenario's {self.objective}, which must be positive; "
                                f"scenario {self.scenarios[k].name!r} has {f[k] / w[k]:.6g}")
        beta = float(x[-1])
        column = lambda rows, v: np.hstack([rows, np.full((rows.shape[0], 1), v)])  # noqa: E731
        df0 = np.append(np.zeros(self.n_design), 1.0)
        return Evaluation(beta, np.concatenate([np.log(f / scale) - beta, g_arr]), df0,
                          np.vstack([column(df / f[:, None], -1.0), column(dg_arr, 0.0)]))

    def _run(self, x: np.ndarray, measure: bool) -> list[Sensitivities | SpatialSensitivities]:
        options: dict[str, Any] = {"method": self.method, **self.settings}
        tolerance = self._to_tolerance()
        held = tolerance and not measure
        if tolerance and measure:
            options |= {"rtol": self.rtol, "atol": self.atol, "hold_gradients": False}
        self.evaluations += 1

        def task(s: Scenario, k: int, sim: Simulation | SpatialSimulation) -> Task:
            if held:
                return Task(sim.spec, x, tuple(self.responses(k)), True, options, sim.options,
                            held=(self.discretizations[s.name], self.rule.at))
            start = {"start": self.discretizations.get(s.name)} if tolerance else {}
            return Task(sim.spec, x, tuple(self.responses(k)), True, options | start, sim.options)

        tasks = [(f"scenario {s.name!r}", task(s, k, sim)) for k, (s, sim) in enumerate(zip(self.scenarios, self.simulations))]
        try:
            runs = execution.run_all(_perform, tasks, self.executor, chunksize=self.chunksize)
        except SimulationError as error:
            raise EvaluationError(str(error), x) from error
        if tolerance and measure:
            self.measured.append(self.evaluations)
            self.rule.measured(x)
        for s, run in zip(self.scenarios, runs):
            if run.discretization is not None:
                self.discretizations[s.name] = run.discretization
            for key, seconds in run.timings.items():
                self.timings[key] = self.timings.get(key, 0.0) + seconds
        return runs

    def to_dict(self) -> dict:
        """What rebuilds this problem (for checkpoints): the scenarios' scenes included."""
        return {"scenarios": [{"name": s.name, "scene": s.spec(), "weight": s.weight} for s in self.scenarios],
                "objective": self.objective, "aggregate": self.aggregate.value,
                "constraints": [list(c) for c in self.given],
                "settings": self.settings, "method": self.method, "objective_scale": self.objective_scale, "rtol": self.rtol,
                "atol": self.atol, "accuracy": self.accuracy, **self.rule.to_dict(),
                "discretizations": {name: spatial_tolerance.saved(d) if isinstance(d, EveryBeam) else list(astuple(d))
                                    for name, d in self.discretizations.items()}}

    def __getstate__(self) -> dict[str, Any]:
        """Pickled without its executor (a pool or a client belongs to the process that made
        it): an unpickled problem runs its scenarios one after the other until given one."""
        return {**self.__dict__, "executor": None}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], executor: Executor | None = None, chunksize: int = 1) -> ScenarioProblem:
        problem = cls([Scenario(s["name"], s["scene"], s["weight"]) for s in data["scenarios"]], data["objective"],
                      [tuple(c) for c in data["constraints"]], aggregate=data["aggregate"], executor=executor, chunksize=chunksize,
                      settings=data["settings"], method=data["method"], objective_scale=data["objective_scale"],
                      rtol=data.get("rtol"), atol=data.get("atol"), accuracy=data.get("accuracy"))
        sims = {s.name: sim for s, sim in zip(problem.scenarios, problem.simulations)}
        problem.discretizations = {name: spatial_tolerance.restored(sims[name], d) if isinstance(sims[name], SpatialSimulation)
                                   else Discretization(*d) for name, d in data.get("discretizations", {}).items()}
        problem.rule = Readapt.from_dict(data)
        return problem


def evaluate(scenarios: Sequence[Scenario], designs: Iterable[Any], responses: Sequence[str] | str, *, gradients: bool = True,
             executor: Executor | None = None, chunksize: int = 1, **options: Any) -> list[dict[str, Sensitivities]]:
    """``responses`` of every scenario at each of ``designs`` (Monte Carlo over payloads,
    parameter studies over motions, multi-starts), as one dict per design from scenario
    name to its result, in the designs' order; ``gradients`` and ``options`` as in
    :meth:`Simulation.map` — a spatial scene's responses come with their gradients always
    (:func:`flextop.spatial.perform`), as :class:`~flextop.spatial.SpatialSensitivities`. The
    runs go to ``executor``, ``chunksize`` to a task."""
    sims = _simulations(_listed("scenarios", scenarios, SceneError), {})
    names = (responses,) if isinstance(responses, str) else tuple(_listed("responses", responses, SettingsError))
    if not all(isinstance(name, str) for name in names):
        raise SettingsError(f"responses: names as text, got {responses!r}")
    vectors = design_vectors(_listed("designs", designs, DesignError), sims[0].n_design)
    tasks = [(f"scenario {s.name!r}, design {i}", Task(sim.spec, x, names, gradients, options, sim.options))
             for i, x in enumerate(vectors) for s, sim in zip(scenarios, sims)]
    flat = execution.run_all(_perform, tasks, executor, chunksize=chunksize)
    n = len(scenarios)
    return [{s.name: flat[i * n + k] for k, s in enumerate(scenarios)} for i in range(len(vectors))]


def robust_robot_arm(*, payloads: Sequence[float] = (0.0, 2.5, 5.0), **scene: Any) -> list[Scenario]:
    """The paper's arm for three motions — the reference (θ from π/3 to π/2 at 0.5 rad/s,
    2 rad/s²), the same twice as fast (1 rad/s, 8 rad/s², on half the step: 0.01 s) and a
    shorter move to another end pose (π/3 to 5π/12) — each with each of ``payloads`` (kg at
    the tip): nine scenarios, named ``"reference, 5 kg"`` and so on."""
    motions = {"reference": {}, "twice as fast": {"speed": 1.0, "acceleration": 8.0, "h": 0.01},
               "to 75°": {"theta_end": 5 * math.pi / 12}}
    return [Scenario(f"{motion}, {payload:g} kg", scenes.robot_arm(tip_mass=payload, **(changes | scene)))
            for motion, changes in motions.items() for payload in payloads]

