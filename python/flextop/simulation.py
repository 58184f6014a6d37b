"""Running a scene: :class:`Simulation` and its :class:`Results`.

``Simulation(scene).run(x)`` integrates a dynamic scene with generalized-α (paper
Algorithm 1) or solves a static one, for the design ``x`` (one density per design
variable, ``None`` for full density). The engine releases the GIL while it runs.
"""

from __future__ import annotations

import copy
import os
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any, Iterator, Sequence

import numpy as np
import scipy.sparse as sp

from . import _core
from .accuracy import preset, refine
from .errors import DesignError
from .scene import Scene


def _as_spec(scene: Scene | dict | str | os.PathLike) -> dict:
    if isinstance(scene, Scene):
        return scene.to_dict()
    if isinstance(scene, dict):
        return scene
    return Scene.from_toml(Path(scene)).to_dict()


@dataclass(frozen=True)
class Joint:
    """A joint of the scene: its ``kind`` (``"clamp"``, ``"pin"``, ``"hinge"``), node
    indices, the ``range`` of its constraint rows in ``lam`` (the drive row last) and
    whether a motion law drives it."""

    name: str
    kind: str
    nodes: tuple[int, ...]
    rows: range
    driven: bool


@dataclass(frozen=True, eq=False)
class Bars:
    """The scene's bars, one entry per bar in each array: ``name``, end ``nodes``
    ``(n_bars, 2)``, design ``variable`` (−1 for a bar of fixed full density), ``component``
    index into :attr:`Simulation.components`, full-density ``volume`` (m³)."""

    name: tuple[str, ...]
    nodes: np.ndarray
    variable: np.ndarray
    component: np.ndarray
    volume: np.ndarray

    def __len__(self) -> int:
        return len(self.name)


@dataclass(frozen=True, eq=False)
class Sensitivities:
    """Responses and their exact gradients from :meth:`Simulation.run_with_sensitivities`.

    Unpacks as ``f, dfdx = ...``. ``values`` has shape ``(n_r,)``, ``gradients``
    ``(n_r, n_design)``, in the order of ``names``; ``method`` is the method used
    (``"direct"`` or ``"adjoint"``) and ``timings`` the seconds spent in the simulation and
    in the sensitivity analysis.
    """

    names: tuple[str, ...]
    values: np.ndarray
    gradients: np.ndarray
    method: str
    timings: dict[str, float]

    def __iter__(self) -> Iterator[np.ndarray]:
        return iter((self.values, self.gradients))

    def __getitem__(self, index: int) -> np.ndarray:
        return (self.values, self.gradients)[index]

    def __len__(self) -> int:
        return 2

    def __repr__(self) -> str:
        pairs = ", ".join(f"{n}={v:.6g}" for n, v in zip(self.names, self.values))
        return f"Sensitivities({pairs}; method={self.method!r})"


class Simulation:
    """A validated scene, ready to run for any design.

    Parameters
    ----------
    scene:
        A :class:`Scene`, a scene dict, or the path of a TOML scene file.
    accuracy:
        ``"fast"``, ``"balanced"`` or ``"accurate"``: a preset of :mod:`flextop.accuracy`
        refining the scene (elements per bar, step size) and the Newton tolerance; settings
        passed to :meth:`run` still win.

    Raises
    ------
    SceneError
        If the scene cannot be built; the message names the entry.
    """

    def __init__(self, scene: Scene | dict | str | os.PathLike, *, accuracy: str | None = None) -> None:
        spec = _as_spec(scene)
        self.spec = copy.deepcopy(spec)
        self.accuracy = accuracy
        self._defaults: dict[str, Any] = {}
        if accuracy is not None:
            chosen = preset(accuracy)
            spec = refine(spec, chosen)
            self._defaults["tol"] = chosen.tol
        self.model = _core.Model.from_dict(spec)
        raw = self.model.bars()
        self.bars = Bars(tuple(raw["name"]), np.asarray(raw["nodes"], dtype=int), np.asarray(raw["variable"], dtype=int),
                         np.asarray(raw["component"], dtype=int), np.asarray(raw["volume"]))
        self.joints = tuple(Joint(j["name"], j["kind"], tuple(j["nodes"]), range(*j["rows"]), j["driven"]) for j in self.model.joints())

    # -- description --------------------------------------------------------------------

    @property
    def analysis(self) -> str:
        """``"dynamic"`` or ``"static"``."""
        return self.model.analysis

    @property
    def n_design(self) -> int:
        """Number of design variables."""
        return self.model.n_design

    @property
    def x_min(self) -> float:
        """Lower bound on densities."""
        return self.model.x_min

    @property
    def node_names(self) -> list[str]:
        return self.model.node_names

    @property
    def variable_names(self) -> list[str]:
        return self.model.variable_names

    @property
    def components(self) -> list[str]:
        return self.model.components

    @property
    def tip(self) -> int | None:
        """Index of the scene's tip node."""
        return self.model.tip

    def node(self, name: str) -> int:
        """Index of the node called ``name``."""
        try:
            return self.model.node_names.index(name)
        except ValueError:
            raise KeyError(f"no node named {name!r}") from None

    # -- runs ---------------------------------------------------------------------------

    def run(self, x: Any = None, *, t_end: float | None = None, h: float | None = None, rho_inf: float | None = None,
            tol: float | None = None, max_iter: int | None = None, mass: str | None = None,
            load_steps: int | None = None) -> Results | StaticResults:
        """Runs the scene for design ``x`` (``None``: every bar at full density).

        Dynamic scenes integrate to ``t_end`` with step ``h`` — shortened, if needed, so that
        a whole number of steps ends exactly at ``t_end``; ``results.raw["h"]`` is the step
        used — and spectral radius ``rho_inf`` (defaults from the scene's ``[simulation]``
        table, ``rho_inf`` 0.8);
        ``tol`` is the relative Newton tolerance (1e-10), ``max_iter`` the iterations per
        step (20), ``mass`` ``"consistent"`` or ``"lumped"``. Static scenes solve the
        equilibrium with ``load_steps`` initial load increments.

        Raises ``DesignError``, ``SettingsError`` or ``SimulationError`` (with the time,
        residual and iteration count of a failed Newton step).
        """
        xv = self._design(x)
        if self.analysis == "static":
            settings = self._settings(t_end=t_end, tol=tol, max_iter=max_iter, load_steps=load_steps)
            return StaticResults(self, _core.solve_static(self.model, xv, settings), xv)
        settings = self._settings(t_end=t_end, h=h, rho_inf=rho_inf, tol=tol, max_iter=max_iter, mass=mass)
        return Results(self, _core.simulate(self.model, xv, settings), xv)

    def _settings(self, **given: Any) -> dict[str, Any]:
        """Run settings given explicitly, over the accuracy preset's defaults."""
        return {**self._defaults, **{k: v for k, v in given.items() if v is not None}}

    def run_with_sensitivities(self, x: Any, responses: Sequence[str] | str = ("tip_deflection",), *,
                               method: str = "auto", memory: str = "auto", **settings: Any) -> Sensitivities:
        """Responses ``f`` (shape ``(n_r,)``) and their exact gradients ``df/dx``
        (``(n_r, n_design)``) for design ``x``, as a :class:`Sensitivities` that unpacks as
        ``f, dfdx``.

        Responses, by name: ``"compliance"`` (mean compliance over the motion, paper Eq. 39,
        or ``Fᵀu`` for a static scene), ``"compliance:COMPONENT"``, ``"tip_deflection"``
        (mean squared deflection from the rigid trajectory, Eq. 40; the scene's tip, or
        ``"tip_deflection:NODE"``), ``"volume"`` / ``"volume:COMPONENT"`` (m³, Eq. 38, 41),
        ``"displacement:NODE:DX,DY"`` (final) and ``"integrated_displacement:NODE:DX,DY"``.
        Time integrals use the trapezoidal rule on the step times, and the gradients are
        those of that discrete value.

        ``method``: ``"direct"`` (Algorithm 2; cost grows with the number of variables),
        ``"adjoint"`` (cost independent of it) or ``"auto"`` (adjoint when there are fewer
        responses than variables). ``memory`` (adjoint): ``"store"`` keeps every step's
        state, ``"checkpoints"`` keeps full states every ⌈√N⌉ steps and replays segments
        backwards (memory O(√N), one more forward sweep), ``"auto"`` checkpoints past 512 MiB.
        ``settings`` are those of :meth:`run`. The result tells the method used and the
        seconds spent in the simulation and in the sensitivity analysis.
        """
        names = [responses] if isinstance(responses, str) else list(responses)
        xv = self._design(x)
        if xv is None:
            raise TypeError("run_with_sensitivities needs a design vector x")
        out = _core.run_with_sensitivities(self.model, xv, names, self._settings(method=method, memory=memory, **settings))
        timings = {"simulation": out["simulation_seconds"], "gradients": out["gradient_seconds"]}
        return Sensitivities(tuple(names), out["values"], out["gradients"], out["method"], timings)

    def as_built(self, x: Any, threshold: float | None = None) -> tuple[Simulation, np.ndarray]:
        """The design ``x`` as it would be built: its void bars removed.

        Bars of ground structures whose density is at most ``threshold`` (default: at
        ``x_min``) are left out of the scene, with the grid nodes only they touched; the
        rest keep their names, densities and the scene's material law. Returns the new
        :class:`Simulation` (same accuracy preset) and its design vector, so that a final
        design can be judged without void bars, e.g. on a refined discretization. Raises
        ``SceneError`` if what remains is not a mechanism (a joint's node was removed, a
        frame falls apart).
        """
        xv = self._design(x)
        if xv is None or xv.shape != (self.n_design,):
            raise DesignError(f"as_built needs a design vector of {self.n_design} densities")
        limit = self.x_min * (1.0 + 1e-9) if threshold is None else float(threshold)
        void = {name for name, v in zip(self.bars.name, self.bars.variable) if v >= 0 and xv[v] <= limit}
        spec = copy.deepcopy(self.spec)
        for g in spec.get("ground_structures", []):
            prefix = f"{g['name']}/bar"
            omit = set(g.get("omit", [])) | {int(n[len(prefix):]) for n in void if n.startswith(prefix) and n[len(prefix):].isdigit()}
            g["omit"] = sorted(omit)
        built = Simulation(spec, accuracy=self.accuracy)
        index = {name: k for k, name in enumerate(self.variable_names)}
        return built, np.array([xv[index[name]] for name in built.variable_names])

    def _design(self, x: Any) -> np.ndarray | None:
        if x is None:
            return None
        xv = np.asarray(x, dtype=float)
        if xv.ndim == 0:
            return np.full(self.n_design, float(xv))
        return np.ascontiguousarray(xv)

    def linearize(self, x: Any = None, q: Any = None, *, mass: str | None = None) -> tuple[sp.csc_matrix, sp.csc_matrix, sp.csc_matrix]:
        """Mass ``M``, tangent stiffness ``K_t(q)`` (at the reference state by default) and
        constraint Jacobian ``G = Φ_q`` as scipy sparse matrices."""
        qv = None if q is None else np.ascontiguousarray(q, dtype=float)
        raw = _core.linearize(self.model, self._design(x), qv, self._settings(mass=mass))
        return tuple(sp.csc_matrix((m["data"], m["indices"], m["indptr"]), shape=m["shape"]) for m in (raw[k] for k in ("M", "K", "G")))

    def natural_frequencies(self, n: int = 3, x: Any = None, *, mass: str | None = None) -> np.ndarray:
        """The ``n`` lowest natural frequencies (Hz) of the structure linearized at rest, on
        the subspace allowed by its joints (drives locked)."""
        import scipy.linalg as la

        M, K, G = self.linearize(x, mass=mass)
        basis = la.null_space(G.toarray()) if G.shape[0] else np.eye(M.shape[0])
        Mr, Kr = basis.T @ (M @ basis), basis.T @ (K @ basis)
        eig = la.eigh(Kr, Mr, eigvals_only=True, subset_by_index=[0, n - 1])
        return np.sqrt(np.clip(eig, 0.0, None)) / (2 * np.pi)

    def rigid_positions(self, times: Any) -> np.ndarray:
        """Positions (m) of every node at ``times`` when every frame is rigid and the joints
        follow their drives, shape ``(len(times), n_nodes, 2)``."""
        return _core.rigid_positions(self.model, [float(t) for t in np.atleast_1d(times)])

    def rigid_trajectory(self, node: int | str, times: Any) -> np.ndarray:
        """Position (m) of ``node`` at ``times`` when every frame is rigid and the joints
        follow their drives: the ``r_rigid`` of paper Eq. 40."""
        index = self.node(node) if isinstance(node, str) else int(node)
        if not 0 <= index < len(self.node_names):
            raise IndexError(f"node index {index} out of range")
        return self.rigid_positions(times)[:, index]


@dataclass
class _Run:
    """What dynamic and static results share: the run's data and its joint loads."""

    simulation: Simulation = field(repr=False)
    raw: dict = field(repr=False)
    x: np.ndarray | None = None

    @property
    def q(self) -> np.ndarray:
        """Solved coordinates ``q``: displacements and rotations from the reference
        configuration, three per node (``(u, v, φ)``)."""
        return self.raw["q"]

    @property
    def lam(self) -> np.ndarray:
        """Lagrange multipliers ``λ``, one per constraint row."""
        return self.raw["lam"]

    @cached_property
    def reactions(self) -> dict[str, np.ndarray]:
        """Per joint, the force (and, for a drive row, torque) it applies on the structure:
        ``−λ`` of its constraint rows."""
        return {j.name: -self.lam[..., j.rows.start:j.rows.stop] for j in self.simulation.joints}

    def _evaluate(self, name: str, q: np.ndarray, times: np.ndarray, load_time: float = 0.0) -> float:
        return float(_core.evaluate_responses(self.simulation.model, self.x, q, list(map(float, times)), load_time, [name])[0])


@dataclass
class Results(_Run):
    """Time histories of a dynamic run (one row per time ``t_n``): ``q``, ``qdot``,
    ``qddot``, ``lam``, as the engine and saved files name them.

    ``q`` holds the solved coordinates — displacements and rotations from the reference
    configuration, three per node; :attr:`coordinates` the absolute nodal coordinates
    ``(x, y, φ)`` of the paper.
    """

    @property
    def time(self) -> np.ndarray:
        return self.raw["time"]

    @property
    def coordinates(self) -> np.ndarray:
        """Absolute nodal coordinates ``(x, y, φ)`` per node: ``q`` plus the reference."""
        ref = np.zeros(self.q.shape[1])
        ref.reshape(-1, 3)[:, :2] = self.simulation.model.reference_positions
        return self.q + ref

    @property
    def qdot(self) -> np.ndarray:
        """Velocities ``q̇``."""
        return self.raw["qdot"]

    @property
    def qddot(self) -> np.ndarray:
        """Accelerations ``q̈``."""
        return self.raw["qddot"]

    @cached_property
    def positions(self) -> np.ndarray:
        """Node positions, shape ``(n_times, n_nodes, 2)``."""
        return self.coordinates.reshape(len(self.time), -1, 3)[:, :, :2]

    @cached_property
    def rotations(self) -> np.ndarray:
        """Node rotations from the reference, shape ``(n_times, n_nodes)``."""
        return self.q.reshape(len(self.time), -1, 3)[:, :, 2]

    @cached_property
    def motor_torques(self) -> dict[str, np.ndarray]:
        """Per driven joint, the motor torque applied on the driven node (N m): its drive row,
        the last of its reactions."""
        return {j.name: self.reactions[j.name][..., -1] for j in self.simulation.joints if j.driven}

    @property
    def energies(self) -> dict[str, np.ndarray]:
        """Kinetic, strain, work of the drives and of external loads (J)."""
        return {k: self.raw[k] for k in ("kinetic", "strain", "drive_work", "external_work")}

    @property
    def newton(self) -> dict[str, Any]:
        """Newton statistics: ``iterations`` per step, ``total``, ``max``, ``mean``."""
        its = np.asarray(self.raw["iterations"][1:])
        return {"iterations": its, "total": int(its.sum()), "max": int(its.max(initial=0)), "mean": float(its.mean()) if its.size else 0.0}

    def tip_error(self, node: int | str | None = None) -> np.ndarray:
        """``e(t) = r(t) − r_rigid(t)`` of ``node`` (the scene's tip by default), ``(n, 2)``."""
        index = self._node(node)
        return self.positions[:, index] - self.simulation.rigid_trajectory(index, self.time)

    def response(self, name: str) -> float:
        """Value of a response of :meth:`Simulation.run_with_sensitivities` (e.g.
        ``"compliance"``) on this run — the same discrete value the gradients refer to."""
        return self._evaluate(name, self.q, self.time)

    def tip_deflection(self, node: int | str | None = None) -> float:
        """Mean squared tip deflection ``d = (1/t_f) ∫ |e|² dt`` (paper Eq. 40, m²), by the
        trapezoidal rule on the step times."""
        if node is None:
            return self.response("tip_deflection")
        name = self.simulation.node_names[node] if isinstance(node, int) else node
        return self.response(f"tip_deflection:{name}")

    def _node(self, node: int | str | None) -> int:
        if node is None:
            if self.simulation.tip is None:
                raise ValueError("the scene has no tip; name a node")
            return self.simulation.tip
        return self.simulation.node(node) if isinstance(node, str) else int(node)


@dataclass
class StaticResults(_Run):
    """A static equilibrium."""

    def response(self, name: str) -> float:
        """Value of a response (``"compliance"`` is ``Fᵀu``) at this equilibrium."""
        return self._evaluate(name, self.q[None, :], np.zeros(1), self.raw["time"])

    @property
    def positions(self) -> np.ndarray:
        """Node positions, shape ``(n_nodes, 2)``."""
        return self.simulation.model.reference_positions + self.q.reshape(-1, 3)[:, :2]

    @property
    def newton(self) -> dict[str, Any]:
        return {"total": self.raw["iterations"], "load_steps": self.raw["load_steps"]}

    def displacement(self, node: int | str) -> np.ndarray:
        """Displacement ``(u, v, φ)`` of ``node``."""
        index = self.simulation.node(node) if isinstance(node, str) else int(node)
        return self.q[3 * index:3 * index + 3]
