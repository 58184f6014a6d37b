//! Natural modes of a spatial mechanism linearized about a configuration, joints as
//! constraints (drives locked):
//!
//! `K_t φ = ω² M φ`  on  `B φ = 0`,
//!
//! `K_t` the derivative of `f(q) + Bᵀλ` in the nodes' algebra (right-trivialized, at rest),
//! symmetric at an equilibrium under conservative loads (the Hessian of the energy there;
//! a dead moment or a follower load is not conservative in space, and is refused). The
//! rotations of nodes only truss bars meet are not unknowns: held still, out of the modes.
//! A negative `ω²` is an unstable state (the mechanism buckles there): it is returned,
//! never hidden, and [`SpatialModes::frequencies`] refuses it.
//!
//! **Every mode** (no count): on a basis `N` of the constraints' null space,
//! `M_r = Nᵀ M N = L Lᵀ` (Cholesky) and the symmetric `L⁻¹ Nᵀ K_t N L⁻ᵀ` give every `ω²`
//! and mass-normalized `φ = N L⁻ᵀ y`. Dense, so none can be missed, and limited to
//! [`MAX_DENSE_UNKNOWNS`].
//!
//! **The lowest `count`**: the planar engine's shift-invert Lanczos on the sparse pencil
//! (`modal/pencil.rs`), any size. `K_t` is symmetric to round-off at an equilibrium
//! under conservative loads (checked entry by entry on the pattern, [`SYMMETRY_TOLERANCE`]),
//! so its symmetric part is factorized, `[K_s − σM + c BᵀB, c Bᵀ; c B, 0]` with the planar
//! `LDLᵀ`, the symbolic
//! analysis kept for the Sturm count at the bound; `M = R Rᵀ` from the bodies' and the
//! elements' mass matrices. The count of negative pivots less the constraint rows proves
//! that no mode below the bound was skipped ([`SturmCount`]); that of `[M + c BᵀB, c Bᵀ;
//! c B, 0]`, equal to the rows, that the mass holds every free direction. In an unstable
//! state the shift moves below the lowest `ω²` (counted) first. The constraint rows must be
//! independent (the dense path finds their rank).

use std::f64::consts::TAU;

use nalgebra::{DMatrix, SymmetricEigen};

use crate::error::{Error, SettingsError, SolveError};
use crate::group::NV;
use crate::modal::pencil::{MassFactor, Pencil};
use crate::solver::linsolve::{FactorError, Ldlt};
use crate::solver::sparsity::Sparsity;
use crate::spatial::assembly::{Assembler, Coefficients};
use crate::spatial::model::SpatialModel;

/// The most velocity unknowns (six per node) the dense modal analysis (every mode) takes.
pub const MAX_DENSE_UNKNOWNS: usize = 1500;

/// Relative size (of the largest) below which a singular value of `B` counts as zero: the
/// directions the joints leave free.
const RANK_TOLERANCE: f64 = 1e-10;

/// Relative asymmetry of `K_t` (on the free directions, or entry by entry for the lowest
/// modes) past which a load is not conservative.
pub const SYMMETRY_TOLERANCE: f64 = 1e-6;

/// Relative force residual (of the largest force) and joint gap (of the mechanism's size)
/// past which a state is not an equilibrium.
pub const EQUILIBRIUM_TOLERANCE: f64 = 1e-6;

/// Most tenfold steps of the shift below zero that look for one under every `ω²` of an
/// unstable state, from `10⁻⁴` of `mean diag K / mean diag M`.
const DESCENTS: i32 = 9;

/// Every natural mode of a spatial mechanism at a configuration, or its lowest.
#[derive(Debug, Clone, PartialEq)]
pub struct SpatialModes {
    /// `ω²` (rad²/s²), ascending; negative where the state is unstable.
    pub omega_squared: Vec<f64>,
    /// Mass-normalized shapes, six numbers per node (`δx` in space, `δθ` in the node's
    /// frame), one per `ω²`.
    pub shapes: Vec<Vec<f64>>,
    /// For the lowest modes, the proof that none was skipped; `None` when every mode was
    /// found.
    pub sturm: Option<SturmCount>,
}

/// The Sturm count of a partial solve: `below` eigenvalues `ω² < bound`, every one among
/// those returned (the last ones returned may sit in a cluster of nearly equal modes wider
/// than the search, then the bound lies below it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SturmCount {
    /// The bound (rad²/s²).
    pub bound: f64,
    /// How many `ω²` lie below it.
    pub below: usize,
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
/// laws: every one densely without a `count`, the lowest `count` by shift-invert Lanczos
/// with their Sturm count (module docs).
///
/// # Errors
/// [`SettingsError`] for `q`, `lambda` of the wrong length or not finite, a `count` of zero
/// or past the free directions, or, without a count, a mechanism past
/// [`MAX_DENSE_UNKNOWNS`]; [`SolveError::Eigen`] for a state that is not an equilibrium
/// ([`EQUILIBRIUM_TOLERANCE`]), where `K_t` is not symmetric (loads that are not
/// conservative), the mass leaves a free direction without inertia, the joints' rows are
/// redundant (a count) or the eigensolver cannot account for every mode below its bound;
/// a force element's errors.
pub fn natural_modes_spatial(
    model: &SpatialModel,
    q: &[f64],
    lambda: &[f64],
    t: f64,
    count: Option<usize>,
) -> Result<SpatialModes, Error> {
    check(model, q, lambda, count)?;
    model.check_nodes()?;
    let n_v = model.n_v();
    let mut asm = Assembler::new(model)?;
    let rest = vec![0.0; n_v];
    equilibrium(&asm, q, lambda, t)?;
    let at = |beta_prime, tangent| Coefficients {
        beta_prime,
        gamma_prime: 0.0,
        scale: 1.0,
        tangent,
    };
    asm.matrix(q, &rest, t, at(0.0, Some((&rest, lambda))))?;
    let stiffness = asm.values.clone();
    asm.matrix(q, &rest, t, at(1.0, None))?;
    match count {
        None => every_mode(&asm.pattern, &stiffness, &asm.values, model),
        Some(count) => lowest_modes(&asm.pattern, &stiffness, &asm.values, model, count),
    }
}

/// Every mode, densely on the constraints' null space, from the assembled stiffness and
/// mass (module docs).
fn every_mode(
    pattern: &Sparsity,
    stiffness: &[f64],
    mass: &[f64],
    model: &SpatialModel,
) -> Result<SpatialModes, Error> {
    let n_v = model.n_v();
    let (stiffness, constraints) = dense(pattern, stiffness, n_v);
    let (mass, _) = dense(pattern, mass, n_v);
    let absent = absent_rotations(model);
    let held = DMatrix::from_fn(constraints.nrows() + absent.len(), n_v, |r, c| {
        if r < constraints.nrows() {
            constraints[(r, c)]
        } else {
            f64::from(u8::from(absent[r - constraints.nrows()] == c))
        }
    });
    let free = null_space(&held, n_v)?;
    let k = free.transpose() * &stiffness * &free;
    let asymmetry = (&k - k.transpose()).amax();
    if asymmetry > SYMMETRY_TOLERANCE * k.amax().max(f64::MIN_POSITIVE) {
        return Err(not_conservative(
            "on the joints' free directions",
            asymmetry / k.amax(),
        ));
    }
    let m = free.transpose() * &mass * &free;
    let l = m.clone().cholesky().ok_or_else(massless)?;
    let l_inv = l.l().try_inverse().ok_or_else(massless)?;
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
        sturm: None,
    })
}

/// The lowest `count` modes by the planar engine's shift-invert Lanczos on the sparse
/// pencil of the symmetric part of `K_t` (module docs).
fn lowest_modes(
    pattern: &Sparsity,
    stiffness: &[f64],
    mass: &[f64],
    model: &SpatialModel,
    count: usize,
) -> Result<SpatialModes, Error> {
    let (n_v, n_rows) = (model.n_v(), model.n_rows());
    let [mut k, mut m, penalty] = split(pattern, stiffness, mass, n_v)?;
    let absent = absent_rotations(model);
    let held: Vec<usize> = (0..n_v)
        .filter(|d| absent.binary_search(d).is_err())
        .collect();
    let diagonal = |d: usize| pattern.slot(d, d).ok_or_else(missing_entry);
    let held_slots = held
        .iter()
        .map(|&d| diagonal(d))
        .collect::<Result<Vec<_>, _>>()?;
    let absent_slots = absent
        .iter()
        .map(|&d| diagonal(d))
        .collect::<Result<Vec<_>, _>>()?;
    let factor = spatial_mass_factor(model);
    let available = factor.columns.min(held.len()).saturating_sub(n_rows);
    if count > available {
        return Err(SettingsError::new(
            "count",
            format!("is {count}: the mechanism has {available} free directions"),
        )
        .into());
    }
    let mean_diagonal = |values: &[f64]| {
        let sum: f64 = held_slots.iter().map(|&s| values[s].abs()).sum();
        sum / held_slots.len().max(1) as f64
    };
    // Scales: the penalty's and the shift's (`ω²` of the order of the stiffest element's
    // frequency); a mechanism of rigid bodies held by gravity alone may have no stiffness
    // on the diagonal.
    let mean_m = mean_diagonal(&m);
    let mean_k = Some(mean_diagonal(&k))
        .filter(|&k| k > 0.0)
        .unwrap_or(mean_m);
    // Absent rotations: held by a unit of the mean stiffness, no mass (of the mean mass
    // while the mass's inertia is counted).
    for &slot in &absent_slots {
        (k[slot], m[slot]) = (mean_k, mean_m);
    }
    let mut ldlt = Ldlt::analyze_saddle_point(
        pattern.n,
        n_v,
        pattern.col_ptr.clone(),
        pattern.row_idx.clone(),
    )
    .map_err(factor_error)?;
    let holding: Vec<f64> = (m.iter().zip(&penalty))
        .map(|(m, g)| m + mean_m * g)
        .collect();
    let holds = match ldlt.factorize(&holding) {
        Ok(()) => ldlt.negative_pivots().map_err(factor_error)? == n_rows,
        Err(FactorError::ZeroPivot { .. }) => false,
        Err(e) => return Err(factor_error(e)),
    };
    if !holds {
        return Err(SolveError::Eigen(
            "the mass leaves a free direction without inertia, or the joints' rows are not \
             independent (every mode, without a count, takes redundant rows)"
                .into(),
        )
        .into());
    }
    for &slot in &absent_slots {
        m[slot] = 0.0;
    }
    let constraints = penalty.iter().map(|g| mean_k * g).collect();
    let scale = mean_k / mean_m;
    let mut pencil = Pencil::new([k, m, constraints], ldlt, [n_v, n_rows], -1e-8 * scale);
    below_every_mode(&mut pencil, scale)?;
    let lowest = pencil.lowest(&factor, count)?;
    Ok(SpatialModes {
        omega_squared: lowest.omega_squared,
        shapes: lowest.shapes,
        sturm: Some(SturmCount {
            bound: lowest.bound,
            below: lowest.below,
        }),
    })
}

/// The symmetric part of the force block's `K_t` (refused where it is not symmetric to
/// [`SYMMETRY_TOLERANCE`] of its largest entry), `M` and the constraints' penalty
/// ([`with_gram`]), each as values on the pattern.
fn split(
    pattern: &Sparsity,
    stiffness: &[f64],
    mass: &[f64],
    n_v: usize,
) -> Result<[Vec<f64>; 3], Error> {
    let mirror = pattern.mirror().ok_or_else(|| {
        factor_error(FactorError::Analysis(
            "a pattern not structurally symmetric".into(),
        ))
    })?;
    let (mut k, mut m, mut b) = (
        vec![0.0; mirror.len()],
        mass.to_vec(),
        vec![0.0; mirror.len()],
    );
    for c in 0..pattern.n {
        for s in pattern.col_ptr[c]..pattern.col_ptr[c + 1] {
            if c < n_v && pattern.row_idx[s] < n_v {
                k[s] = stiffness[s];
            } else {
                (b[s], m[s]) = (stiffness[s], 0.0);
            }
        }
    }
    let largest = k.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let asymmetry = (k.iter().zip(&mirror)).fold(0.0f64, |a, (v, &s)| a.max((v - k[s]).abs()));
    if asymmetry > SYMMETRY_TOLERANCE * largest.max(f64::MIN_POSITIVE) {
        return Err(not_conservative("entry by entry", asymmetry / largest));
    }
    let symmetric = (k.iter().zip(&mirror))
        .map(|(v, &s)| 0.5 * (v + k[s]))
        .collect();
    Ok([symmetric, m, with_gram(pattern, &b, n_v)?])
}

/// Moves the shift of an unstable state (a negative `ω²` below it, counted) below every
/// `ω²`: `−10ᵏ` of `scale` (`mean diag K / mean diag M`) for `k` from −4 up, tenfold
/// steps, each counted.
fn below_every_mode(pencil: &mut Pencil, scale: f64) -> Result<(), Error> {
    let mut shifts = (0..DESCENTS).map(|k| -scale * 10f64.powi(k - 4));
    while pencil.count_below(pencil.shift)? > 0 {
        pencil.shift = shifts.next().ok_or_else(|| {
            SolveError::Eigen(format!(
                "no shift down to {:.3e} rad²/s² lies below every ω²",
                pencil.shift
            ))
        })?;
    }
    Ok(())
}

/// `B` and `Bᵀ` of the constraint blocks `b` with `BᵀB` added to the force block: the
/// penalty `[BᵀB, Bᵀ; B, 0]` that conditions the saddle point without changing its inertia
/// (module docs of [`crate::modal::pencil`]). A row's DOFs are its joint's nodes', whose
/// blocks the pattern holds.
fn with_gram(pattern: &Sparsity, b: &[f64], n_v: usize) -> Result<Vec<f64>, SolveError> {
    let mut out = b.to_vec();
    for row in n_v..pattern.n {
        let entries: Vec<(usize, f64)> = (pattern.col_ptr[row]..pattern.col_ptr[row + 1])
            .filter(|&s| pattern.row_idx[s] < n_v)
            .map(|s| (pattern.row_idx[s], b[s]))
            .collect();
        for &(i, bi) in &entries {
            for &(j, bj) in &entries {
                out[pattern.slot(i, j).ok_or_else(missing_entry)?] += bi * bj;
            }
        }
    }
    Ok(out)
}

/// `M = R Rᵀ` from the bodies' `diag(m I, J)` and the elements' mass matrices: the blocks
/// the assembler adds at `β' = 1`.
fn spatial_mass_factor(model: &SpatialModel) -> MassFactor {
    let dofs = |nodes: &[usize]| -> Vec<usize> {
        nodes
            .iter()
            .flat_map(|&n| (0..NV).map(move |k| NV * n + k))
            .collect()
    };
    let bodies = model.bodies.iter().map(|b| {
        let m = b.mass_matrix();
        (
            dofs(&[b.node]),
            DMatrix::from_iterator(NV, NV, m.iter().copied()),
        )
    });
    let elements = model.elements().map(|e| {
        let m = e.mass_matrix();
        let local = 2 * NV;
        (
            dofs(&e.nodes()),
            DMatrix::from_iterator(local, local, m.iter().copied()),
        )
    });
    MassFactor::new(bodies.chain(elements))
}

/// The velocity unknowns of the rotations of nodes only truss bars meet.
fn absent_rotations(model: &SpatialModel) -> Vec<usize> {
    (model.rotation_absent().iter().enumerate())
        .filter(|(_, a)| **a)
        .flat_map(|(n, _)| (3..NV).map(move |k| NV * n + k))
        .collect()
}

fn not_conservative(where_: &str, asymmetry: f64) -> Error {
    SolveError::Eigen(format!(
        "K_t is not symmetric {where_} (by {asymmetry:.1e} of its largest entry): a load is \
         not conservative (a dead moment or a follower load); the modes of non-conservative \
         systems are not built"
    ))
    .into()
}

fn massless() -> Error {
    SolveError::Eigen("the mass leaves a free direction without inertia".into()).into()
}

fn factor_error(e: FactorError) -> Error {
    SolveError::Eigen(format!("{e:?}")).into()
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

fn check(
    model: &SpatialModel,
    q: &[f64],
    lambda: &[f64],
    count: Option<usize>,
) -> Result<(), SettingsError> {
    let n_v = model.n_v();
    if count.is_none() && n_v > MAX_DENSE_UNKNOWNS {
        return Err(SettingsError::new(
            "model",
            format!(
                "{} nodes: every mode is found densely, for at most {} nodes \
                 ({MAX_DENSE_UNKNOWNS} unknowns); pass a count for the lowest modes of a larger one",
                model.nodes.len(),
                MAX_DENSE_UNKNOWNS / NV
            ),
        ));
    }
    if count == Some(0) {
        return Err(SettingsError::new(
            "count",
            "is 0: ask for at least one mode",
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

/// The force block (`n_v × n_v`) and the constraint rows (`B`) of values on the pattern,
/// dense.
fn dense(p: &Sparsity, values: &[f64], n_v: usize) -> (DMatrix<f64>, DMatrix<f64>) {
    let mut force = DMatrix::zeros(n_v, n_v);
    let mut rows = DMatrix::zeros(p.n - n_v, n_v);
    for c in 0..n_v {
        let range = p.col_ptr[c]..p.col_ptr[c + 1];
        for (&r, &v) in p.row_idx[range.clone()].iter().zip(&values[range]) {
            if r < n_v {
                force[(r, c)] = v;
            } else {
                rows[(r - n_v, c)] = v;
            }
        }
    }
    (force, rows)
}

/// An orthonormal basis of `{φ : B φ = 0}`: the right singular vectors of `B` whose singular
/// values are zero to [`RANK_TOLERANCE`] of the largest. `B` is padded with zero rows to at
/// least `n_v` so that its SVD's `V` is complete. (Not the eigenvectors of `BᵀB`: their
/// zero eigenvalues come out at round-off of the largest, `1e-16 σ²_max`, above a squared
/// tolerance, and free directions were lost — a body welded to a beam held its rotation.)
fn null_space(b: &DMatrix<f64>, n_v: usize) -> Result<DMatrix<f64>, Error> {
    if b.nrows() == 0 {
        return Ok(DMatrix::identity(n_v, n_v));
    }
    let mut padded = DMatrix::zeros(b.nrows().max(n_v), n_v);
    padded.rows_mut(0, b.nrows()).copy_from(b);
    let svd = padded.svd(false, true);
    let v_t = (svd.v_t).ok_or_else(|| {
        Error::from(SolveError::Eigen(
            "the joints' null space: the SVD gave no right singular vectors".into(),
        ))
    })?;
    let largest = svd.singular_values.amax();
    let free: Vec<usize> = (0..n_v)
        .filter(|&i| svd.singular_values[i] <= RANK_TOLERANCE * largest)
        .collect();
    Ok(DMatrix::from_fn(n_v, free.len(), |r, c| v_t[(free[c], r)]))
}

/// The error of an entry the pattern lacks where the assembler put it (an engine defect).
fn missing_entry() -> SolveError {
    SolveError::Setup("an entry missing from the sparsity pattern".into())
}
