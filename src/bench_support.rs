//! Hooks for `benches/` to time internals: not part of the API.

use crate::error::{Error, SolveError};
use crate::mechanism::element::MassKind;
use crate::mechanism::model::Model;
use crate::solver::assembly::{Assembler, Jacobian, Pattern};
use crate::solver::linsolve::{FactorError, Ldlt};

pub use crate::solver::linsolve::{Storage, DENSE_FILL, DENSE_LIMIT, SUPERNODAL_RATIO};

/// The iteration matrix `c M + K_t + s Φ_qᵀΦ_q` (with its constraint blocks) of a design at
/// the reference, `c = s`, and its factors in a chosen storage.
pub struct Refactoring {
    /// Number of unknowns (DOFs and multipliers).
    pub unknowns: usize,
    /// The share of the lower triangle sparse factors fill, over the unknowns they hold
    /// (`None` when stored dense).
    pub fill: Option<f64>,
    ldlt: Ldlt,
    values: Vec<f64>,
    rhs: Vec<f64>,
}

impl Refactoring {
    /// `model`'s matrix for design `x` with `c = s = mass_coefficient`, its factors stored
    /// as `storage`.
    ///
    /// # Errors
    /// A bad design, or a matrix that cannot be set up.
    pub fn new(
        model: &Model,
        x: Option<&[f64]>,
        mass_coefficient: f64,
        storage: Storage,
    ) -> Result<Self, Error> {
        let asm = Assembler::new(model, model.densities(x)?, MassKind::Consistent)?;
        let p = &asm.pattern;
        let multipliers = Pattern::multiplier_dofs(model);
        let (cp, ri) = (p.sparsity.col_ptr.clone(), p.sparsity.row_idx.clone());
        let ldlt =
            Ldlt::analyze_as(storage, p.sparsity.n, cp, ri, p.n_q, &multipliers).map_err(setup)?;
        let q = vec![0.0; p.n_q];
        let mut values = vec![0.0; p.nnz()];
        let jacobian = Jacobian::at(model, &q);
        asm.start_iteration_matrix(mass_coefficient, mass_coefficient, &jacobian, &mut values);
        asm.internal_forces(&q, &mut vec![0.0; p.n_q], Some(&mut values));
        Ok(Self {
            unknowns: p.sparsity.n,
            fill: ldlt.fill(),
            ldlt,
            values,
            rhs: vec![0.0; p.sparsity.n],
        })
    }

    /// Refactors the matrix and solves once, as a Newton iteration with a fresh matrix does.
    ///
    /// # Errors
    /// A singular matrix.
    pub fn run(&mut self) -> Result<(), Error> {
        self.ldlt.factorize(&self.values).map_err(setup)?;
        self.rhs.fill(1.0);
        self.ldlt.solve_in_place(&mut self.rhs).map_err(setup)?;
        Ok(())
    }
}

fn setup(e: FactorError) -> SolveError {
    SolveError::Setup(format!("{e:?}"))
}
