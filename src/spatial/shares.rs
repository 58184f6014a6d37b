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
//! about `R u_f` (the trapezoidal rule; `first_order` is `u`'s alone). Left out, as on planar
//! scenes: a response's own reading of a split beam (a strain energy, a stress) and the jump
//! of a restart at a drive's kink.

use std::collections::HashMap;

use crate::error::{Error, SettingsError};
use crate::group::{NQ, NV};
use crate::scene::spatial::SpatialScene;
use crate::settings::DynamicSettings;
use crate::solver::alpha::State;
use crate::spatial::element::Element;
use crate::spatial::force::Local;
use crate::spatial::integrator::run;
use crate::spatial::model::SpatialModel;
use crate::spatial::sensitivity::{dual_weights, Response};
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

/// Each scene beam's share of the change of `responses` (read on `coarse`; `fine_responses`
/// the same on `fine`) from the run of `coarse` on `grid` at design `x` to the run of `fine`,
/// `coarse` with every frame beam's elements split in two, on the same steps (module docs).
///
/// # Errors
/// A [`SettingsError`] when `fine` is not `coarse` split in two; design and solve errors of
/// the two runs and the sweeps.
pub fn beam_shares(
    coarse: &SpatialScene,
    fine: &SpatialScene,
    x: Option<&[f64]>,
    settings: &DynamicSettings,
    grid: &TimeGrid,
    responses: &[Response],
    fine_responses: &[Response],
) -> Result<BeamShares, Error> {
    if fine_responses.len() != responses.len() {
        let msg = "must name the coarse scene's responses, one for one";
        return Err(SettingsError::new("fine responses", msg).into());
    }
    let map = Split::new(coarse, fine)?;
    let (coarse_model, fine_model) = (coarse.model_at(x)?, fine.model_at(x)?);
    let (states, restarted) = run(&coarse_model, settings, grid)?;
    let (fine_states, _) = run(&fine_model, settings, grid)?;
    let fine_values = dual_weights(
        &fine_model,
        settings,
        grid,
        fine_responses,
        (&fine_states, vec![false; fine_states.len()]),
        None,
    )?;
    let restricted: Vec<State> = fine_states.iter().map(|s| map.restrict(s)).collect();
    let residuals = Residuals {
        map: &map,
        coarse: &coarse_model,
        fine: &fine_model,
        restricted: &restricted,
        fine_states: &fine_states,
    };
    let (n_r, n_b) = (responses.len(), map.beams.len());
    let mut own = vec![0.0; n_r * n_b];
    let mut about = vec![0.0; n_r * n_b];
    let values = dual_weights(
        &coarse_model,
        settings,
        grid,
        responses,
        (&states, restarted.clone()),
        Some(&mut residuals.weighing(&mut own)),
    )?;
    dual_weights(
        &coarse_model,
        settings,
        grid,
        responses,
        (&restricted, restarted),
        Some(&mut residuals.weighing(&mut about)),
    )?;
    Ok(BeamShares {
        values,
        fine_values,
        shares: own.iter().zip(&about).map(|(a, b)| 0.5 * (a + b)).collect(),
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
    fn new(coarse: &SpatialScene, fine: &SpatialScene) -> Result<Self, SettingsError> {
        let not_split = |what: String| {
            SettingsError::new(
                "fine scene",
                format!("is not the coarse scene with every frame beam split in two: {what}"),
            )
        };
        let (cm, fm) = (&coarse.model, &fine.model);
        if fm.n_rows() != cm.n_rows() || fine.beams.len() != coarse.beams.len() {
            return Err(not_split("its joints or beams differ".into()));
        }
        let frame: Vec<&str> = (coarse.beams.iter())
            .filter(|(_, b)| !b.truss)
            .map(|(name, _)| name.as_str())
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
        let mut beams = Vec::with_capacity(coarse.beams.len());
        for ((name, c), f) in coarse.beams.iter().zip(fine.beams.values()) {
            if c.truss {
                beams.push(Vec::new());
                continue;
            }
            if f.truss || f.elements.len() != 2 * c.elements.len() {
                return Err(not_split(format!(
                    "beam {name} is not in twice its elements"
                )));
            }
            let halves: Vec<(usize, [usize; 2])> = (c.elements.iter().enumerate())
                .map(|(j, &e)| (e, [f.elements[2 * j], f.elements[2 * j + 1]]))
                .collect();
            for &(e, [h0, h1]) in &halves {
                let [a, b] = cm.beams[e].nodes().map(|n| fine_node[n]);
                if fm.beams[h0].nodes()[0] != a || fm.beams[h1].nodes()[1] != b {
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

/// The beams' terms of the residual in both scenes at the design.
struct Residuals<'a> {
    map: &'a Split,
    coarse: &'a SpatialModel,
    fine: &'a SpatialModel,
    restricted: &'a [State],
    fine_states: &'a [State],
}

impl Residuals<'_> {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::spatial::tests::{built, PENDULUM};
    use crate::settings::RunOptions;

    fn shares_of(
        coarse: &SpatialScene,
        fine: &SpatialScene,
        names: [&[&str]; 2],
    ) -> Result<BeamShares, Error> {
        let named = |s: &SpatialScene, names: &[&str]| {
            names
                .iter()
                .map(|r| s.response(r).unwrap())
                .collect::<Vec<_>>()
        };
        let settings = RunOptions::default().dynamic(&coarse.options).unwrap();
        let x = [0.6, 0.3, 0.5];
        let (rs, fs) = (named(coarse, names[0]), named(fine, names[1]));
        let grid = settings.grid();
        beam_shares(coarse, fine, Some(&x), &settings, &grid, &rs, &fs)
    }

    /// The shares of the flexible pendulum's node positions (its end's, an inner node's)
    /// add up to the change that splitting every beam makes, within 1 %; the truss bar has
    /// none.
    #[test]
    fn shares_add_up_to_the_change_of_splitting() {
        let coarse = built(PENDULUM).unwrap();
        let fine = built(&PENDULUM.replace("split = 2", "split = 4")).unwrap();
        let responses = ["x:c", "z:c", "y:lower[1]"];
        let out = shares_of(&coarse, &fine, [&responses, &["x:c", "z:c", "y:lower[2]"]]).unwrap();
        let n_b = coarse.beams.len();
        let truss = coarse.beams.keys().position(|b| b == "brace").unwrap();
        for (k, name) in responses.iter().enumerate() {
            let change = out.fine_values[k] - out.values[k];
            let row = &out.shares[k * n_b..(k + 1) * n_b];
            let sum: f64 = row.iter().sum();
            assert!(
                change.abs() > 1e-9,
                "{name}: no change to measure ({change:e})"
            );
            assert!(
                (sum - change).abs() <= 1e-2 * change.abs(),
                "{name}: shares {sum:e} against the change {change:e}"
            );
            assert_eq!(row[truss], 0.0);
        }
    }

    /// A fine scene that is not the coarse one split in two is named.
    #[test]
    fn a_scene_not_split_in_two_is_named() {
        let coarse = built(PENDULUM).unwrap();
        for (fine, words) in [
            (PENDULUM.to_string(), "it has no node upper[2]"),
            (
                PENDULUM.replace("split = 2", "split = 3"),
                "beam lower is not in twice its elements",
            ),
        ] {
            let fine = built(&fine).unwrap();
            let e = shares_of(&coarse, &fine, [&["x:c"], &["x:c"]]).unwrap_err();
            assert!(e.to_string().contains(words), "{e}");
        }
        let e = shares_of(&coarse, &coarse, [&["x:c"], &[]]).unwrap_err();
        assert!(e.to_string().contains("one for one"), "{e}");
    }
}
