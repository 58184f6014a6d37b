"""Running a spatial scene: :class:`SpatialSimulation`, built once, runs its motion
(generalized-α on the Lie group ℝ³ × SO(3) of each node), its static equilibrium, its
natural modes about an equilibrium, and the exact gradients of its responses to its
densities and parameters, direct or adjoint, over the motion or at the equilibrium. Every run
takes a design ``x`` first: the density of each beam (or design group) not ``fixed``, in
``[x_min, 1]`` (one number for all; full density by default), its stiffness scaled by the
scene's ``[design]`` interpolation and its mass by its mass law.

Responses by name (the engine's registry, :data:`flextop.responses.SPATIAL_NAMES`; a name
means what it means on a planar scene): ``x:NAME``, ``y:NAME``, ``z:NAME`` (a body's centre of
mass or a node's origin at the end of the run, m), ``strain_energy`` (its mean
``(1/t_f) ∫U dt`` over the motion, J; ``U`` at an equilibrium, J), ``kinetic_energy``
(``∫T dt`` over the motion, J s), ``compliance`` (the mean strain energy over the motion, J,
paper Eq. 39; at an equilibrium ``Fᵀu``, the work of the dead forces and gravity, J, refused
where a follower load, a moment or a motor acts), ``torque_squared:JOINT`` (``∫λ² dt`` of a
driven joint's drive row), ``reaction:JOINT[:OPTIONS]`` (the force ``|F|`` the joint transmits, N: its
rows that hold its points together, not a locked rotation's moment; at an equilibrium ``|F|``,
over a motion a p-mean, ``p=8`` by default, or a KS mean, ``ks=RHO,scale=S``, its peak
reported), ``torque:JOINT[:OPTIONS]`` (a drive's torque, N m, or a slide drive's force, N,
condensed likewise), ``volume``
(the beams' and bars' material volume ``Σ xᵢ Vᵢ``, m³) and ``volume:NAME`` (a ground
structure's designed bars', paper Eq. 41 per link), ``mass`` and ``mass:NAME`` (``Σ m(xᵢ) Mᵢ``
by the scene's mass law, kg), ``tip_deflection`` or
``tip_deflection:NAME`` (the mean squared deflection ``(1/t_f) ∫ |r − r_rigid|² dt`` of the
scene's tip, or a body or node, from its rigid trajectory, m², paper Eq. 40: the motion of the
mechanism with each link one rigid body on its joints and drives, every freedom of which the
drives must hold), ``stress[:NAME][:OPTIONS]`` (of every beam and bar, or of one beam or ground
structure ``NAME``: the relaxed stresses ``x^q σ`` of the solid material,
von Mises at each beam section's edge points — stretch, both bendings and torsion — and axial
in each truss bar, condensed over the run and the structure by a p-mean, ``p=8`` by default,
or a KS mean, ``ks=RHO,scale=S``; ``q=`` the relaxation, 0.5 by default, Pa),
``buckling[:NAME][:OPTIONS]`` (the same of the buckling ratios ``x^q b``, each element's
compression over the Euler load ``π² E I_min / L²`` of its bar pin-ended, ``L`` the whole
bar's length, of the solid section; zero in tension; dimensionless).
Parameters by name: ``mass:BODY`` (kg), ``Ixx:BODY`` … ``Iyz:BODY`` (kg m²), ``k:SPRING``,
``c:SPRING``, ``torque:MOTOR``, ``E:BEAM`` and ``rho:BEAM`` (Pa, kg/m³), a dimension of
a beam's section ``diameter:BEAM``, ``outer:BEAM``, ``inner:BEAM``, ``width:BEAM``,
``height:BEAM`` (m: its stiffnesses, inertias and stress points move with it), ``end:JOINT``,
``acceleration:JOINT`` and ``speed:JOINT`` (a trapezoidal drive's law: rad, rad/s², rad/s on
a revolute joint, m, m/s², m/s on a prismatic one; ``tip_deflection``'s rigid trajectory
moves with them too), ``position_x:JOINT``, ``position_y:JOINT`` and ``position_z:JOINT``
(the joint's place along an axis of space where the scene builds it, m: both its anchors'
points move with it in their bodies' frames, the ground's in space, so that the scene
starts as built; a ``tip_deflection``'s rigid trajectory would move too, and is refused
with them).
"""

from __future__ import annotations

import math
import os
import time
from collections import OrderedDict
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Callable, Iterator, Sequence

import numpy as np

from . import _core, plausibility
from .checks import number, whole
from .quaternion import rotations
from .discretization import spatial as spatial_tolerance
from .discretization.accuracy import rtol_of, run_tolerance
from .discretization.indicator import Shares
from .discretization.tolerance import TIME_ESTIMATES, Discretization
from .errors import DesignError, SceneError, SettingsError, SimulationError
from .scenes.builder import read_toml
from .scenes.spatial import SpatialScene, axis_angle
from .simulation import DesignLike, Task, cached, design_vector

NQ, NV = 7, 6
"""Numbers per node: in a configuration (position, unit quaternion w, x, y, z), in a
velocity (velocity in space, angular velocity in the node's axes)."""


@dataclass(frozen=True)
class _Layout:
    """Where a name's numbers are — nodes (bodies on theirs) and joints' rows — and the
    structure's cells: each beam element's or bar's end nodes, its beam's index, its design
    variable's (−1 where fixed) and its section's reach from the axis (m), each body's node,
    each joint's first anchor: its node (−1: the ground) and point in that node's frame."""

    nodes: dict[str, int]
    joints: dict[str, range]
    nodes_in_order: tuple[str, ...]
    lines: tuple[tuple[int, int], ...]
    line_beam: tuple[int, ...]
    bodies: tuple[int, ...]
    line_variable: tuple[int, ...] = ()
    line_radius: tuple[float, ...] = ()
    joint_anchors: tuple[tuple[int, tuple[float, ...]], ...] = ()

    def joint_points(self, q: np.ndarray) -> np.ndarray:
        """Each joint's first anchor in space at the configuration ``q`` (seven numbers per
        node), shape ``(n_joints, 3)`` (m)."""
        points = np.zeros((len(self.joint_anchors), 3))
        nodes = q.reshape(-1, NQ)
        for k, (node, arm) in enumerate(self.joint_anchors):
            points[k] = arm if node < 0 else nodes[node, :3] + rotations(nodes[node, 3:][None])[0] @ np.asarray(arm)
        return points

    def line_densities(self, x: np.ndarray | None) -> np.ndarray:
        """Each line's density at design ``x`` (1 where fixed or at full density)."""
        variable = np.asarray(self.line_variable, dtype=int)
        if x is None:
            return np.ones(len(variable))
        return np.where(variable >= 0, np.asarray(x, dtype=float)[np.maximum(variable, 0)], 1.0)

    def node(self, name: str) -> int:
        if name not in self.nodes:
            raise SettingsError(f"{name!r} is no body or node of the scene (it has {', '.join(self.nodes) or 'none'})")
        return self.nodes[name]

    def rows(self, joint: str) -> range:
        if joint not in self.joints:
            raise SettingsError(f"{joint!r} is no joint of the scene (it has {', '.join(self.joints) or 'none'})")
        return self.joints[joint]


@dataclass(frozen=True)
class SpatialResults:
    """A spatial motion: ``time`` (s), configurations ``q`` (seven numbers per node),
    velocities ``v`` (six), multipliers ``lam`` and the ``kinetic``, ``potential`` and
    ``strain`` energies (J) at each time."""

    time: np.ndarray
    q: np.ndarray
    v: np.ndarray
    lam: np.ndarray
    kinetic: np.ndarray
    potential: np.ndarray
    strain: np.ndarray
    layout: _Layout
    #: The design it ran at (``None``: full density).
    x: np.ndarray | None = None

    def position(self, name: str) -> np.ndarray:
        """A body's centre of mass or a node's origin at each time, shape ``(n, 3)`` (m)."""
        k = self.layout.node(name)
        return self.q[:, NQ * k:NQ * k + 3]

    def rotation(self, name: str) -> np.ndarray:
        """A body's or node's axes in space at each time, shape ``(n, 3, 3)``."""
        k = self.layout.node(name)
        return rotations(self.q[:, NQ * k + 3:NQ * k + 7])

    def to_vtk(self, path: str | os.PathLike, *, every: int | None = None) -> Path:
        """The motion for ParaView: a ``.pvd`` index and its ``.vtu`` frames, about 100 or
        every ``every``-th step (:mod:`flextop.io.spatial_export`)."""
        from .io.spatial_export import write_spatial_motion

        return write_spatial_motion(self, path, every=every)

    def multipliers(self, joint: str) -> np.ndarray:
        """A joint's multipliers at each time, shape ``(n, rows)``: its constraint forces'
        measures (N, N m; a drive's row last)."""
        return self.lam[:, self.layout.rows(joint)]


@dataclass(frozen=True)
class SpatialEquilibrium:
    """A static equilibrium: configuration ``q``, multipliers ``lam``, the ``strain`` energy
    (J), Newton ``iterations`` over ``load_steps``, at ``time`` (s) of the drives' laws and
    the loads."""

    q: np.ndarray
    lam: np.ndarray
    strain: float
    iterations: int
    load_steps: int
    layout: _Layout
    time: float = 0.0
    #: The design it stands at (``None``: full density).
    x: np.ndarray | None = None
    #: The configuration the scene gives, where it started from (seven numbers per node).
    reference: np.ndarray | None = field(default=None, repr=False)

    def position(self, name: str) -> np.ndarray:
        """A body's centre of mass or a node's origin (m)."""
        k = self.layout.node(name)
        return self.q[NQ * k:NQ * k + 3]

    def to_vtk(self, path: str | os.PathLike) -> Path:
        """The equilibrium for ParaView: one ``.vtu`` file, the structure where the scene
        puts it with ``displacement`` to the equilibrium (:mod:`flextop.io.spatial_export`)."""
        from .io.spatial_export import write_spatial_state

        return write_spatial_state(self, self.q if self.reference is None else self.reference, path)

    def rotation(self, name: str) -> np.ndarray:
        """A body's or node's axes in space."""
        k = self.layout.node(name)
        return rotations(self.q[NQ * k + 3:NQ * k + 7])


@dataclass(frozen=True)
class SpatialModes:
    """Every natural mode about a configuration, or the lowest ``count``: ``omega_squared``
    (rad²/s², ascending; negative where it is unstable) and mass-normalized ``shapes`` (one
    row per mode, six numbers per node: displacement in space, rotation in the node's axes);
    for the lowest, the Sturm ``bound`` (rad²/s²) and the count ``below`` it that proves
    none was skipped (``None`` for every mode); the rates of ``omega_squared`` where
    :meth:`SpatialSimulation.modes` was given parameters."""

    omega_squared: np.ndarray
    shapes: np.ndarray
    stable_frequencies: np.ndarray | None = None
    bound: float | None = None
    below: int | None = None
    #: The parameters ``omega_squared_gradient`` is to, by name.
    parameters: tuple[str, ...] = ()
    #: ``∂ω²/∂p`` (rad²/s² per unit), one row per mode, the configuration held.
    omega_squared_gradient: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    #: ``∂ω²/∂x`` to the design's densities, one row per mode, the configuration held.
    omega_squared_dfdx: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))

    @property
    def frequencies(self) -> np.ndarray:
        """The natural frequencies (Hz), ascending. Raises :class:`SimulationError` where the
        configuration is unstable (an ``ω²`` below round-off of the largest, as the engine
        judges)."""
        if self.stable_frequencies is None:
            raise SimulationError(f"the configuration is unstable (ω² down to {self.omega_squared.min():.4g} rad²/s²): "
                                  "it has no natural frequencies")
        return self.stable_frequencies


@dataclass(frozen=True)
class SpatialSensitivities:
    """Responses' ``values``, their exact ``gradient`` to the parameters and ``dfdx`` to the
    design's densities (one row per response), by name; unpacks as ``values, dfdx``."""

    responses: tuple[str, ...]
    parameters: tuple[str, ...]
    values: np.ndarray
    gradient: np.ndarray
    variables: tuple[str, ...] = ()
    dfdx: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    #: The peak behind each aggregated response's mean, by name: ``max |x^q σ|`` of a
    #: ``stress``, ``max |F|`` of a ``reaction``, ``max |τ|`` of a ``torque``.
    peaks: dict[str, float] = field(default_factory=dict)
    #: The grid that ran, where it was chosen to meet a tolerance (``None``: the scene's).
    discretization: Discretization | None = None
    #: Estimated relative errors of the values and of their gradients (2-norm over the
    #: parameters and densities), by name, where a tolerance chose the grid.
    errors: dict[str, float] = field(default_factory=dict)
    gradient_errors: dict[str, float] = field(default_factory=dict)
    #: Each value's time error ``f(h) − f`` to leading order in the step, estimated by the
    #: adjoint sweep of a motion that made the gradients (as :meth:`SpatialSimulation.time_errors`;
    #: none for a volume or a mass, explicit in the design); ``None`` where no such sweep
    #: made them (the direct method, an equilibrium).
    time_errors: np.ndarray | None = field(default=None, repr=False)
    #: Seconds spent, where a task's run was timed (:func:`perform`): ``"runs"``, the
    #: runs with their adjoint sweeps, one engine call each.
    timings: dict[str, float] = field(default_factory=dict)

    def __iter__(self) -> Iterator[np.ndarray]:
        return iter((self.values, self.dfdx))

    @property
    def names(self) -> tuple[str, ...]:
        """The responses' names, as :class:`~flextop.Sensitivities` calls them."""
        return self.responses

    @property
    def gradients(self) -> np.ndarray:
        """The gradients to the densities (:attr:`dfdx`), as :class:`~flextop.Sensitivities`
        calls them."""
        return self.dfdx

    def __getitem__(self, response: str) -> float:
        return float(self.values[self._row(response)])

    def d(self, response: str, parameter: str) -> float:
        """``∂response/∂parameter``."""
        if parameter not in self.parameters:
            raise SettingsError(f"{parameter!r} was not asked for (parameters: {', '.join(self.parameters)})")
        return float(self.gradient[self._row(response), self.parameters.index(parameter)])

    def _row(self, response: str) -> int:
        if response not in self.responses:
            raise SettingsError(f"{response!r} was not asked for (responses: {', '.join(self.responses)})")
        return self.responses.index(response)


def _as_spec(scene: SpatialScene | dict | str | os.PathLike) -> dict:
    if isinstance(scene, SpatialScene):
        return scene.to_dict()
    if isinstance(scene, dict):
        return scene
    return read_toml(Path(scene))


def _names(value: Sequence[str] | str, what: str) -> tuple[str, ...]:
    try:
        names = (value,) if isinstance(value, str) else tuple(value)
    except TypeError:  # not a sequence of names at all
        names = (value,)  # type: ignore[assignment]
    if not all(isinstance(n, str) for n in names):
        raise SettingsError(f"{what}: names as text, got {value!r}")
    return names


def _checked(settings: dict[str, Any]) -> dict[str, Any]:
    """A run's ``settings`` with the unset (``None``) left out and its span and step checked
    (finite and positive) before a grid is made of them; the engine checks the rest."""
    out = {k: v for k, v in settings.items() if v is not None}
    for key in ("t_end", "h"):
        if key in out:
            number(key, out[key], 0.0, math.inf, "()")
    return out


def _finite(what: str, *arrays: np.ndarray) -> None:
    """A :class:`SimulationError` where a run's results left finite numbers: a drive, a load
    or a start beyond the scene's scale ran the motion away."""
    if not all(np.all(np.isfinite(a)) for a in arrays):
        raise SimulationError(f"{what} are not finite numbers: a drive, a load, a rate or a place far beyond the "
                              "scene's scale ran the mechanism away; check the scene's magnitudes")


class SpatialSimulation:
    """A validated spatial scene, ready to run.

    Parameters
    ----------
    scene:
        A :class:`~flextop.scenes.spatial.SpatialScene`, a scene dict (``dimension = 3``) or
        the path of a TOML scene file.
    accuracy, rtol, atol:
        A tolerance for :meth:`run_with_sensitivities` (a preset's name of
        :mod:`flextop.discretization.accuracy`, or ``rtol`` and ``atol``): the elements of
        the frame beams and the steps chosen so that every response's estimated error is
        within ``rtol·|f| + atol`` and its gradients' within ``5·rtol``
        (:mod:`flextop.discretization.spatial`); ``None``: the scene's grid.
    refine:
        How a run to a tolerance refines the beams: ``"bars"`` (the default: a dynamic
        scene's beams graded by their own lowest frequencies and masses, as a planar scene's
        bars; a static scene's alike), ``"shares"`` (graded so, then where a value's space
        error is over, the beams whose measured shares of it carry 80 % refined:
        :meth:`beam_shares`) or ``"uniform"`` (every frame beam alike).

    Raises
    ------
    SceneError
        If the scene cannot be built; the message names the entry.
    SettingsError
        If ``rtol`` is not in [1e-6, 1), ``atol`` is negative, ``accuracy`` is not a preset's
        name, both ``accuracy`` and ``rtol`` are given, or ``refine`` is not one of
        ``"bars"``, ``"shares"`` and ``"uniform"``.
    """

    def __init__(self, scene: SpatialScene | dict | str | os.PathLike, *, accuracy: str | None = None,
                 rtol: float | None = None, atol: float = 0.0, refine: str = "bars") -> None:
        self.accuracy, self.rtol, self.atol = accuracy, rtol_of(accuracy, rtol, atol), atol
        if refine not in spatial_tolerance.REFINE:
            raise SettingsError(f"refine: {refine!r} is not one of {', '.join(spatial_tolerance.REFINE)}")
        self.refine = refine
        #: The scene with every frame beam's elements times a factor, by factor, each built on
        #: first use by a run to a tolerance (:mod:`flextop.discretization.spatial`).
        self.refined: dict[int, SpatialSimulation] = {}
        #: The scene with each frame beam's elements times its own factor, by factors, the
        #: most recently used kept (``refine="bars"``).
        self.graded: OrderedDict[tuple[int, ...], SpatialSimulation] = OrderedDict()
        self.spec = _as_spec(scene)
        self.model = _core.SpatialModel.from_dict(self.spec)
        points = [entry["position"] for key in ("rigid_bodies", "nodes") for entry in self.spec.get(key, [])]
        plausibility.check(self.spec, float(np.linalg.norm(np.ptp(points, axis=0))) if points else 0.0)
        nodes = {name: k for k, name in enumerate(self.model.node_names)}
        nodes.update(dict(self.model.body_nodes))
        beams, variables, radii = self.model.beams, self.model.beam_variables, self.model.beam_radii
        anchors = tuple((-1 if nodes_[0] is None else int(nodes_[0]), tuple(map(float, arms[0])))
                        for _, _, nodes_, arms in self.model.joint_anchors)
        self.layout = _Layout(nodes, {name: range(a, b) for name, a, b in self.model.joint_rows}, tuple(self.model.node_names),
                              tuple((int(a), int(b)) for _, ends in beams for a, b in ends),
                              tuple(k for k, (_, ends) in enumerate(beams) for _ in ends),
                              tuple(node for _, node in self.model.body_nodes),
                              tuple(-1 if v is None else v for (_, ends), v in zip(beams, variables) for _ in ends),
                              tuple(r for (_, ends), r in zip(beams, radii) for _ in ends), anchors)

    def __reduce__(self) -> tuple[Any, tuple[dict, dict[str, Any]]]:
        """Pickled as its scene and :attr:`options`, built again where it is unpickled (as a
        :class:`~flextop.Simulation` is): it can be sent to another process or a cluster."""
        return rebuilt, (self.spec, self.options)

    @property
    def options(self) -> dict[str, Any]:
        """The keyword arguments that rebuild this simulation from its scene: ``accuracy``,
        or ``rtol`` and ``atol``, and ``refine``."""
        return {"accuracy": self.accuracy, "rtol": None if self.accuracy else self.rtol, "atol": self.atol,
                "refine": self.refine}

    @property
    def analysis(self) -> str:
        """``"dynamic"`` or ``"static"``."""
        return str(self.model.analysis)

    @property
    def tip(self) -> str | None:
        """The body or node whose final position is the default response."""
        return self.model.tip

    def _design(self, x: DesignLike) -> list[float] | None:
        xv = self.design(x)
        return None if xv is None else xv.tolist()

    def design(self, x: DesignLike) -> np.ndarray | None:
        """Design ``x`` as a vector of :attr:`variables` (``None``: full density), each in
        ``[x_min, 1]``, or the :class:`~flextop.errors.DesignError` a run would raise."""
        xv = design_vector(x, self.n_design)
        if xv is not None:
            outside = np.flatnonzero(~((xv >= self.x_min) & (xv <= 1.0)))
            if outside.size:
                k = int(outside[0])
                raise DesignError(f"x[{k}] ({self.variables[k]}) = {xv[k]} is outside [{self.x_min}, 1]")
        return xv

    @property
    def variables(self) -> tuple[str, ...]:
        """The design variables' names: each beam's (or design group's) density, in the
        order of ``x``."""
        return tuple(self.model.variables)

    @property
    def n_design(self) -> int:
        """The number of design variables."""
        return len(self.model.variables)

    @property
    def x_min(self) -> float:
        """The lower bound on the densities."""
        return float(self.model.x_min)

    def run(self, x: DesignLike = None, **settings: Any) -> SpatialResults | SpatialEquilibrium:
        """The scene's analysis at design ``x``: :meth:`simulate` or :meth:`equilibrium`."""
        return self.simulate(x, **settings) if self.analysis == "dynamic" else self.equilibrium(x, **settings)

    def simulate(self, x: DesignLike = None, *, progress: Callable[[float], None] | None = None,
                 **settings: Any) -> SpatialResults:
        """The motion at design ``x`` (densities of :attr:`variables`, each in
        ``[x_min, 1]``; full density by default) over ``t_end`` in steps ``h`` (the scene's
        ``[simulation]`` defaults overridden by ``settings``: ``t_end``, ``h``, ``rho_inf``,
        ``tol``, ``max_iter``); ``progress`` is called with the time reached (s)."""
        design = self._design(x)
        r = self.model.simulate(_checked(settings), progress, design)
        _finite("the motion's states or energies", *(np.asarray(r[k]) for k in ("q", "v", "kinetic", "potential", "strain")))
        return SpatialResults(np.asarray(r["time"]), np.asarray(r["q"]), np.asarray(r["v"]), np.asarray(r["lam"]),
                              np.asarray(r["kinetic"]), np.asarray(r["potential"]), np.asarray(r["strain"]), self.layout,
                              None if design is None else np.asarray(design))

    def equilibrium(self, x: DesignLike = None, **settings: Any) -> SpatialEquilibrium:
        """The static equilibrium at design ``x`` under the loads and with the drives at
        ``t_end`` (the scene's ``[simulation]`` one by default, else 0), by Newton on the
        group with ``load_steps``: the drives move with the load factor, so that a mechanism
        they carry far from its start is reached step by step."""
        settings = _checked(settings)
        r = self.model.solve_static(settings, self._design(x))
        _finite("the equilibrium's state or its strain energy", np.asarray(r["q"]), np.asarray(r["strain"]))
        time = float(settings.get("t_end", self.model.options().get("t_end", 0.0)))
        design = self._design(x)
        return SpatialEquilibrium(np.asarray(r["q"]), np.asarray(r["lam"]), float(r["strain"]), int(r["iterations"]),
                                  int(r["load_steps"]), self.layout, time, None if design is None else np.asarray(design),
                                  np.asarray(self.model.initial_q))

    def modes(self, x: DesignLike = None, at: SpatialEquilibrium | str | None = None, count: int | None = None,
              parameters: Sequence[str] | str | None = None, **settings: Any) -> SpatialModes:
        """The natural modes at design ``x`` about the equilibrium ``at`` (the static
        equilibrium at ``t_end`` by default, :meth:`equilibrium`; ``"rest"``: the structure at
        rest, its initial configuration with its loads, motors and gravity taken away), drives
        locked at its time:
        every one (a dense
        solve, at most 1500 unknowns), or with ``count`` the lowest ``count`` by
        shift-invert Lanczos on the sparse matrices, any size, with the Sturm count that
        proves none was skipped (``bound``, ``below``).

        Given ``parameters`` (``[]`` for the densities alone), their rates ``∂ω²/∂p`` to them by name (a body's ``mass:`` and ``Ixx:`` …,
        a beam's ``E:``, ``rho:`` and section sizes ``diameter:`` …) and ``∂ω²/∂x`` to the
        densities, with the configuration held (``omega_squared_gradient``,
        ``omega_squared_dfdx``): exact about an unloaded state (``at="rest"``), where the
        state does not move with them; about a loaded equilibrium the prestress's own change is left out.
        Within a cluster of equal frequencies only the cluster's sum has a rate (the sum of
        these)."""
        wanted = None if count is None else whole("count", count)
        names = None if parameters is None else _names(parameters, "parameters")
        if not (at is None or isinstance(at, (str, SpatialEquilibrium))):
            raise SettingsError(f"at: give an equilibrium (SpatialEquilibrium), \"rest\" or nothing, got {at!r}")
        wanted_names = None if names is None else list(names)
        if isinstance(at, str):
            if at != "rest":
                raise SettingsError(f"at: {at!r} is neither an equilibrium nor \"rest\"")
            try:
                r = self.model.natural_modes(None, None, 0.0, self._design(x), wanted, wanted_names)
            except SimulationError as error:
                raise type(error)(f"at rest (the initial configuration, its loads, motors and gravity taken away, "
                                  f"no constraint force; a preloaded spring holds it elsewhere): {error}") from None
        else:
            eq = self.equilibrium(x, **settings) if at is None else at
            r = self.model.natural_modes(list(eq.q), list(eq.lam), eq.time, self._design(x), wanted, wanted_names)
        frequencies = None if r["frequencies"] is None else np.asarray(r["frequencies"])
        modes = SpatialModes(np.asarray(r["omega_squared"]), np.asarray(r["shapes"]), frequencies, r["bound"], r["below"])
        if names is None or r["omega_squared_rates"] is None:
            return modes
        rates = np.asarray(r["omega_squared_rates"]).reshape(len(modes.omega_squared), -1)
        return replace(modes, parameters=names, omega_squared_gradient=rates[:, :len(names)],
                       omega_squared_dfdx=rates[:, len(names):])

    def rigid_trajectory(self, name: str | None = None, **settings: Any) -> np.ndarray:
        """The rigid trajectory of a body's centre or a node's origin (the scene's tip by
        default) on the grid :meth:`simulate` runs with ``settings``: where it goes with every
        link rigid on its joints and drives (paper Eq. 40's ``r_rigid``), shape ``(n, 3)`` (m);
        a :class:`SettingsError` where the drives leave the rigid mechanism a freedom."""
        name = self.tip if name is None else name
        if name is None:
            raise SettingsError("no name given, and the scene names no tip")
        return np.asarray(self.model.rigid_trajectory(self.layout.node(name), settings))

    def run_with_sensitivities(self, x: DesignLike = None, responses: Sequence[str] | str | None = None,
                               parameters: Sequence[str] | str = (), *, equilibrium: bool | None = None,
                               rtol: float | None = None, atol: float | None = None, time_estimate: str = "adjoint",
                               extrapolate: bool = True, start: Discretization | None = None,
                               **settings: Any) -> SpatialSensitivities:
        """The ``responses`` at design ``x`` (full density by default; the tip's x, y, z by
        default) and their exact gradients to the densities (``dfdx``, one column per design
        variable) and to the ``parameters`` (module docs), over the motion or, with
        ``equilibrium`` (the default of a static scene), at the static equilibrium;
        ``method`` ``"direct"``, ``"adjoint"`` or ``"auto"`` among the settings. The result
        unpacks as ``f, dfdx``.

        With a tolerance (``rtol`` and ``atol``, or the simulation's), the elements of every
        frame beam and the steps are chosen to meet it (:mod:`flextop.discretization.spatial`;
        an explicit ``h`` runs the scene's grid instead, and cannot be given with ``rtol``):
        the gradients are exact for the grid that ran, and the result carries its
        ``discretization`` and the estimated relative ``errors`` and ``gradient_errors``.
        ``time_estimate``: as :meth:`flextop.Simulation.run_with_sensitivities`' — a
        candidate's time errors by its own adjoint sweep where they agree with its half steps
        (``"adjoint"``), or by step doubling alone (``"doubling"``). With ``extrapolate`` (the
        default), a motion's candidate is also judged on Richardson's extrapolation in the
        step from its half steps, and where that is the more accurate the values, gradients
        and peaks are the extrapolation of the two runs (``discretization.extrapolated``).
        ``start``: the grid the candidates start from (a ``discretization`` a run to a
        tolerance returned, near this design; the scene's by default)."""
        if responses is None:
            if self.tip is None:
                raise SettingsError("no responses given, and the scene names no tip")
            responses = [f"{axis}:{self.tip}" for axis in "xyz"]
        rs, ps = _names(responses, "responses"), _names(parameters, "parameters")
        settings = _checked(settings)
        if not (start is None or isinstance(start, Discretization)):
            raise SettingsError(f"start: give a discretization a run to a tolerance returned, got {start!r}")
        static = self.analysis == "static" if equilibrium is None else bool(equilibrium)
        wanted = self._tolerance(rtol, atol, settings.get("h"))
        if wanted is not None:
            if time_estimate not in TIME_ESTIMATES:
                raise SettingsError(f"time_estimate must be one of {', '.join(map(repr, TIME_ESTIMATES))}, "
                                    f"got {time_estimate!r}")
            accepted = spatial_tolerance.to_tolerance(self, self._design(x), rs, ps, static, wanted, settings, start=start,
                                                      time_estimate=time_estimate, extrapolate=extrapolate)
            return replace(accepted.sensitivities, responses=rs, discretization=accepted.discretization,
                           errors=accepted.errors, gradient_errors=accepted.gradient_errors)
        design = self._design(x)
        measured = {k: self._measure(name, design) for k, name in enumerate(rs) if name.split(":")[0] in MEASURES}
        densities = [p for p in ps if p.startswith("rho:")]
        sizes = [p for p in ps if p.split(":")[0] in SIZE_PARAMETERS]
        masses = [rs[k] for k in measured if rs[k].split(":")[0] == "mass"]
        if densities and masses:  # with the sections' sizes, the only parameters a measured response reads
            raise SettingsError(f"{masses[0]!r} to {densities[0]!r}: a mass's derivative to a material density is not "
                                "built; ask for them in two calls")
        if sizes and measured:
            raise SettingsError(f"{rs[next(iter(measured))]!r} to {sizes[0]!r}: a volume's or mass's derivative to a "
                                "section's size is not built here (SizingProblem gives them by section); ask for them in "
                                "two calls")
        engine = [name for k, name in enumerate(rs) if k not in measured]
        values, gradient = np.zeros(len(rs)), np.zeros((len(rs), len(ps) + self.n_design))
        if engine or not rs:
            r = self.model.sensitivities(engine, list(ps), settings, static, design)
            rows = [k for k in range(len(rs)) if k not in measured]
            values[rows] = np.asarray(r["values"])
            gradient[rows] = np.asarray(r["gradient"]).reshape(len(engine), len(ps) + self.n_design)
        peaks: dict[str, float] = {}
        by_adjoint = not static and settings.get("method", "auto") != "direct"
        time_errors: np.ndarray | None = np.zeros(len(rs)) if by_adjoint else None  # a measured response: none in time
        if engine or not rs:
            peaks = {name: peak for name, peak in zip(engine, r["peaks"]) if peak is not None}
            if r["time_errors"] is None:
                time_errors = None
            else:
                time_errors[rows] = np.asarray(r["time_errors"])
        for k, (value, slope) in measured.items():
            values[k], gradient[k, len(ps):] = value, slope
        _finite("the responses or their gradients", values, gradient)
        return SpatialSensitivities(rs, ps, values, gradient[:, :len(ps)], self.variables, gradient[:, len(ps):], peaks,
                                    time_errors=time_errors)

    def time_errors(self, x: DesignLike = None, responses: Sequence[str] | str | None = None, *, steps: int | None = None,
                    **settings: Any) -> dict[str, tuple[float, float]]:
        """Each response's value for design ``x`` on ``steps`` uniform steps (the scene's step
        by default; other settings as in :meth:`run`) and its time error ``f(h) − f`` to
        leading order in the step, estimated from that run alone: generalized-α's local
        errors on the group (the increment's, with its ``(h³/12) ω × ω̇``, and the
        velocities'), weighted by the run's adjoint, one backward sweep, with the
        trapezoidal rule's own error on a time sum. The space error is not in it."""
        if self.analysis != "dynamic":
            raise SettingsError("a time error is a motion's; this scene is static")
        rs = _names(responses if responses is not None else ["strain_energy"], "responses")
        if not rs:
            raise SettingsError("responses: give at least one response")
        settings = _checked(settings)
        duration = settings.get("t_end") or self.spec.get("simulation", {}).get("t_end")
        if steps is not None:
            if isinstance(steps, bool) or not (isinstance(steps, (int, np.integer)) and steps >= 1):
                raise SettingsError(f"steps must be a positive whole number, got {steps!r}")
            if duration is None:
                raise SettingsError("t_end: give it in the scene's [simulation] table or to the run")
            settings = {**settings, "h": float(duration) / int(steps)}
        out = self.model.time_errors(list(rs), settings, self._design(x))
        return {name: (float(out["values"][k]), float(out["errors"][k])) for k, name in enumerate(rs)}

    def beam_shares(self, x: DesignLike = None, responses: Sequence[str] | str | None = None,
                    **settings: Any) -> Shares:
        """Each scene beam's share of the change of ``responses`` (the tip's deflection by
        default) at design ``x`` when the elements of every frame beam are split in two:
        where refinement pays, measured by dual-weighted residuals on the rotation group
        (``src/spatial/shares.rs``). One run of this scene and of the split one, and two
        adjoint sweeps of this one, with ``settings`` as in :meth:`run`.
        ``shares.shares[name]`` follows ``self.model.beams`` (a truss bar's is zero);
        ``shares.change`` is the change measured, ``unattributed`` what the shares leave of
        it (a stress's own reading of the split beams; a strain or kinetic energy's is in
        the shares)."""
        if self.analysis != "dynamic":
            raise SettingsError("beam shares are measured on a dynamic run; a static scene's refinement is uniform")
        rs = _names(responses if responses is not None else ["tip_deflection"], "responses")
        if not rs:
            raise SettingsError("responses: give at least one response")
        measured = [r for r in rs if r.split(":")[0] in MEASURES]
        if measured:
            raise SettingsError(f"responses: {measured[0]!r} is explicit in the design: splitting a beam does not change it")
        fine = spatial_tolerance.refined_level(self, 2)
        return spatial_tolerance.beam_shares(self, self._design(x), rs, settings, fine)

    def _tolerance(self, rtol: float | None, atol: float | None, h: float | None) -> tuple[float, float] | None:
        """The tolerance a run is made to, or ``None`` for a run on the scene's grid
        (:func:`~flextop.discretization.accuracy.run_tolerance`)."""
        return run_tolerance((self.rtol, self.atol), rtol, atol, h)

    def volume(self, x: DesignLike = None, structure: str | None = None) -> float:
        """The material volume ``Σ xᵢ Vᵢ`` of the beams and bars at design ``x`` (full density
        by default), the fixed ones' at full density (m³; paper Eq. 38); of one ground
        structure's designed bars with ``structure`` (its name; Eq. 41's per link)."""
        return self._measure("volume" if structure is None else f"volume:{structure}", self._design(x))[0]

    def mass(self, x: DesignLike = None, structure: str | None = None) -> float:
        """The mass ``Σ m(xᵢ) Mᵢ`` of the beams and bars at design ``x`` (full density by
        default; ``m`` the scene's mass law, ``Mᵢ`` a variable's bars' solid mass), the fixed
        ones' at full density (kg); of one ground structure's designed bars with
        ``structure``."""
        return self._measure("mass" if structure is None else f"mass:{structure}", self._design(x))[0]

    def _measure(self, response: str, design: list[float] | None) -> tuple[float, np.ndarray]:
        """The value and density gradient of ``volume`` or ``mass`` (every beam and bar)
        or ``volume:NAME``, ``mass:NAME`` (the designed bars of ground structure ``NAME``,
        no fixed part), explicit in the design checked before."""
        kind, _, name = response.partition(":")
        x = np.ones(self.n_design) if design is None else np.asarray(design, dtype=float)
        if kind == "volume":
            full, fixed = self.model.volumes
            values, slopes = x * np.asarray(full), np.asarray(full)
        else:
            masses, rates, fixed = self.model.masses(None if design is None else list(design))
            values, slopes = np.asarray(masses), np.asarray(rates)
        if not name:
            return fixed + float(values.sum()), slopes
        mine = np.array([v.startswith(f"{name}/") for v in self.variables], dtype=bool)
        if not mine.any():
            raise SettingsError(f"{response!r}: '{name}' is no ground structure with designed bars")
        return float(values[mine].sum()), np.where(mine, slopes, 0.0)


MEASURES = spatial_tolerance.MEASURED
"""Responses explicit in the design, measured here rather than by a run."""

SIZE_PARAMETERS = ("diameter", "outer", "inner", "width", "height")
"""Parameters of a beam's section size by kind (``outer:BEAM`` …): what a measured response's
volume and mass change with besides the densities."""


def rebuilt(scene: dict, options: dict[str, Any]) -> SpatialSimulation:
    """The :class:`SpatialSimulation` of ``scene`` with ``options``: what an unpickled one is."""
    return SpatialSimulation(scene, **options)


def perform(task: Task) -> SpatialSensitivities:
    """Runs ``task`` (a :class:`~flextop.simulation.Task` on a spatial scene) on this
    process's :class:`SpatialSimulation` of its scene, built on first use: its responses
    with their gradients to the densities — on the grid ``task.held`` holds, or to the
    tolerance its options give (``rtol``, ``atol``, ``start``; the gradients held to it too),
    or on the scene's grid. A spatial scene's responses come from its adjoint sweep, so they
    come with their gradients even where the task asks for none. Timed as ``"runs"``."""
    sim = cached(task.scene, task.simulation, make=SpatialSimulation)
    options = {k: v for k, v in task.options.items() if k != "hold_gradients"}
    began = time.perf_counter()
    if task.held is None:
        run = sim.run_with_sensitivities(task.x, task.responses, **options)
    else:
        design, static = sim._design(task.x), sim.analysis == "static"
        run = replace(spatial_tolerance.on_grid(sim, task.held[0], design, task.responses, [], static, options),
                      responses=task.responses, discretization=task.held[0])
    return replace(run, timings={"runs": time.perf_counter() - began})

_PLANAR_JOINTS = {"clamp": "weld", "pin": "revolute", "hinge": "revolute", "weld": "weld"}
"""A planar joint's spatial kind (its axis z)."""


def from_planar(scene: Any) -> SpatialScene:
    """The spatial scene of a planar one (a :class:`~flextop.Scene`, its dict or TOML file,
    or a :class:`~flextop.Simulation`): its nodes in the plane z = 0, each bar a beam of as
    many elements in the design group of the bar's variable (fixed where the bar is), so that
    the spatial scene's design variables are the planar one's, in order, with its design laws;
    rigid bodies with the planar moment of inertia about
    every axis, clamps, pins, hinges and welds (axes z) with their drives, point masses,
    loads, gravity, the tip and the run settings. The motion stays in the plane; the beams'
    out-of-plane bending and torsion are held by the joints.

    Raises :class:`SceneError` naming what has no spatial counterpart yet: a section not a
    solid circle, sliders and rollers, springs, motors, rings, continuum members, rotary
    inertia of point masses, initial rates."""
    from .simulation import Simulation

    sim = scene if isinstance(scene, Simulation) else Simulation(scene)
    spec, model = sim.spec, sim.model
    for key in ("springs", "motors", "rings", "members", "initial_rates"):
        if spec.get(key):
            raise SceneError(f"{key}: a planar scene's {key} have no spatial counterpart in from_planar yet")
    out = SpatialScene(spec.get("name", ""), analysis=spec.get("analysis", "dynamic"),
                       gravity=None if spec.get("gravity") is None else (*spec["gravity"], 0.0))
    for name, s in spec.get("sections", {}).items():
        if "diameter" not in s:
            raise SceneError(f"sections.{name}: from_planar converts solid circles (a diameter) only")
        nu = s["nu"] if "nu" in s else s["E"] / (2.0 * s["G"]) - 1.0
        out.section(name, E=s["E"], rho=s["rho"], nu=nu, diameter=s["diameter"], rayleigh=s.get("rayleigh"))
    _planar_bodies(out, spec)
    names, positions = model.node_names, np.asarray(model.reference_positions)
    bars = model.bars()
    grid = sorted({int(n) for ends in bars["nodes"] for n in ends})
    for k in grid:
        out.node(names[k], (*positions[k], 0.0))
    variables = sim.variable_names
    for name, ends, split, component, kind, v in zip(bars["name"], bars["nodes"], bars["elements"], bars["component"],
                                                     bars["kind"], bars["variable"]):
        a, b = (names[int(n)] for n in ends)
        out.beam(name, a, b, section=_bar_section(spec, sim.components[component], name), split=split, kind=kind,
                 group=variables[v] if v >= 0 else None, fixed=v < 0)
    if "design" in spec:
        out.design(**spec["design"])
    for k, p in enumerate(spec.get("point_masses", [])):
        if p.get("inertia", 0.0):
            raise SceneError(f"point_masses[{k}]: a point mass with rotary inertia has no spatial counterpart yet")
        out.point_mass(f"mass at {p['node']}", p["node"], p["mass"])
    for j in spec.get("joints", []):
        _planar_joint(out, j)
    for k, load in enumerate(spec.get("loads", [])):
        fx, fy = load.get("force", (0.0, 0.0))
        out.load(f"load{k}", load["node"], force=(fx, fy, 0.0), moment=(0.0, 0.0, load.get("moment", 0.0)),
                 table=None if load.get("table") is None else (load["table"]["t"], load["table"]["scale"]))
    if spec.get("tip") is not None:
        out.tip = spec["tip"]
    defaults = {k: v for k, v in spec.get("simulation", {}).items() if k in ("t_end", "h", "rho_inf", "tol", "max_iter", "load_steps")}
    out.simulation(**defaults)
    return out


def _bar_section(spec: dict, component: str, bar: str) -> str:
    """The section of a bar of ``component`` (a ground structure or a beam)."""
    for entry in spec.get("ground_structures", []) + spec.get("beams", []):
        if entry.get("name") in (component, bar):
            return str(entry["section"])
    raise SceneError(f"bars.{bar}: its section is not found")


def _planar_bodies(out: SpatialScene, spec: dict) -> None:
    for body in spec.get("rigid_bodies", []):
        inertia = body.get("inertia", 0.0)
        points = {k: (*v, 0.0) for k, v in body.get("points", {}).items()}
        out.rigid_body(body["name"], mass=body["mass"], inertia=(inertia, inertia, inertia),
                       position=(*body["position"], 0.0), orientation=axis_angle((0.0, 0.0, 1.0), body.get("angle", 0.0)),
                       points=points)


def _planar_joint(out: SpatialScene, j: dict) -> None:
    kind = _PLANAR_JOINTS.get(j["kind"])
    if kind is None:
        raise SceneError(f"joints.{j['name']}: a planar {j['kind']} has no spatial counterpart in from_planar yet")
    a, b = ("ground", j["node"]) if "node" in j else tuple(j["nodes"])
    if kind == "weld":
        out.weld(j["name"], a, b)
    else:
        out.revolute(j["name"], a, b, axis=(0.0, 0.0, 1.0), drive=j.get("drive"))
