//! Natural modes of a spatial mechanism linearized about a configuration, joints as
//! constraints (drives locked):
//!
//! `K_t φ = ω² M φ`  on  `B φ = 0`,
//!
//! `K_t` the derivative of `f(q) + Bᵀλ` in the nodes' algebra (right-trivialized, at rest),
//! symmetric at an equilibrium under conservative loads (the Hessian of the energy there;
//! a dead moment or a follower load is not conservative in space, and is refused). On a basis `N` of
//! the constraints' null space, `M_r = Nᵀ M N = L Lᵀ` (Cholesky) and the symmetric
//! `L⁻¹ Nᵀ K_t N L⁻ᵀ` give every `ω²` and mass-normalized `φ = N L⁻ᵀ y`.
//!
//! The solve is **dense**: every mode is found, so none can be missed (the planar engine's
//! partial Lanczos and its Sturm count are for large meshes), and its size is limited to
//! [`MAX_DENSE_UNKNOWNS`]. A negative `ω²` is an unstable state (the mechanism buckles
//! there): it is returned, never hidden, and [`SpatialModes::frequencies`] refuses it.

use std::f64::consts::TAU;

use nalgebra::{DMatrix, SymmetricEigen};

use crate::error::{Error, SettingsError, SolveError};
use crate::group::NV;
use crate::spatial::assembly::{Assembler, Coefficients};
use crate::spatial::model::SpatialModel;

/// The most velocity unknowns (six per node) the dense modal analysis takes.
pub const MAX_DENSE_UNKNOWNS: usize = 1500;

/// Relative size (of the largest) below which a singular value of `B` counts as zero: the
/// directions the joints leave free.
const RANK_TOLERANCE: f64 = 1e-10;

/// Relative asymmetry of `K_t` on the free directions past which a load is not
/// conservative.
const SYMMETRY_TOLERANCE: f64 = 1e-6;

/// Relative force residual (of the largest force) and joint gap (of the mechanism's size)
/// past which a state is not an equilibrium.
pub const EQUILIBRIUM_TOLERANCE: f64 = 1e-6;

/// Every natural mode of a spatial mechanism at a configuration.
#[derive(Debug, Clone, PartialEq)]
pub struct SpatialModes {
    /// `ω²` (rad²/s²), ascending; negative where the state is unstable.
    pub omega_squared: Vec<f64>,
    /// Mass-normalized shapes, six numbers per node (`δx` in space, `δθ` in the node's
    /// frame), one per `ω²`.
    pub shapes: Vec<Vec<f64>>,
}

impl SpatialModes {
    /// The natural frequencies `ω/2π` (Hz), ascending; `None` for an unstable state (a
    /// negative `ω²` beyond round-off of the largest).
    pub fn frequencies(&self) -> Option<Vec<f64>> {
        let largest = self
            .omega_squared
            .iter()
            .fold(0.0f64, |m, w| m.max(w.abs()));
        let round_off = 1e-12 * largest;
        if self.omega_squared.iter().any(|&w| w < -round_off) {
            return None;
        }
        Some(
            self.omega_squared
                .iter()
                .map(|w| w.max(0.0).sqrt() / TAU)
                .collect(),
        )
    }
}

/// The natural modes of `model` about configuration `q` with multipliers `lambda` (a static
/// equilibrium's: [`crate::spatial::statics::solve_static_spatial`]; its initial
/// configuration with zero multipliers where it is unloaded), at time `t` of the drives'
/// laws (module docs).
///
/// # Errors
/// [`SettingsError`] for a mechanism past [`MAX_DENSE_UNKNOWNS`] or `q`, `lambda` of the
/// wrong length or not finite; [`SolveError::Eigen`] for a state that is not an equilibrium
/// ([`EQUILIBRIUM_TOLERANCE`]), where `K_t` is not symmetric on the free directions (loads
/// that are not conservative) or the mass leaves a free direction without
/// inertia; a force element's errors.
pub fn natural_modes_spatial(
    model: &SpatialModel,
    q: &[f64],
    lambda: &[f64],
    t: f64,
) -> Result<SpatialModes, Error> {
    check(model, q, lambda)?;
    model.check_nodes()?;
    let n_v = model.n_v();
    let mut asm = Assembler::new(model);
    let rest = vec![0.0; n_v];
    equilibrium(&asm, q, lambda, t)?;
    let at = |beta_prime, tangent| Coefficients {
        beta_prime,
        gamma_prime: 0.0,
        scale: 1.0,
        tangent,
    };
    asm.matrix(q, &rest, t, at(0.0, Some((&rest, lambda))))?;
    let (stiffness, constraints) = dense(&asm, n_v);
    asm.matrix(q, &rest, t, at(1.0, None))?;
    let (mass, _) = dense(&asm, n_v);
    // The rotations of nodes only truss bars meet are not unknowns: held like joints' rows.
    let absent: Vec<usize> = (model.rotation_absent().iter().enumerate())
        .filter(|(_, a)| **a)
        .flat_map(|(n, _)| (3..NV).map(move |k| NV * n + k))
        .collect();
    let held = DMatrix::from_fn(constraints.nrows() + absent.len(), n_v, |r, c| {
        if r < constraints.nrows() {
            constraints[(r, c)]
        } else {
            f64::from(u8::from(absent[r - constraints.nrows()] == c))
        }
    });
    let free = null_space(&held, n_v);
    let k = free.transpose() * &stiffness * &free;
    let asymmetry = (&k - k.transpose()).amax();
    if asymmetry > SYMMETRY_TOLERANCE * k.amax().max(f64::MIN_POSITIVE) {
        return Err(SolveError::Eigen(format!(
            "K_t is not symmetric on the joints' free directions (by {:.1e} of its largest entry): \
             a load is not conservative (a dead moment or a follower load); the modes of \
             non-conservative systems are not built",
            asymmetry / k.amax()
        ))
        .into());
    }
    let m = free.transpose() * &mass * &free;
    let l = m.clone().cholesky().ok_or_else(|| {
        SolveError::Eigen("the mass leaves a free direction without inertia".into())
    })?;
    let l_inv = l.l().try_inverse().ok_or_else(|| {
        SolveError::Eigen("the mass leaves a free direction without inertia".into())
    })?;
    let c = &l_inv * (&k + k.transpose()) * 0.5 * l_inv.transpose();
    let eigen = SymmetricEigen::new(c);
    let mut order: Vec<usize> = (0..eigen.eigenvalues.len()).collect();
    order.sort_by(|&a, &b| eigen.eigenvalues[a].total_cmp(&eigen.eigenvalues[b]));
    let to_shape = &free * l_inv.transpose();
    Ok(SpatialModes {
        omega_squared: order.iter().map(|&i| eigen.eigenvalues[i]).collect(),
        shapes: order
            .iter()
            .map(|&i| {
                (&to_shape * eigen.eigenvectors.column(i))
                    .as_slice()
                    .to_vec()
            })
            .collect(),
    })
}

/// Checks that `(q, λ)` is an equilibrium: forces balanced and joints closed to
/// [`EQUILIBRIUM_TOLERANCE`] of the largest force and of the mechanism's size.
fn equilibrium(asm: &Assembler<'_>, q: &[f64], lambda: &[f64], t: f64) -> Result<(), Error> {
    let n_v = asm.model.n_v();
    let rest = vec![0.0; n_v];
    let mut r = vec![0.0; asm.pattern.n];
    let force = asm.residual(q, &rest, &rest, lambda, t, &mut r)?;
    let unbalanced =
        r[..n_v].iter().fold(0.0f64, |m, x| m.max(x.abs())) / force.max(f64::MIN_POSITIVE);
    let open = r[n_v..].iter().fold(0.0f64, |m, x| m.max(x.abs())) / asm.model.size();
    if unbalanced > EQUILIBRIUM_TOLERANCE || open > EQUILIBRIUM_TOLERANCE {
        return Err(SolveError::Eigen(format!(
            "the state is not an equilibrium (forces unbalanced by {:.1e} of the largest, joints \
             open by {:.1e} of the mechanism's size): solve it first (solve_static_spatial)",
            unbalanced, open
        ))
        .into());
    }
    Ok(())
}

fn check(model: &SpatialModel, q: &[f64], lambda: &[f64]) -> Result<(), SettingsError> {
    let n_v = model.n_v();
    if n_v > MAX_DENSE_UNKNOWNS {
        return Err(SettingsError::new(
            "model",
            format!(
                "{} nodes: the spatial modal analysis is dense, at most {} nodes ({MAX_DENSE_UNKNOWNS} unknowns)",
                model.nodes.len(),
                MAX_DENSE_UNKNOWNS / NV
            ),
        ));
    }
    for (name, values, len) in [("q", q, model.n_q()), ("lambda", lambda, model.n_rows())] {
        if values.len() != len {
            return Err(SettingsError::new(
                name,
                format!("has {} entries, the mechanism {len}", values.len()),
            ));
        }
        if let Some(k) = values.iter().position(|v| !v.is_finite()) {
            return Err(SettingsError::new(
                name,
                format!("entry {k} is {}: must be finite", values[k]),
            ));
        }
    }
    Ok(())
}

/// The assembled matrix's force block (`n_v × n_v`) and constraint rows (`B`), dense.
fn dense(asm: &Assembler<'_>, n_v: usize) -> (DMatrix<f64>, DMatrix<f64>) {
    let p = &asm.pattern;
    let mut force = DMatrix::zeros(n_v, n_v);
    let mut rows = DMatrix::zeros(p.n - n_v, n_v);
    for c in 0..n_v {
        for k in p.col_ptr[c]..p.col_ptr[c + 1] {
            let r = p.row_idx[k];
            if r < n_v {
                force[(r, c)] = asm.values[k];
            } else {
                rows[(r - n_v, c)] = asm.values[k];
            }
        }
    }
    (force, rows)
}

/// An orthonormal basis of `{φ : B φ = 0}`: the eigenvectors of `BᵀB` whose eigenvalues are
/// zero to [`RANK_TOLERANCE`] of the largest (squared).
fn null_space(b: &DMatrix<f64>, n_v: usize) -> DMatrix<f64> {
    if b.nrows() == 0 {
        return DMatrix::identity(n_v, n_v);
    }
    let eigen = SymmetricEigen::new(b.transpose() * b);
    let largest = eigen.eigenvalues.amax();
    let free: Vec<usize> = (0..n_v)
        .filter(|&i| eigen.eigenvalues[i] <= RANK_TOLERANCE.powi(2) * largest)
        .collect();
    DMatrix::from_fn(n_v, free.len(), |r, c| eigen.eigenvectors[(r, free[c])])
}
