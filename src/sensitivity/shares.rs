//! Each bar's share of the change of the responses when the elements of the frame bars are
//! split in two: dual-weighted residuals of the discrete scheme (Becker and Rannacher's
//! goal-oriented estimate, with the adjoint that the gradients already compute).
//!
//! Let `u` be a run of a model and `u_f` a run on the same steps of the same scene with
//! every element of a frame bar split in two ([`crate::Prolongation`]). The fine run's
//! values at the coarse nodes, `R u_f`, satisfy the coarse scheme's Newmark relations (node
//! by node: they are linear in the states) and its joints; only its equilibrium is off. At
//! each time `tₙ`
//!
//! ```text
//! ρₙ = r(R u_f,ₙ) = Σ_b Δg_b,ₙ,   Δg_b = g_b(R u_f) − g_b^f(u_f)
//! ```
//!
//! where `g_b` is bar `b`'s terms of the residual on its nodes in the coarse model (inertia,
//! internal force, damping, gravity, end coupling: the residual of Algorithm 1) and `g_b^f`
//! those of its halves on the same nodes. The rows of the middle nodes are the fine run's own
//! equilibrium (zero), and everything else (bodies, springs, joints, loads) is alike in both
//! models and cancels. So `R u_f` is the coarse run with `ρ` added to its residual, and a
//! response changes to first order by
//!
//! ```text
//! f(u_f) − f(u) ≈ Σₙ μₙᵀ ρₙ = Σ_b η_b,   η_b = Σₙ μₙᵀ Δg_b,ₙ
//! ```
//!
//! with `μₙ` the adjoint of the coarse residual at `tₙ` ([`super::adjoint::dual_weights`]):
//! `η_b`, the change bar `b`'s splitting makes, is its **share**. The weights are the mean of
//! the adjoints linearized about `u` and about `R u_f` (the trapezoidal rule, exact for a
//! linear scheme and a quadratic response such as the tip deflection, third order otherwise);
//! `u`'s alone (`first_order`) is off by 3–74 % on the designs measured and has the wrong
//! sign where splitting a bar adds a resonance (BENCHMARKS.md, "Each bar's share, measured").
//!
//! Left out: the responses' own reading of a split bar (a strain energy or a stress reads
//! its elements; tip deflections, joint positions and reactions read nodes and joints, alike
//! in both models), and the jump system of a restart at a drive's kink. A run from the
//! static equilibrium is refused: its start differs between the models too.

use super::adjoint::{dual_weights, Path};
use super::PseudoLoads;
use crate::error::{Error, SettingsError};
use crate::mechanism::element::Kind;
use crate::mechanism::model::{Initial, Model};
use crate::mechanism::parameter::{At, Level};
use crate::response::Response;
use crate::settings::DynamicSettings;
use crate::solver::assembly::Assembler;
use crate::solver::prolongation::Prolongation;
use crate::time_grid::TimeGrid;

/// The coarse run's response values and each bar's share of their change.
#[derive(Debug, Clone, PartialEq)]
pub struct Shares {
    /// The responses on the coarse model.
    pub values: Vec<f64>,
    /// `η_b` of each response (row) and bar (column, the coarse model's bars), row-major.
    pub shares: Vec<f64>,
    /// The same with the coarse run's weights alone.
    pub first_order: Vec<f64>,
}

/// Each bar's share of the change of `responses` from the run of `coarse` on `grid` for the
/// design `x` to the run `fine_run` of `fine` (`coarse` with every frame bar's elements
/// split in two) on the same steps.
///
/// # Errors
/// A [`SettingsError`] when `fine` is not `coarse` split in two, when `fine_run` has not one
/// finite row per time, or for a run from the static equilibrium; design and solve errors
/// of the coarse run and its adjoint.
pub fn bar_shares(
    coarse: &Model,
    fine: &Model,
    x: &[f64],
    settings: &DynamicSettings,
    grid: &TimeGrid,
    responses: &[Response],
    fine_run: Path<'_>,
) -> Result<Shares, Error> {
    if coarse.initial == Initial::Equilibrium {
        return Err(SettingsError::new(
            "initial",
            "bar shares need a run from rest: from the static equilibrium the models start apart",
        )
        .into());
    }
    let n_c = coarse.n_constraints();
    if fine.n_constraints() != n_c {
        let msg = "has other joints than the coarse model: not the coarse one split";
        return Err(SettingsError::new("fine model", msg).into());
    }
    fine_run.check("fine run", fine.n_dofs(), n_c, grid.len() + 1)?;
    let map = NodeMap::new(coarse, fine)?;
    let (n_q, n_f) = (coarse.n_dofs(), fine.n_dofs());
    let restricted = Restricted::of(&map, fine_run, n_q, grid.len() + 1);
    let path = Path {
        q: &restricted.q,
        qdot: &restricted.qdot,
        qddot: &restricted.qddot,
        lam: fine_run.lam,
    };
    let densities = || coarse.densities(Some(x));
    let (values, about_coarse) =
        dual_weights(coarse, densities()?, settings, grid, responses, None)?;
    let (_, about_fine) =
        dual_weights(coarse, densities()?, settings, grid, responses, Some(path))?;
    let residuals = Residuals::new(coarse, fine, x, settings)?;
    let (n_r, n_b) = (responses.len(), coarse.bars.len());
    let mut shares = vec![0.0; n_r * n_b];
    let mut first_order = vec![0.0; n_r * n_b];
    for (n, &t) in grid.times().iter().enumerate() {
        crate::interrupt::poll()?;
        let fine_at = row_at(
            fine_run.q,
            fine_run.qdot,
            fine_run.qddot,
            n * n_f..(n + 1) * n_f,
            t,
        );
        let coarse_at = row_at(path.q, path.qdot, path.qddot, n * n_q..(n + 1) * n_q, t);
        let w = n * n_r * n_q..(n + 1) * n_r * n_q;
        let (own, about) = (&about_coarse[w.clone()], &about_fine[w]);
        residuals.for_each_term(&map, &coarse_at, &fine_at, |b, dof, value| {
            for k in 0..n_r {
                let (i, j) = (k * n_q + dof, k * n_b + b);
                shares[j] += 0.5 * (own[i] + about[i]) * value;
                first_order[j] += own[i] * value;
            }
        });
    }
    Ok(Shares {
        values,
        shares,
        first_order,
    })
}

/// `rows` of a run's states at time `t`, as the residual's terms read them.
fn row_at<'s>(
    q: &'s [f64],
    v: &'s [f64],
    a: &'s [f64],
    rows: std::ops::Range<usize>,
    t: f64,
) -> At<'s> {
    At {
        q: &q[rows.clone()],
        rates: Some((&v[rows.clone()], &a[rows])),
        lam: &[],
        t,
        level: Level::Position,
    }
}

/// Which coarse node each fine node is (`None` for the middles), and the bars matched by name.
struct NodeMap {
    coarse_node: Vec<Option<usize>>,
    /// Each coarse bar's index among the fine model's bars.
    fine_bar: Vec<usize>,
    /// Each fine bar's index among the coarse model's.
    coarse_bar: Vec<Option<usize>>,
}

impl NodeMap {
    fn new(coarse: &Model, fine: &Model) -> Result<Self, SettingsError> {
        let prolongation = Prolongation::between(coarse, fine)?;
        let fine_bar = coarse
            .bars
            .iter()
            .map(|bar| fine.bars.iter().position(|b| b.name == bar.name))
            .collect::<Option<Vec<_>>>()
            .ok_or_else(|| SettingsError::new("fine model", "misses a bar of the coarse one"))?;
        let mut coarse_bar = vec![None; fine.bars.len()];
        for (b, &f) in fine_bar.iter().enumerate() {
            coarse_bar[f] = Some(b);
        }
        Ok(Self {
            coarse_bar,
            coarse_node: (0..fine.nodes.len())
                .map(|k| prolongation.coarse_node(k))
                .collect(),
            fine_bar,
        })
    }

    /// The coarse coordinate of fine coordinate `d`, if its node is a coarse one.
    fn coarse_dof(&self, d: usize) -> Option<usize> {
        self.coarse_node[d / 3].map(|c| 3 * c + d % 3)
    }
}

/// The fine run's states at the coarse nodes, `R u_f`, at every time.
struct Restricted {
    q: Vec<f64>,
    qdot: Vec<f64>,
    qddot: Vec<f64>,
}

impl Restricted {
    fn of(map: &NodeMap, fine: Path<'_>, n_q: usize, times: usize) -> Self {
        let n_f = fine.q.len() / times;
        let take = |all: &[f64]| {
            let mut out = vec![0.0; n_q * times];
            for (row, fine_row) in out.chunks_mut(n_q).zip(all.chunks(n_f)) {
                for (d, &v) in fine_row.iter().enumerate() {
                    if let Some(c) = map.coarse_dof(d) {
                        row[c] = v;
                    }
                }
            }
            out
        };
        Self {
            q: take(fine.q),
            qdot: take(fine.qdot),
            qddot: take(fine.qddot),
        }
    }
}

/// The bars' terms of the residual in both models, at the design's densities.
struct Residuals<'m> {
    coarse: Assembler<'m>,
    fine: Assembler<'m>,
    coarse_terms: PseudoLoads,
    fine_terms: PseudoLoads,
}

impl<'m> Residuals<'m> {
    fn new(
        coarse: &'m Model,
        fine: &'m Model,
        x: &[f64],
        settings: &DynamicSettings,
    ) -> Result<Self, Error> {
        let kind = settings.mass;
        Ok(Self {
            coarse: Assembler::new(coarse, coarse.densities(Some(x))?, kind)?,
            fine: Assembler::new(fine, fine.densities(Some(x))?, kind)?,
            coarse_terms: PseudoLoads::new(coarse, kind, &[]),
            fine_terms: PseudoLoads::new(fine, kind, &[]),
        })
    }

    /// Calls `add(b, i, v)` for each term `v` of `Δg_b` on coarse coordinate `i`: bar `b`'s
    /// elements and end coupling in the coarse model at `at`, less its halves' in the fine
    /// model at `at_fine` on the coarse nodes. A truss bar is one element in both.
    fn for_each_term(
        &self,
        map: &NodeMap,
        at: &At<'_>,
        at_fine: &At<'_>,
        mut add: impl FnMut(usize, usize, f64),
    ) {
        let (coarse, fine) = (self.coarse.model, self.fine.model);
        let (dc, df) = (&self.coarse.densities, &self.fine.densities);
        for (b, bar) in coarse.bars.iter().enumerate() {
            if bar.kind == Kind::Truss {
                continue;
            }
            for e in bar.elements.clone() {
                let g = self.coarse_terms.element_residual(
                    &self.coarse,
                    e,
                    at,
                    dc.mass[e],
                    dc.stiffness[e],
                );
                coarse.elements[e]
                    .dofs()
                    .iter()
                    .zip(g.iter())
                    .for_each(|(&i, &v)| add(b, i, v));
            }
            for e in fine.bars[map.fine_bar[b]].elements.clone() {
                let g = self.fine_terms.element_residual(
                    &self.fine,
                    e,
                    at_fine,
                    df.mass[e],
                    df.stiffness[e],
                );
                for (&i, &v) in fine.elements[e].dofs().iter().zip(g.iter()) {
                    if let Some(c) = map.coarse_dof(i) {
                        add(b, c, -v);
                    }
                }
            }
        }
        // The bars' end couplings (`mass = "bar_lumped"`), whose coefficient differs.
        let kind = self.coarse.mass_kind;
        for bar in coarse.bar_couplings(kind) {
            let b = coarse.elements[bar.element].bar;
            let g = PseudoLoads::coupling_residual(bar, &self.coarse, at, dc.mass[bar.element]);
            bar.dofs().iter().zip(g).for_each(|(&i, v)| add(b, i, v));
        }
        for bar in fine.bar_couplings(kind) {
            let Some(b) = map.coarse_bar[fine.elements[bar.element].bar] else {
                continue;
            };
            let g = PseudoLoads::coupling_residual(bar, &self.fine, at_fine, df.mass[bar.element]);
            for (&i, v) in bar.dofs().iter().zip(g) {
                if let Some(c) = map.coarse_dof(i) {
                    add(b, c, -v);
                }
            }
        }
    }
}
