//! Each spatial beam's share of the change of the responses when the elements of every frame
//! beam are split in two: the dual-weighted residuals of the planar engine's
//! [`crate::sensitivity::shares`], on the rotation group.
//!
//! Let `u` be a run of a scene and `u_f` a run on the same steps of the scene with every
//! frame beam's elements split in two. The fine run's states at the coarse nodes, `R u_f`
//! (positions, rotations, velocities and accelerations taken node by node), satisfy the
//! coarse scheme's updates `qₙ₊₁ = qₙ ∘ exp(Δ)` and its relations between `Δ`, `v`, `v̇` and
//! `a`, all node by node, and its joints; only its equilibrium is off. At each time `tₙ`
//!
//! ```text
//! ρₙ = r(R u_f,ₙ) = Σ_b Δg_b,ₙ,   Δg_b = g_b(R u_f) − g_b^f(u_f)
//! ```
//!
//! where `g_b` is beam `b`'s elements' terms of the residual on its nodes in the coarse scene
//! (elastic, viscous, inertial and gyroscopic forces and weight, in each node's frame) and
//! `g_b^f` its halves' on the same nodes (a middle node's rows are the fine run's own
//! equilibrium). Bodies, joints, force elements, loads and truss bars are alike in both
//! scenes and cancel. So a response changes to first order by
//!
//! ```text
//! f(u_f) − f(u) ≈ Σₙ μₙᵀ ρₙ = Σ_b η_b,   η_b = Σₙ μₙᵀ Δg_b,ₙ
//! ```
//!
//! with `μₙ` the adjoint variables of the coarse force rows
//! ([`crate::spatial::sensitivity::dual_weights`]), the mean of those linearized about `u` and
//! about `R u_f` (the trapezoidal rule; `first_order` is `u`'s alone). That is the change of
//! `f_c(R u_f) − f_c(u)`; a response that reads the elements themselves changes by
//! `f_f(u_f) − f_c(R u_f)` besides, its own reading of the split beams on the same motion,
//! which for the strain energy's mean and the kinetic energy's integral (and the mean
//! compliance, the strain energy's in motion) is a sum over beams too, `Σₙ wₙ (E_b^f(u_f,ₙ) −
//! E_b(R u_f,ₙ))` of each beam's energy `E_b`: added to both. Left out: a stress's own
//! reading (a mean over the elements' points, not a sum over beams) and the jump of a
//! restart at a drive's kink.

use std::collections::HashMap;

use crate::error::{Error, SettingsError};
use crate::group::{NQ, NV};
use crate::settings::DynamicSettings;
use crate::solver::alpha::State;
use crate::spatial::element::Element;
use crate::spatial::force::Local;
use crate::spatial::integrator::run;
use crate::spatial::model::SpatialModel;
use crate::spatial::sensitivity::{dual_weights, trapezoid_weight, Response};
use crate::TimeGrid;

/// The responses on both scenes and each scene beam's share of their change.
#[derive(Debug, Clone, PartialEq)]
pub struct BeamShares {
    /// The responses on the coarse scene's run.
    pub values: Vec<f64>,
    /// The same responses on the fine scene's run.
    pub fine_values: Vec<f64>,
    /// `η_b` of each response (row) and scene beam (column, in the scene's order; a truss
    /// bar's is zero), row-major.
    pub shares: Vec<f64>,
    /// The same with the coarse run's weights alone.
    pub first_order: Vec<f64>,
}

/// A scene beam in both scenes: its elements in the coarse model's `beams` and in the fine
/// model's (twice as many, in the same order from end to end); none for a truss bar.
#[derive(Debug, Clone, PartialEq)]
pub struct SplitBeam {
    /// Its name in the scene.
    pub name: String,
    /// Its elements in the coarse model.
    pub coarse: Vec<usize>,
    /// Its elements in the fine model.
    pub fine: Vec<usize>,
}

/// Each scene beam's share (`beams`, in the scene's order) of the change of `responses`
/// (read on `coarse`; `fine_responses` the same on `fine`) from the run of `coarse` on `grid`
/// to the run of `fine`, `coarse` with every frame beam's elements split in two, on the same
/// steps, both at the same design (module docs).
///
/// # Errors
/// A [`SettingsError`] when `fine` is not `coarse` split in two; solve errors of the two runs
/// and the sweeps.
pub fn beam_shares(
    (coarse_model, fine_model): (&SpatialModel, &SpatialModel),
    beams: &[SplitBeam],
    settings: &DynamicSettings,
    grid: &TimeGrid,
    responses: &[Response],
    fine_responses: &[Response],
) -> Result<BeamShares, Error> {
    if fine_responses.len() != responses.len() {
        let msg = "must name the coarse scene's responses, one for one";
        return Err(SettingsError::new("fine responses", msg).into());
    }
    let map = Split::new(coarse_model, fine_model, beams)?;
    let (states, restarted) = run(coarse_model, settings, grid)?;
    let (fine_states, _) = run(fine_model, settings, grid)?;
    let fine_values = dual_weights(
        fine_model,
        settings,
        grid,
        fine_responses,
        (&fine_states, vec![false; fine_states.len()]),
        None,
    )?;
    let restricted: Vec<State> = fine_states.iter().map(|s| map.restrict(s)).collect();
    let residuals = Residuals {
        map: &map,
        coarse: coarse_model,
        fine: fine_model,
        restricted: &restricted,
        fine_states: &fine_states,
    };
    let (n_r, n_b) = (responses.len(), map.beams.len());
    let mut own = vec![0.0; n_r * n_b];
    let mut about = vec![0.0; n_r * n_b];
    let values = dual_weights(
        coarse_model,
        settings,
        grid,
        responses,
        (&states, restarted.clone()),
        Some(&mut residuals.weighing(&mut own)),
    )?;
    dual_weights(
        coarse_model,
        settings,
        grid,
        responses,
        (&restricted, restarted),
        Some(&mut residuals.weighing(&mut about)),
    )?;
    let mut shares: Vec<f64> = own.iter().zip(&about).map(|(a, b)| 0.5 * (a + b)).collect();
    for (k, r) in responses.iter().enumerate() {
        let Some(reading) = residuals.own_reading(r) else {
            continue;
        };
        for (b, change) in reading.iter().enumerate() {
            shares[k * n_b + b] += change;
            own[k * n_b + b] += change;
        }
    }
    Ok(BeamShares {
        values,
        fine_values,
        shares,
        first_order: own,
    })
}

/// How the fine scene's nodes and elements lie on the coarse scene's.
struct Split {
    /// Each coarse node's index among the fine scene's nodes.
    fine_node: Vec<usize>,
    /// Each scene beam's coarse elements, each with its two fine halves; empty for a truss
    /// bar.
    beams: Vec<Vec<(usize, [usize; 2])>>,
}

impl Split {
    fn new(
        cm: &SpatialModel,
        fm: &SpatialModel,
        split: &[SplitBeam],
    ) -> Result<Self, SettingsError> {
        let not_split = |what: String| {
            SettingsError::new(
                "fine scene",
                format!("is not the coarse scene with every frame beam split in two: {what}"),
            )
        };
        if fm.n_rows() != cm.n_rows() {
            return Err(not_split("its joints differ".into()));
        }
        let frame: Vec<&str> = (split.iter())
            .filter(|b| !b.coarse.is_empty())
            .map(|b| b.name.as_str())
            .collect();
        let by_name: HashMap<&str, usize> = (fm.nodes.iter().enumerate())
            .map(|(k, n)| (n.name.as_str(), k))
            .collect();
        let fine_node = (cm.nodes.iter())
            .map(|n| {
                let name = doubled(&n.name, &frame);
                by_name
                    .get(name.as_str())
                    .copied()
                    .ok_or_else(|| not_split(format!("it has no node {name}")))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let mut beams = Vec::with_capacity(split.len());
        for b in split {
            if b.fine.len() != 2 * b.coarse.len() {
                let name = &b.name;
                return Err(not_split(format!(
                    "beam {name} is not in twice its elements"
                )));
            }
            let halves: Vec<(usize, [usize; 2])> = (b.coarse.iter().enumerate())
                .map(|(j, &e)| (e, [b.fine[2 * j], b.fine[2 * j + 1]]))
                .collect();
            for &(e, [h0, h1]) in &halves {
                let ends = |m: &SpatialModel, e: usize| m.beams.get(e).map(|b| b.nodes());
                let meet = match (ends(cm, e), ends(fm, h0), ends(fm, h1)) {
                    (Some([a, z]), Some([a0, _]), Some([_, z1])) => {
                        a0 == fine_node[a] && z1 == fine_node[z]
                    }
                    _ => false,
                };
                if !meet {
                    let name = &b.name;
                    return Err(not_split(format!(
                        "beam {name}'s halves do not meet its ends"
                    )));
                }
            }
            beams.push(halves);
        }
        Ok(Self { fine_node, beams })
    }

    /// A fine state at the coarse nodes, `R u_f`.
    fn restrict(&self, s: &State) -> State {
        let take = |all: &[f64], width: usize| {
            (self.fine_node.iter())
                .flat_map(|&f| all[width * f..width * f + width].iter().copied())
                .collect::<Vec<_>>()
        };
        State {
            q: take(&s.q, NQ),
            qdot: take(&s.qdot, NV),
            qddot: take(&s.qddot, NV),
            a: take(&s.a, NV),
            ..s.clone()
        }
    }
}

/// A coarse node's name in the fine scene: `BEAM[k]` of a frame beam is `BEAM[2k]`.
fn doubled(name: &str, frame: &[&str]) -> String {
    let inner = name
        .strip_suffix(']')
        .and_then(|n| n.rsplit_once('['))
        .filter(|(beam, _)| frame.contains(beam))
        .and_then(|(beam, k)| Some((beam, k.parse::<usize>().ok()?)));
    match inner {
        Some((beam, k)) => format!("{beam}[{}]", 2 * k),
        None => name.to_string(),
    }
}

/// An element's energy at a state (J).
type Energy = fn(&dyn Element, &State) -> f64;

/// The beams' terms of the residual in both scenes at the design.
struct Residuals<'a> {
    map: &'a Split,
    coarse: &'a SpatialModel,
    fine: &'a SpatialModel,
    restricted: &'a [State],
    fine_states: &'a [State],
}

impl Residuals<'_> {
    /// Each beam's share of `f_f(u_f) − f_c(R u_f)`, the response's own reading of the split
    /// beams on the same motion, where it is a sum over beams (module docs); `None` for the
    /// others.
    fn own_reading(&self, r: &Response) -> Option<Vec<f64>> {
        let (energy, mean): (Energy, bool) = match r {
            Response::StrainEnergy | Response::Compliance => (|e, s| e.strain_energy(&s.q), true),
            Response::KineticEnergy => (|e, s| e.kinetic_energy(&s.qdot), false),
            _ => return None,
        };
        let states = self.fine_states;
        let duration = match states {
            [first, .., last] if mean => last.t - first.t,
            _ => 1.0,
        };
        let reading = (self.map.beams.iter())
            .map(|halves| {
                (0..states.len())
                    .map(|n| {
                        let w = trapezoid_weight(states, n) / duration;
                        let change: f64 = (halves.iter())
                            .map(|&(e, [h0, h1])| {
                                let fine = energy(&self.fine.beams[h0], &states[n])
                                    + energy(&self.fine.beams[h1], &states[n]);
                                fine - energy(&self.coarse.beams[e], &self.restricted[n])
                            })
                            .sum();
                        w * change
                    })
                    .sum()
            })
            .collect();
        Some(reading)
    }

    /// Adds `μₙ,ₖᵀ Δg_b,ₙ` to `out[k · beams + b]` as a sweep gives each `(n, k, μ)`.
    fn weighing<'a>(&'a self, out: &'a mut [f64]) -> impl FnMut(usize, usize, &[f64]) + 'a {
        let n_b = self.map.beams.len();
        move |n, k, mu| {
            self.for_each_term(n, |b, row, value| out[k * n_b + b] += mu[row] * value);
        }
    }

    /// Calls `add(b, i, v)` for each term `v` of `Δg_b,ₙ` on the coarse velocity row `i`:
    /// beam `b`'s elements in the coarse scene at `R u_f,ₙ`, less their halves' in the fine
    /// scene at `u_f,ₙ` on the coarse nodes.
    fn for_each_term(&self, n: usize, mut add: impl FnMut(usize, usize, f64)) {
        let terms = |model: &SpatialModel, e: usize, s: &State| -> Local {
            let t = model.beams[e].terms(&s.q, &s.qdot, Some(&s.qddot), &model.gravity, None);
            t.internal + t.inertia
        };
        let (coarse_at, fine_at) = (&self.restricted[n], &self.fine_states[n]);
        for (b, halves) in self.map.beams.iter().enumerate() {
            for &(e, [h0, h1]) in halves {
                let g = terms(self.coarse, e, coarse_at);
                let (f0, f1) = (terms(self.fine, h0, fine_at), terms(self.fine, h1, fine_at));
                let nodes = self.coarse.beams[e].nodes();
                for (side, fine_half) in [(0, f0), (1, f1)] {
                    for i in 0..NV {
                        let row = NV * side + i;
                        add(b, NV * nodes[side] + i, g[row] - fine_half[row]);
                    }
                }
            }
        }
    }
}
