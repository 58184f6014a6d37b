//! Error types of the engine, one enum per layer.
//!
//! Library code returns these instead of panicking on user data; the Python
//! bindings map each to its own exception class (`SceneError`, `DesignError`,
//! `SettingsError`, `SimulationError`).

use thiserror::Error;

/// A scene that cannot be built: unknown key, non-physical or non-finite value,
/// missing node, degenerate geometry, over- or under-constrained mechanism.
#[derive(Debug, Clone, Error, PartialEq)]
#[error("{path}: {message}")]
pub struct SceneError {
    /// Where in the scene the problem is, e.g. `sections.al20.E` or `joints[1] (elbow)`.
    pub path: String,
    /// What is wrong with it.
    pub message: String,
}

impl SceneError {
    /// A scene error at `path`.
    pub fn new(path: impl Into<String>, message: impl Into<String>) -> Self {
        Self {
            path: path.into(),
            message: message.into(),
        }
    }
}

/// A design vector that does not fit the scene's design variables.
#[derive(Debug, Clone, Error, PartialEq)]
pub enum DesignError {
    /// `x` has the wrong number of entries.
    #[error("design vector has {got} entries, the scene has {expected} design variables")]
    Length {
        /// Number of design variables of the scene.
        expected: usize,
        /// Length of the vector given.
        got: usize,
    },
    /// An entry is non-finite or outside `[x_min, 1]`.
    #[error("x[{index}] ({name}) = {} is outside [{}, 1]", short(*value), short(*lower))]
    OutOfBounds {
        /// Index of the design variable.
        index: usize,
        /// Its name, e.g. `link1/bar12 (3-7)`.
        name: String,
        /// The value given.
        value: f64,
        /// The lower bound `x_min`.
        lower: f64,
    },
}

/// `v` as a user reads it: plain decimals from 1e-3 to 1e6 (`0.01`, `2`), shortest
/// scientific notation otherwise (`5e-324`, `1.5e12`).
pub fn short(v: f64) -> String {
    if v == 0.0 || !v.is_finite() || (1e-3..1e6).contains(&v.abs()) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

/// Run settings that make no sense (step size, spectral radius, tolerances, responses).
#[derive(Debug, Clone, Error, PartialEq)]
#[error("{name}: {message}")]
pub struct SettingsError {
    /// The setting, e.g. `h` or `responses[2]`.
    pub name: String,
    /// What is wrong with it.
    pub message: String,
}

impl SettingsError {
    /// A settings error for `name`.
    pub fn new(name: impl Into<String>, message: impl Into<String>) -> Self {
        Self {
            name: name.into(),
            message: message.into(),
        }
    }
}

/// A solve that failed: Newton did not converge, the iteration matrix is singular,
/// or the state became non-finite.
#[derive(Debug, Clone, Error, PartialEq)]
pub enum SolveError {
    /// Newton's method reached its iteration limit.
    #[error(
        "Newton did not converge at {at}: residual {residual:.3e} (tolerance {tolerance:.1e}) \
         after {iterations} iterations"
    )]
    NewtonFailed {
        /// Where: `t = … s` (dynamics) or `load factor …` (statics).
        at: String,
        /// Iterations done.
        iterations: usize,
        /// Relative residual reached.
        residual: f64,
        /// Relative residual required.
        tolerance: f64,
    },
    /// A converged step turned a node by more than π/2: the step (or load increment) is
    /// too large for the motion, or the solve jumped to another branch.
    #[error(
        "the step to {at} turned node '{node}' by {rotation:.3e} rad (more than π/2 in \
         one step); use a smaller step h (or more load steps)"
    )]
    Diverged {
        /// Where the step ends: `t = … s` or `load factor …`.
        at: String,
        /// The rotation (rad).
        rotation: f64,
        /// The node it turned.
        node: String,
    },
    /// A spring between two points shrank to (nearly) zero length, where its direction
    /// and its force are undefined.
    #[error(
        "at {at} spring '{spring}' has collapsed (to {length:.3e} m, or through zero length): \
         its force has no direction there; keep its points apart (a stiffer spring, a stop, \
         other geometry)"
    )]
    SpringCollapsed {
        /// Where the step ends: `t = … s` or `load factor …`.
        at: String,
        /// The spring's name.
        spring: String,
        /// Its length (m).
        length: f64,
    },
    /// A torsion spring's joint turned half a turn from where it was built, where its angle,
    /// read within one turn, jumps.
    #[error(
        "at {at} torsion spring '{spring}' has turned its joint by {angle:.4} rad from where \
         it was built: its angle is read within half a turn either way; keep the joint's \
         rotation under π (a stiffer spring, a stop, a drive)"
    )]
    SpringWound {
        /// Where the step ends: `t = … s` or `load factor …`.
        at: String,
        /// The spring's name.
        spring: String,
        /// Its angle (rad).
        angle: f64,
    },
    /// A converged step turned a continuum cell inside out: its deformed area passed
    /// through zero at a Gauss point.
    #[error(
        "at {at} cell '{cell}' (density {density:.3}) has turned inside out (area ratio \
         {ratio:.3e} at a Gauss point): {advice}",
        advice = inverted_cell_advice(*.density)
    )]
    CellInverted {
        /// Where the step ends: `t = … s` or `load factor …`.
        at: String,
        /// The cell, `NAME/cell[i,j]`.
        cell: String,
        /// Its density.
        density: f64,
        /// The smallest `det F` over its Gauss points.
        ratio: f64,
    },
    /// The LDLᵀ factorization met a zero pivot or produced non-finite values.
    #[error("singular iteration matrix at t = {time:.6} s ({detail})")]
    Singular {
        /// Time (or load factor) of the failure.
        time: f64,
        /// What the solver reported.
        detail: String,
    },
    /// The exact sensitivity solve with a damping whose `C` follows the state (the beams'
    /// stiffness-proportional damping, dampers on distances) did not settle within its
    /// iteration limit.
    #[error(
        "the sensitivity solve with {damping} did not settle at t = {time:.6} s: the damping \
         is too strong for the step; use a smaller step h"
    )]
    Unsettled {
        /// Time of the state.
        time: f64,
        /// The dampings at fault, in the scene's words.
        damping: String,
    },
    /// Local error control wanted a step below its smallest.
    #[error(
        "the step fell below {h_min:.3e} s at t = {time:.6} s: the local error tolerance \
         cannot be met there (raise local_tol, or look for a singularity of the motion)"
    )]
    StepTooSmall {
        /// Time of the last accepted state.
        time: f64,
        /// The smallest step allowed (s).
        h_min: f64,
    },
    /// Load stepping could not reach the full load: the increment fell below its smallest,
    /// or the Newton iterations over all load steps exceeded their budget.
    #[error(
        "static equilibrium not reached past load factor {load:.6}: {why} (the last \
         failure: {last}); a limit point or a mechanism may lie there"
    )]
    LoadStepping {
        /// The largest load factor at which equilibrium was found.
        load: f64,
        /// Which limit stopped it.
        why: String,
        /// The last Newton failure, as its message.
        last: String,
    },
    /// A nonlinear static solve failed where the linear solution moves a node by a large
    /// share of the model's size ([`crate::LARGE_DISPLACEMENT`]): the load
    /// is large for the stiffness, and the small-displacement problem may be what is meant.
    #[error(
        "{failure}. The linear solution moves node '{node}' by {ratio:.3} times the model's \
         size: the load is large for the stiffness. For the small-displacement problem (K₀u = \
         f, as in the 88-line code's units) select the linear analysis: analysis = \"linear\" \
         in the scene's [simulation] table, analysis=\"linear\" in Python, or --analysis \
         linear on the command line"
    )]
    LargeLoad {
        /// The nonlinear solve's failure.
        failure: Box<SolveError>,
        /// The node the linear solution moves farthest.
        node: String,
        /// Its displacement over the model's size.
        ratio: f64,
    },
    /// A spatial run's Newton failed in a step that began with a bar at or near its Euler
    /// load ([`crate::spatial::integrator::BUCKLING_HINT`]): a buckling bar.
    #[error(
        "{failure}; bar '{bar}' was at {ratio:.3} times its Euler load when the step began: \
         it buckles, which its elements may be too few to follow (give its bars more \
         elements: the scene's split, or a run to a tolerance), or the design is too light \
         to carry the motion"
    )]
    Buckled {
        /// Newton's failure.
        failure: Box<SolveError>,
        /// The element nearest its Euler load, by name.
        bar: String,
        /// Its compression over its Euler load.
        ratio: f64,
    },
    /// The sparse pattern or the symbolic factorization could not be set up: a defect of
    /// the engine, not of the input, reported instead of a panic.
    #[error("internal error setting up the linear solver ({0}); please report it with the scene")]
    Setup(String),
    /// The caller asked the work to stop ([`crate::with_checker`]).
    #[error("interrupted")]
    Interrupted,
    /// The modal analysis failed: an unstable state, or modes it cannot account for.
    #[error("natural modes: {0}")]
    Eigen(String),
    /// The rigid kinematics of the driven mechanism cannot be solved.
    #[error("rigid kinematics failed at t = {time:.6} s: {detail}")]
    Kinematics {
        /// Time of the failure.
        time: f64,
        /// Why.
        detail: String,
    },
}

/// Any error of the engine.
#[derive(Debug, Clone, Error, PartialEq)]
pub enum Error {
    /// See [`SceneError`].
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// See [`DesignError`].
    #[error(transparent)]
    Design(#[from] DesignError),
    /// See [`SettingsError`].
    #[error(transparent)]
    Settings(#[from] SettingsError),
    /// See [`SolveError`].
    #[error(transparent)]
    Solve(#[from] SolveError),
}

/// What turns a cell of `density` inside out, and what to do, for [`SolveError::CellInverted`]:
/// a light cell is squeezed by stiffer neighbours or a load; a solid one is crushed, its
/// St. Venant–Kirchhoff material softening in strong compression, where it carries a mass
/// or a load with little material around it.
fn inverted_cell_advice(density: f64) -> &'static str {
    if density < 0.5 {
        "a cell this light cannot keep its shape against stiffer neighbours or a load, as \
         void cells joining solid regions; filter the design (regions joined through \
         material), or raise x_min or e_min"
    } else {
        "a solid cell crushed, as one that carries a mass or a load with little material \
         around it (its material softens in strong compression); give the region around it \
         material (a member's solid_radius, passive cells), filter the design, or lessen the \
         load"
    }
}
