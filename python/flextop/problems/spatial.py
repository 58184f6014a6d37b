"""Design problems on a spatial scene (:class:`~flextop.spatial.SpatialSimulation`): one
response of its motion or equilibrium minimized over the densities of its beams and bars,
subject to upper bounds on others, with ``x_min ≤ x ≤ 1`` (paper Section 3):

    minimize f(x)   s.t.   r_j(x) ≤ b_j,

seen by the optimizers as ``f0 = f / f_ref`` and ``g_j = r_j / b_j − 1 ≤ 0``, so every
function is of order one; ``f_ref`` is the objective at the first design evaluated unless
given. Responses are those of :meth:`SpatialSimulation.run_with_sensitivities` by name
(``tip_deflection``, ``strain_energy``, ``compliance``, ``z:NODE``, ``reaction:JOINT``,
``torque:JOINT``, ``volume`` …); each
evaluation is one run with its adjoint gradients of every response. A run that fails (a trial
design too weak to carry its motion) becomes an :class:`~flextop.optimizers.EvaluationError`,
which the optimizer recovers from by stepping back.

Held to a tolerance (``rtol``, or the simulation's), the problem follows the planar
problems' rule (:mod:`.held`): a design the optimizer accepts that moved by more than
``readapt`` from the one measured last is measured — the grid refined from the one held
until every response and its gradient meet ``rtol``
(:func:`flextop.discretization.spatial.to_tolerance`) — and every other evaluation runs on
the grid held; the design a run returns is measured as it ends.

A bound on a ``stress``, ``reaction`` or ``torque`` response bounds its peak, as on a planar scene
(:class:`~flextop.problems.TopologyProblem`): the optimizer sees ``g = c P/b − 1``, ``P`` the
p-mean or KS mean, ``c`` the ratio peak/P of the start design, moved once per iteration
towards the ratio at the accepted design (damped by
:data:`~flextop.problems.topology.NORMALIZATION_DAMPING`; Le, Norato, Bruns, Ha & Tortorelli
2010).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..checks import number
from ..discretization import spatial as spatial_tolerance
from ..discretization import tolerance
from ..discretization.tolerance import Discretization
from ..errors import SettingsError, SimulationError
from ..modal import ks_lowest_of
from ..optimizers import Evaluation, EvaluationError, Problem
from ..spatial import SpatialSimulation
from .held import READAPT, Readapt
from .topology import FLOOR_MODES, FLOOR_RHO, MIN_FREQUENCY, normalized, relation, renormalized


def structures_of(sim: SpatialSimulation) -> list[str]:
    """The ground structures of ``sim`` with designed bars, in order."""
    return list(dict.fromkeys(v.split("/")[0] for v in sim.variables if "/" in v))


def volume_bounds(sim: SpatialSimulation, fraction: float, per_structure: bool) -> list[tuple[str, float]]:
    """``fraction`` of each ground structure's full volume as its bound (paper Eq. 41) with
    ``per_structure`` where the scene has such structures, else of the whole."""
    structures = structures_of(sim) if per_structure else []
    if not structures:
        return [("volume", fraction * sim.volume(1.0))]
    return [(f"volume:{name}", fraction * sim.volume(1.0, name)) for name in structures]


class SpatialProblem(Problem):
    """Minimize the response ``objective`` of ``sim`` subject to ``constraints``, each a
    ``(response, upper bound)`` or ``("min_frequency", f_min)``, a floor (Hz) on the lowest
    natural frequency of the structure at rest (KS over its lowest two, exact gradients); ``volume`` (a fraction of the full material volume) adds
    ``("volume", volume · V_full)`` or, ``per_structure``, one ``("volume:NAME", volume ·
    V_full,NAME)`` per ground structure (paper Eq. 41, per link). ``settings`` go to every run
    (``t_end``, ``h``, …). ``rtol``, ``atol`` (default: the simulation's) and ``readapt``: the
    tolerance every value and its gradient are held to and the rule that holds it (module
    docs).

    Raises
    ------
    SettingsError
        For a volume fraction outside (0, 1], a bound that is not positive and finite, a
        reference that is not, a tolerance out of range, or ``h`` with a tolerance.
    """

    def __init__(self, sim: SpatialSimulation, objective: str, constraints: Sequence[tuple[str, float]] = (), *,
                 volume: float | None = None, per_structure: bool = False, reference: float | None = None,
                 rtol: float | None = None, atol: float | None = None, readapt: float = READAPT,
                 **settings: Any) -> None:
        bounds = list(constraints)
        if volume is not None:
            if not (isinstance(volume, (int, float)) and 0.0 < volume <= 1.0):
                raise SettingsError(f"volume: {volume!r} is not a fraction in (0, 1] of the full volume")
            if per_structure and not structures_of(sim):
                raise SettingsError("per_structure: the scene has no ground structure with designed bars")
            bounds += volume_bounds(sim, volume, per_structure)
        for name, bound in bounds:
            if not (isinstance(bound, (int, float)) and np.isfinite(bound) and bound > 0.0):
                raise SettingsError(f"constraint {name!r}: the bound {bound!r} must be positive and finite")
        if reference is not None and not (np.isfinite(reference) and reference > 0.0):
            raise SettingsError(f"reference: {reference!r} must be positive and finite")
        super().__init__(np.full(sim.n_design, sim.x_min), np.ones(sim.n_design), len(bounds),
                         [f"{name} {'≥' if relation(name) == '>=' else '≤'} {bound:.4g}" for name, bound in bounds])
        self.sim, self.objective, self.settings = sim, objective, settings
        self.constraints = [(name, float(bound)) for name, bound in bounds]
        self.responses = [objective, *(name for name, _ in bounds if name != MIN_FREQUENCY)]
        self.bounds = np.array([bound for name, bound in bounds if name != MIN_FREQUENCY], dtype=float)
        self.reference = reference
        #: Each stress bound's factor ``c`` (module docs), set by the first evaluation.
        self.normalization: dict[str, float] = {}
        self._ratios: dict[bytes, dict[str, float]] = {}
        rtol = sim.rtol if rtol is None else rtol
        atol = sim.atol if atol is None else atol
        number("atol", atol, 0.0, math.inf, "[)")  # checked where no rtol reads it too
        if rtol is not None:
            tolerance.check_tolerance(rtol, atol)
            if "h" in settings:
                raise SettingsError("give h (a fixed step) or rtol (steps chosen to meet it), not both")
        self.rtol, self.atol = rtol, atol
        self.tolerance = None if rtol is None else (float(rtol), float(atol))
        #: Where the error is measured, and the grid held since (``None`` before the first).
        self.rule, self.held = Readapt(readapt), None  # type: Readapt, Discretization | None

    def to_dict(self) -> dict:
        """What rebuilds this problem on the same scene (for checkpoints): its responses,
        every bound (a volume fraction's as its volume), the reference and each stress
        bound's factor as they stand."""
        held = None if self.held is None else spatial_tolerance.saved(self.held)
        return {"objective": self.objective, "constraints": [[name, bound] for name, bound in self.constraints],
                "reference": self.reference, "settings": dict(self.settings), "normalization": dict(self.normalization),
                "rtol": self.rtol, "atol": self.atol, "rule": self.rule.to_dict(), "held": held}

    @classmethod
    def from_dict(cls, sim: SpatialSimulation, data: dict) -> SpatialProblem:
        """The problem :meth:`to_dict` describes, on ``sim``."""
        problem = cls(sim, data["objective"], [(name, bound) for name, bound in data["constraints"]],
                      reference=data["reference"], rtol=data.get("rtol"), atol=data.get("atol"), **data["settings"])
        problem.normalization = {str(k): float(v) for k, v in data["normalization"].items()}
        if data.get("rule") is not None:
            problem.rule = Readapt.from_dict(data["rule"])
        if data.get("held") is not None:
            problem.held = spatial_tolerance.restored(sim, data["held"])
        return problem

    def evaluate(self, x: np.ndarray) -> Evaluation:
        """The responses at ``x``: on the scene's grid, or held to the tolerance — measured
        where no grid is held yet (or the caller never accepts and ``x`` moved), else on the
        grid held."""
        return self._evaluated(x, self.rtol is not None and self.rule.in_evaluate(x, self.held is not None))

    def _run(self, x: np.ndarray, measure: bool) -> Any:
        """The run of every response at ``x`` with its adjoint gradients: measured to the
        tolerance (the grid held from then on), on the grid held, or on the scene's grid."""
        static = self.sim.analysis == "static"
        settings = {**self.settings, "method": "adjoint"}
        design = self.sim._design(x)
        if measure and self.tolerance is not None:
            accepted = spatial_tolerance.to_tolerance(self.sim, design, self.responses, [], static,
                                                      self.tolerance, settings, start=self.held)
            self.held = accepted.discretization
            self.rule.measured(x)
            return accepted.sensitivities
        if self.held is not None:
            return spatial_tolerance.on_grid(self.sim, self.held, design, self.responses, [], static, settings)
        return self.sim.run_with_sensitivities(x, self.responses, **settings)

    def _evaluated(self, x: np.ndarray, measure: bool) -> Evaluation:
        try:
            run = self._run(x, measure)
        except SimulationError as error:  # a trial the optimizer steps back from
            raise EvaluationError(str(error), np.asarray(x)) from error
        if self.reference is None:
            if not run.values[0] > 0.0:
                raise SettingsError(f"{self.objective} is {run.values[0]:.3g} at the start: give a positive reference")
            self.reference = float(run.values[0])
        key = np.asarray(x, dtype=float).tobytes()
        factors = np.array([normalized(self.normalization, self._ratios, key, name, value, run.peaks[name])
                            if name in run.peaks else 1.0 for name, value in zip(self.responses[1:], run.values[1:])])
        g = factors * run.values[1:] / self.bounds - 1.0
        dg = (factors / self.bounds)[:, None] * run.dfdx[1:]
        if len(self.responses) <= self.m:  # a frequency floor among the constraints
            g, dg = self._with_floor(x, g, dg)
        return Evaluation(run.values[0] / self.reference, g, run.dfdx[0] / self.reference, dg)

    def _with_floor(self, x: np.ndarray, g: np.ndarray, dg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The constraints with the frequency floor's in its place: ``1 − KS/f_min``, KS over
        the lowest :data:`~flextop.problems.topology.FLOOR_MODES` natural frequencies of the
        structure at rest (its loads, motors and gravity taken away, where their rates are
        exact), as on planar scenes."""
        try:
            modes = self.sim.modes(x, at="rest", count=FLOOR_MODES, parameters=[])
        except SimulationError as error:
            raise EvaluationError(str(error), np.asarray(x)) from error
        f = modes.frequencies
        df = modes.omega_squared_dfdx / (8.0 * np.pi**2 * np.maximum(f, 1e-300))[:, None]
        rows, values, k = [], [], 0
        for name, bound in self.constraints:
            if name == MIN_FREQUENCY:
                ks, dks = ks_lowest_of(f, df, bound, FLOOR_RHO)
                values.append(1.0 - ks / bound)
                rows.append(-dks / bound)
            else:
                values.append(g[k])
                rows.append(dg[k])
                k += 1
        return np.array(values), np.array(rows).reshape(self.m, self.n)

    def accept(self, x: np.ndarray, evaluation: Evaluation) -> Evaluation:
        """Held to a tolerance, the accepted design is measured where it moved by more than
        ``readapt`` (its evaluation replaced); each stress bound's ``c`` moves towards the
        ratio peak/P at the accepted design and its constraint is rescaled to it (module
        docs)."""
        if self.rtol is not None and self.rule.in_accept(x):
            evaluation = self._evaluated(x, True)
        ratios = self._ratios.get(np.asarray(x, dtype=float).tobytes(), {})
        self._ratios = {}
        return renormalized(self.normalization, ratios, [name for name, _ in self.constraints], evaluation)

    def conclude(self, x: np.ndarray, evaluation: Evaluation) -> Evaluation:
        """Held to a tolerance, the design a run returns is measured unless it was the last
        measured: what the result reports meets the tolerance there."""
        if self.rtol is not None and self.rule.in_conclude(x):
            return self._evaluated(x, True)
        return evaluation
