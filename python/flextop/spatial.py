"""Running a spatial scene: :class:`SpatialSimulation`, built once, runs its motion
(generalized-α on the Lie group ℝ³ × SO(3) of each node), its static equilibrium, its
natural modes about an equilibrium, and the exact gradients of its responses to its
parameters, direct or adjoint, over the motion or at the equilibrium.

Responses by name: ``x:NAME``, ``y:NAME``, ``z:NAME`` (a body's centre of mass or a node's
origin at the end of the run, m), ``strain_energy`` (``∫U dt`` over the motion, J s; ``U`` at
an equilibrium, J), ``effort:JOINT`` (``∫λ² dt`` of a driven joint's drive row).
Parameters by name: ``mass:BODY`` (kg), ``Ixx:BODY`` … ``Iyz:BODY`` (kg m²), ``k:SPRING``,
``c:SPRING``, ``torque:MOTOR``, ``E:BEAM`` and ``rho:BEAM`` (Pa, kg/m³).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from . import _core
from .errors import SettingsError, SimulationError
from .scenes.builder import read_toml
from .scenes.spatial import SpatialScene

NQ, NV = 7, 6
"""Numbers per node: in a configuration (position, unit quaternion w, x, y, z), in a
velocity (velocity in space, angular velocity in the node's axes)."""


def _rotations(quaternions: np.ndarray) -> np.ndarray:
    """Rotation matrices of unit quaternions ``(w, x, y, z)``, shape ``(..., 3, 3)``."""
    w, x, y, z = np.moveaxis(quaternions, -1, 0)
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
    ], -2)


@dataclass(frozen=True)
class _Names:
    """Where a name's numbers are: nodes (bodies on theirs) and joints' rows."""

    nodes: dict[str, int]
    joints: dict[str, range]

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
    names: _Names

    def position(self, name: str) -> np.ndarray:
        """A body's centre of mass or a node's origin at each time, shape ``(n, 3)`` (m)."""
        k = self.names.node(name)
        return self.q[:, NQ * k:NQ * k + 3]

    def rotation(self, name: str) -> np.ndarray:
        """A body's or node's axes in space at each time, shape ``(n, 3, 3)``."""
        k = self.names.node(name)
        return _rotations(self.q[:, NQ * k + 3:NQ * k + 7])

    def multipliers(self, joint: str) -> np.ndarray:
        """A joint's multipliers at each time, shape ``(n, rows)``: its constraint forces'
        measures (N, N m; a drive's row last)."""
        return self.lam[:, self.names.rows(joint)]


@dataclass(frozen=True)
class SpatialEquilibrium:
    """A static equilibrium: configuration ``q``, multipliers ``lam``, the ``strain`` energy
    (J), Newton ``iterations`` over ``load_steps``."""

    q: np.ndarray
    lam: np.ndarray
    strain: float
    iterations: int
    load_steps: int
    names: _Names

    def position(self, name: str) -> np.ndarray:
        """A body's centre of mass or a node's origin (m)."""
        k = self.names.node(name)
        return self.q[NQ * k:NQ * k + 3]

    def rotation(self, name: str) -> np.ndarray:
        """A body's or node's axes in space."""
        k = self.names.node(name)
        return _rotations(self.q[NQ * k + 3:NQ * k + 7])


@dataclass(frozen=True)
class SpatialModes:
    """Every natural mode about a configuration: ``omega_squared`` (rad²/s², ascending;
    negative where it is unstable) and mass-normalized ``shapes`` (one row per mode, six
    numbers per node: displacement in space, rotation in the node's axes)."""

    omega_squared: np.ndarray
    shapes: np.ndarray

    @property
    def frequencies(self) -> np.ndarray:
        """The natural frequencies (Hz), ascending. Raises :class:`SimulationError` where the
        configuration is unstable (an ``ω²`` below round-off of the largest)."""
        round_off = 1e-12 * float(np.max(np.abs(self.omega_squared), initial=0.0))
        if np.any(self.omega_squared < -round_off):
            raise SimulationError(f"the configuration is unstable (ω² down to {self.omega_squared.min():.4g} rad²/s²): "
                                  "it has no natural frequencies")
        return np.sqrt(np.maximum(self.omega_squared, 0.0)) / (2.0 * np.pi)


@dataclass(frozen=True)
class SpatialSensitivities:
    """Responses' ``values`` and their exact ``gradient`` to the parameters (one row per
    response), by name."""

    responses: tuple[str, ...]
    parameters: tuple[str, ...]
    values: np.ndarray
    gradient: np.ndarray

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
    names = (value,) if isinstance(value, str) else tuple(value)
    if not all(isinstance(n, str) for n in names):
        raise SettingsError(f"{what}: names as text, got {value!r}")
    return names


class SpatialSimulation:
    """A validated spatial scene, ready to run.

    Parameters
    ----------
    scene:
        A :class:`~flextop.scenes.spatial.SpatialScene`, a scene dict (``dimension = 3``) or
        the path of a TOML scene file.

    Raises
    ------
    SceneError
        If the scene cannot be built; the message names the entry.
    """

    def __init__(self, scene: SpatialScene | dict | str | os.PathLike) -> None:
        self.spec = _as_spec(scene)
        self.model = _core.SpatialModel.from_dict(self.spec)
        nodes = {name: k for k, name in enumerate(self.model.node_names)}
        nodes.update(dict(self.model.body_nodes))
        self.names = _Names(nodes, {name: range(a, b) for name, a, b in self.model.joint_rows})

    @property
    def analysis(self) -> str:
        """``"dynamic"`` or ``"static"``."""
        return str(self.model.analysis)

    @property
    def tip(self) -> str | None:
        """The body or node whose final position is the default response."""
        return self.model.tip

    def run(self, **settings: Any) -> SpatialResults | SpatialEquilibrium:
        """The scene's analysis: :meth:`simulate` or :meth:`equilibrium`."""
        return self.simulate(**settings) if self.analysis == "dynamic" else self.equilibrium(**settings)

    def simulate(self, *, progress: Callable[[float], None] | None = None, **settings: Any) -> SpatialResults:
        """The motion over ``t_end`` in steps ``h`` (the scene's ``[simulation]`` defaults
        overridden by ``settings``: ``t_end``, ``h``, ``rho_inf``, ``tol``, ``max_iter``);
        ``progress`` is called with the time reached (s)."""
        r = self.model.simulate(settings, progress)
        return SpatialResults(np.asarray(r["time"]), np.asarray(r["q"]), np.asarray(r["v"]), np.asarray(r["lam"]),
                              np.asarray(r["kinetic"]), np.asarray(r["potential"]), np.asarray(r["strain"]), self.names)

    def equilibrium(self, **settings: Any) -> SpatialEquilibrium:
        """The static equilibrium under the loads at ``t_end`` (0 by default), by Newton on the
        group with ``load_steps``."""
        r = self.model.solve_static(settings)
        return SpatialEquilibrium(np.asarray(r["q"]), np.asarray(r["lam"]), float(r["strain"]), int(r["iterations"]),
                                  int(r["load_steps"]), self.names)

    def modes(self, at: SpatialEquilibrium | None = None, **settings: Any) -> SpatialModes:
        """Every natural mode about the equilibrium ``at`` (the static equilibrium of the
        scene's loads at ``t_end`` by default)."""
        eq = self.equilibrium(**settings) if at is None else at
        r = self.model.natural_modes(list(eq.q), list(eq.lam), float(settings.get("t_end", 0.0)))
        return SpatialModes(np.asarray(r["omega_squared"]), np.asarray(r["shapes"]))

    def run_with_sensitivities(self, responses: Sequence[str] | str | None = None, parameters: Sequence[str] | str = (), *,
                               equilibrium: bool | None = None, **settings: Any) -> SpatialSensitivities:
        """The ``responses`` (the tip's x, y, z by default) and their exact gradients to the
        ``parameters`` (module docs), over the motion or, with ``equilibrium`` (the default
        of a static scene), at the static equilibrium; ``method`` ``"direct"``,
        ``"adjoint"`` or ``"auto"`` among the settings."""
        if responses is None:
            if self.tip is None:
                raise SettingsError("no responses given, and the scene names no tip")
            responses = [f"{axis}:{self.tip}" for axis in "xyz"]
        rs, ps = _names(responses, "responses"), _names(parameters, "parameters")
        static = self.analysis == "static" if equilibrium is None else bool(equilibrium)
        r = self.model.sensitivities(list(rs), list(ps), settings, static)
        return SpatialSensitivities(rs, ps, np.asarray(r["values"]), np.asarray(r["gradient"]).reshape(len(rs), len(ps)))
