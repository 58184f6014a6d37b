"""Type stubs of the native extension ``flextop._core`` (Rust, PyO3).

``Model`` is a built mechanism and its description; the functions run it. Settings dicts
take the keys of a scene's ``[simulation]`` table plus ``method`` and ``memory``.

What crosses the boundary as a string-keyed dict is a ``TypedDict`` below, every key with its
type, shape and units (``n_q``: DOFs, ``n_c``: constraint rows, ``n_x``: design variables,
``n_t``: recorded states, ``t = 0`` first). They exist for the type checker only
(``@type_check_only``); import them under ``typing.TYPE_CHECKING``. ``tests/python/test_stub.py``
runs ``mypy.stubtest`` on this file and checks each dict's keys and value types against the running module.
"""

from typing import Callable, Any, TypedDict, final, type_check_only

import numpy as np
import numpy.typing as npt

__all__ = ["Model", "SpatialModel", "simulate", "solve_static", "run_with_sensitivities", "evaluate_responses", "linearize", "natural_modes",
           "rigid_positions", "prolong", "bar_shares", "time_errors", "section_forces", "cell_fields", "response_kinds", "size_limits", "cancel_running"]

_F = npt.NDArray[np.float64]

# -- Model's description ----------------------------------------------------------------

@type_check_only
class CellTable(TypedDict):
    """``Model.cells()``: one entry per cell of the continuum members."""

    nodes: _F  # corner node indices (as floats), anticlockwise, (n_cells, 4)
    centre: _F  # reference centre (m), (n_cells, 2)
    volume: _F  # full-density volume t·A (m³), (n_cells,)
    variable: list[int]  # design variable, −1 for a fixed cell
    member: list[int]  # index into ``members``
    members: list[str]  # the members' names

@type_check_only
class BarTable(TypedDict):
    """``Model.bars()``: one entry per bar."""

    name: list[str]  # the bars' names, n_bars
    nodes: _F  # end node indices (as floats), (n_bars, 2)
    variable: list[int]  # design variable of each bar, −1 for a bar of fixed full density
    component: list[int]  # index into Model.components
    volume: _F  # full-density volume, (n_bars,), m³
    elements: list[int]  # how many elements each bar is split into
    kind: list[str]  # "frame" (Timoshenko beams) or "truss" (one pin-jointed bar)

@type_check_only
class ElementTable(TypedDict):
    """``Model.elements()``: one entry per beam element."""

    nodes: _F  # end node indices (as floats), (n_elements, 2)
    bar: list[int]  # the bar each element belongs to, index into BarTable's entries

@type_check_only
class MechanismInfo(TypedDict):
    """``Model.mechanism()``: the rigid mechanism behind the flexible one."""

    frames: int  # rigid clusters (frames of beams, rigid bodies)
    mobility: int  # rigid-body modes the joints leave free at the reference
    redundant_rows: int  # constraint rows that depend on others in the rigid mechanism (0: none)
    repeated_rows: int  # of those, rows that repeat undriven rows between the same two frames
    over_constraining: list[str]  # names of the joints in the other dependencies

@type_check_only
class JointInfo(TypedDict):
    """One entry of ``Model.joints()``."""

    name: str  # the joint's name
    kind: str  # "clamp", "pin", "hinge", "weld", "prismatic" or "roller"
    nodes: list[int]  # node indices (a rigid body's own node for its points; a slider's carrier first)
    rows: tuple[int, int]  # its constraint rows in lam as (first, end), the drive row last
    driven: bool  # whether a motion law drives it
    drive_phases: list[float] | None  # when its trapezoidal law stops accelerating, starts braking, is done (s)

# -- results of the functions -------------------------------------------------------------

@type_check_only
class Trajectory(TypedDict):
    """``simulate``: time histories of a dynamic run, one row per recorded state."""

    time: _F  # times t_n, (n_t,), s
    q: _F  # coordinates from the reference (u, v, φ per node), (n_t, n_q), m and rad
    qdot: _F  # velocities, (n_t, n_q), m/s and rad/s
    qddot: _F  # accelerations, (n_t, n_q), m/s² and rad/s²
    lam: _F  # Lagrange multipliers, (n_t, n_c), N or N m
    iterations: list[int]  # Newton iterations of each step, n_t (0 for t = 0)
    steps: _F  # the step that reached each state, (n_t,), s (0 for t = 0)
    kinetic: _F  # kinetic energy, (n_t,), J
    strain: _F  # strain energy (springs included), (n_t,), J
    drive_work: _F  # work of the drives since t = 0, (n_t,), J
    external_work: _F  # work of loads, gravity and motors since t = 0, (n_t,), J
    damping_work: _F  # work of the dampers since t = 0, (n_t,), J (never positive)
    h: float  # the step used (an adaptive run's first step), s
    rho_inf: float  # generalized-α spectral radius at infinity used, dimensionless

@type_check_only
class Equilibrium(TypedDict):
    """``solve_static``: a static equilibrium."""

    q: _F  # coordinates from the reference (u, v, φ per node), (n_q,), m and rad
    lam: _F  # Lagrange multipliers, (n_c,), N or N m
    iterations: int  # Newton iterations over all load steps
    load_steps: int  # load steps taken
    time: float  # the time the loads act at, s

@type_check_only
class SensitivityData(TypedDict):
    """``run_with_sensitivities``: responses and their exact gradients."""

    values: _F  # response values f_k(x), (n_r,), each in its response's units
    gradients: _F  # ∂f_k/∂x_j, (n_r, n_x), response units per unit density
    parameter_gradients: _F  # ∂f_k/∂p_i of the scene parameters named, (n_r, n_p)
    peaks: list[float | None]  # per response, an aggregate's largest point value (stress: Pa), None for others
    time_errors: _F | None  # (n_r,): each f(h) − f to leading order in h, by the adjoint sweep of a motion; None otherwise
    method: str  # the method actually used: "direct" or "adjoint"
    simulation_seconds: float  # wall time of the simulation, s
    gradient_seconds: float  # wall time of the sensitivity analysis, s

@type_check_only
class BeamShareData(TypedDict):
    """``SpatialModel.beam_shares``: each scene beam's share of the change of splitting every frame beam."""

    values: _F  # the responses on this scene, (n_r,)
    fine_values: _F  # the same on the split scene, (n_r,)
    shares: _F  # each response's share per scene beam, (n_r, n_beams)
    first_order: _F  # the same with the coarse run's adjoint alone, (n_r, n_beams)

@type_check_only
class TimeErrors(TypedDict):
    """``time_errors``: the responses' values and their time errors ``f(h) − f`` estimated by the adjoint."""

    values: _F  # response values on the steps given, (n_r,)
    errors: _F  # each one's time error to leading order in the step, (n_r,)

@type_check_only
class BarShares(TypedDict):
    """``bar_shares``: each bar's share of the responses' change when the frame bars are split in two."""

    values: _F  # response values on the coarse model, (n_r,)
    shares: _F  # each bar's share, dual-weighted by the trapezoidal rule, (n_r, n_bars)
    first_order: _F  # the same weighted by the coarse run's adjoint alone, (n_r, n_bars)

@type_check_only
class ResponseData(TypedDict):
    """``evaluate_responses``: responses on recorded states."""

    values: _F  # response values, (n_r,), each in its response's units
    peaks: list[float | None]  # per response, an aggregate's largest point value (stress: Pa), None for others

@type_check_only
class CscMatrix(TypedDict):
    """A sparse matrix as the arguments of ``scipy.sparse.csc_matrix((data, indices, indptr), shape)``."""

    data: _F  # nonzero values, (nnz,)
    indices: list[int]  # row index of each value, nnz
    indptr: list[int]  # start of each column in data, n_cols + 1
    shape: tuple[int, int]  # (n_rows, n_cols)

@type_check_only
class Linearization(TypedDict):
    """``linearize``: the system matrices at a state."""

    M: CscMatrix  # mass matrix, (n_q, n_q), kg and kg m²
    K: CscMatrix  # tangent stiffness K_t(q), (n_q, n_q), N/m, N and N m
    G: CscMatrix  # constraint Jacobian Φ_q, (n_c, n_q)

@type_check_only
class NaturalModes(TypedDict):
    """``natural_modes``: the lowest natural modes, drives locked (n_f ≤ count found)."""

    frequencies: _F  # natural frequencies ω/2π, ascending, (n_f,), Hz
    shapes: _F  # mass-normalized mode shapes (φᵀMφ = 1), (n_f, n_q)
    bound: float  # Sturm bound: above every frequency returned, Hz
    below: int  # Sturm count: how many frequencies lie below bound
    gradients: _F  # ∂f_j/∂x_i, (n_f, n_x), Hz per unit density

# -- the module ---------------------------------------------------------------------------

@final
class Model:
    """A built and validated mechanism."""

    @staticmethod
    def from_dict(spec: dict[str, Any]) -> Model: ...
    @staticmethod
    def from_toml(text: str) -> Model: ...
    @property
    def name(self) -> str: ...
    @property
    def analysis(self) -> str: ...
    @property
    def n_dofs(self) -> int: ...
    @property
    def n_constraints(self) -> int: ...
    @property
    def n_design(self) -> int: ...
    @property
    def x_min(self) -> float: ...
    @property
    def tip(self) -> int | None: ...
    @property
    def node_names(self) -> list[str]: ...
    @property
    def variable_names(self) -> list[str]: ...
    @property
    def components(self) -> list[str]: ...
    @property
    def reference_positions(self) -> _F: ...
    def bars(self) -> BarTable: ...
    def bar_frequencies(self, x: _F | None = None) -> _F: ...
    def bar_masses(self, x: _F | None = None) -> _F: ...
    def check_design(self, x: _F) -> None: ...
    def elements(self) -> ElementTable: ...
    def cells(self) -> CellTable: ...
    def joints(self) -> list[JointInfo]: ...
    def mechanism(self) -> MechanismInfo: ...

@type_check_only
class SpatialTrajectory(TypedDict):
    """``SpatialModel.simulate()``: a spatial motion (``n_n`` nodes, bodies' included)."""

    time: _F  # (n_t,), s
    q: _F  # (n_t, 7 n_n): each node's position (m) and unit quaternion (w, x, y, z)
    v: _F  # (n_t, 6 n_n): each node's velocity in space (m/s), angular velocity in its axes (rad/s)
    lam: _F  # (n_t, n_c) multipliers
    kinetic: _F  # (n_t,) kinetic energy, J
    potential: _F  # (n_t,) gravity's, springs', dead loads' and strain energy, J
    strain: _F  # (n_t,) beams' and bars' strain energy, J

@type_check_only
class SpatialEquilibriumData(TypedDict):
    """``SpatialModel.solve_static()``."""

    q: _F  # (7 n_n,)
    lam: _F  # (n_c,)
    strain: float  # J
    iterations: int  # Newton iterations over all load steps
    load_steps: int

@type_check_only
class SpatialModeData(TypedDict):
    """``SpatialModel.natural_modes()``: every mode about a configuration, or the lowest
    ``count``."""

    omega_squared: _F  # (n_m,), rad²/s², ascending
    frequencies: _F | None  # (n_m,), Hz; None where the state is unstable
    shapes: _F  # (n_m, 6 n_n), mass-normalized
    bound: float | None  # rad²/s², the Sturm bound of a count; None for every mode
    below: int | None  # the ω² below bound (every one returned); None for every mode
    omega_squared_rates: _F | None  # (n_m, n_p + n_x), ∂ω²/∂p then ∂ω²/∂x, state held; None without parameters

@type_check_only
class SpatialSensitivityData(TypedDict):
    """``SpatialModel.sensitivities()``."""

    values: _F  # (n_r,)
    gradient: _F  # (n_r, n_p)
    peaks: list[float | None]  # (n_r,): a stress mean's peak
    time_errors: _F | None  # (n_r,): each f(h) − f to leading order in h, by the adjoint sweep of a motion; None otherwise

@final
class SpatialModel:
    """A built and validated spatial scene."""

    @staticmethod
    def from_dict(spec: dict[str, Any]) -> SpatialModel: ...
    @staticmethod
    def from_toml(text: str) -> SpatialModel: ...
    @property
    def name(self) -> str: ...
    @property
    def analysis(self) -> str: ...
    @property
    def variables(self) -> list[str]: ...
    @property
    def x_min(self) -> float: ...
    @property
    def volumes(self) -> tuple[list[float], float]: ...
    @property
    def tip(self) -> str | None: ...
    @property
    def node_names(self) -> list[str]: ...
    @property
    def body_nodes(self) -> list[tuple[str, int]]: ...
    @property
    def joint_rows(self) -> list[tuple[str, int, int]]: ...
    @property
    def beams(self) -> list[tuple[str, list[list[int]]]]: ...
    @property
    def beam_variables(self) -> list[int | None]: ...
    @property
    def beam_radii(self) -> list[float]: ...
    @property
    def joint_anchors(self) -> list[tuple[str, str, list[int | None], list[list[float]]]]: ...
    @property
    def initial_q(self) -> list[float]: ...
    def options(self) -> dict[str, float]: ...
    def simulate(self, settings: dict[str, Any] | None = None,
                 progress: Callable[[float], object] | None = None, x: list[float] | None = None) -> SpatialTrajectory: ...
    def rigid_trajectory(self, node: int, settings: dict[str, Any] | None = None) -> _F: ...
    def solve_static(self, settings: dict[str, Any] | None = None, x: list[float] | None = None) -> SpatialEquilibriumData: ...
    def natural_modes(self, q: list[float] | None = None, lam: list[float] | None = None, t: float = 0.0,
                      x: list[float] | None = None, count: int | None = None,
                      parameters: list[str] | None = None) -> SpatialModeData: ...
    def masses(self, x: list[float] | None = None) -> tuple[list[float], list[float], float]: ...
    def beam_frequencies(self, x: list[float] | None = None) -> list[float]: ...
    def beam_masses(self, x: list[float] | None = None) -> list[float]: ...
    def sensitivities(self, responses: list[str], parameters: list[str], settings: dict[str, Any] | None = None,
                      equilibrium: bool = False, x: list[float] | None = None) -> SpatialSensitivityData: ...
    def time_errors(self, responses: list[str], settings: dict[str, Any] | None = None,
                    x: list[float] | None = None) -> TimeErrors: ...
    def beam_shares(self, fine: SpatialModel, responses: list[str], fine_responses: list[str],
                    settings: dict[str, Any] | None = None, x: list[float] | None = None) -> BeamShareData: ...

def simulate(model: Model, x: _F | None = None, settings: dict[str, Any] | None = None, local_tol: float | None = None,
             steps: list[float] | None = None, guide: _F | None = None,
             progress: Callable[[float], object] | None = None) -> Trajectory: ...
def solve_static(model: Model, x: _F | None = None, settings: dict[str, Any] | None = None) -> Equilibrium: ...
def run_with_sensitivities(model: Model, x: _F, responses: list[str], settings: dict[str, Any] | None = None,
                           steps: list[float] | None = None, parameters: list[str] = ...,
                           path: tuple[_F, _F, _F, _F] | None = None) -> SensitivityData: ...
def evaluate_responses(model: Model, x: _F | None, q: _F, lam: _F, times: list[float], load_time: float,
                       responses: list[str], qdot: _F | None = None,
                       settings: dict[str, Any] | None = None) -> ResponseData: ...
def prolong(coarse: Model, fine: Model, q: _F) -> _F: ...
def bar_shares(coarse: Model, fine: Model, x: _F, responses: list[str], settings: dict[str, Any] | None, steps: list[float],
               q: _F, qdot: _F, qddot: _F, lam: _F) -> BarShares: ...
def time_errors(model: Model, x: _F, responses: list[str], settings: dict[str, Any] | None,
                steps: list[float]) -> TimeErrors: ...
def linearize(model: Model, x: _F | None = None, q: _F | None = None, settings: dict[str, Any] | None = None) -> Linearization: ...
def natural_modes(model: Model, count: int, x: _F | None = None, q: _F | None = None,
                  settings: dict[str, Any] | None = None) -> NaturalModes: ...
def rigid_positions(model: Model, times: list[float]) -> _F: ...
def section_forces(model: Model, x: _F | None, q: _F) -> _F: ...
def cell_fields(model: Model, x: _F | None, q: _F) -> _F: ...
def response_kinds() -> list[tuple[str, str, str, bool, str, bool, str | None]]: ...
def size_limits() -> list[tuple[str, int]]: ...
def cancel_running() -> None: ...
