//! Responses weighted over the states of a run, as the sensitivity sweeps read them: the
//! values, their partials at each state, the aggregates' references (the peak so far) and
//! the rigid trajectories the tip deflections measure from.

use super::{Context, Known, Partials, Response, Sample};
use crate::error::Error;
use crate::mechanism::model::{Analysis, Model};
use crate::mechanism::parameter::Parameter;
use crate::mechanism::rigid::Clusters;
use crate::time_grid::TimeGrid;

/// Responses with their weights on a time grid and the rigid trajectories they need.
pub(crate) struct Objectives<'a> {
    responses: &'a [Response],
    /// The scene parameters, whose columns follow the design variables'.
    parameters: &'a [Parameter],
    /// Per response: the rigid trajectory of its [`Response::rigid_node`] at every state
    /// of the grid, empty for a response without one.
    rigid: Vec<Vec<[f64; 2]>>,
    /// Per response and parameter: the rates of that trajectory to a drive-law parameter
    /// at every state, empty for the others.
    rigid_rates: Vec<Vec<Vec<[f64; 2]>>>,
    analysis: Analysis,
    grid: &'a TimeGrid,
    /// Per response: the reference of its aggregate, the largest point value so far (0
    /// for the others).
    references: Vec<f64>,
}

impl<'a> Objectives<'a> {
    /// Objectives over the states of `grid` (a grid without steps for statics), with
    /// gradients to the design variables and to `parameters`.
    pub(crate) fn new(
        model: &Model,
        responses: &'a [Response],
        parameters: &'a [Parameter],
        grid: &'a TimeGrid,
    ) -> Result<Self, Error> {
        let clusters = Clusters::of(model);
        let times = grid.times();
        let needed = responses.iter().any(|r| r.rigid_node().is_some());
        let motion = if needed {
            clusters.rigid_motion(model, times)?
        } else {
            Vec::new()
        };
        let (mut rigid, mut rigid_rates) = (Vec::new(), Vec::new());
        for r in responses {
            let Some(node) = r.rigid_node() else {
                rigid.push(Vec::new());
                rigid_rates.push(vec![Vec::new(); parameters.len()]);
                continue;
            };
            rigid.push(
                motion
                    .iter()
                    .map(|rho| clusters.position(model, rho, node))
                    .collect(),
            );
            let rates = parameters
                .iter()
                .map(|p| match p.drive(model, 0.0) {
                    Some((row, _)) => {
                        let g: Vec<f64> = times
                            .iter()
                            .map(|&t| p.drive(model, t).map_or(0.0, |(_, s)| s.angle))
                            .collect();
                        clusters.trajectory_rates(model, &motion, times, node, row, &g)
                    }
                    None => Ok(Vec::new()),
                })
                .collect::<Result<_, _>>()?;
            rigid_rates.push(rates);
        }
        Ok(Self {
            responses,
            parameters,
            rigid,
            rigid_rates,
            analysis: model.analysis,
            grid,
            references: vec![0.0; responses.len()],
        })
    }

    /// The number of responses.
    pub(crate) fn len(&self) -> usize {
        self.responses.len()
    }

    /// What response `k` needs at state `n` besides the state: its rigid position (zeros
    /// for a response that needs none: its trajectory is empty) and its reference.
    fn known(&self, k: usize, n: usize) -> Known {
        Known {
            rigid: self.rigid[k].get(n).copied().unwrap_or_default(),
            reference: self.references[k],
        }
    }

    /// Raises the references of the aggregates to the point values of state `at`, carrying
    /// the sums accumulated so far in `values` and in the rows of `gradients` (row-major,
    /// empty when the caller keeps none) to the new reference. Call before
    /// [`Self::add_values`] at every state.
    pub(crate) fn observe(
        &mut self,
        ctx: &Context,
        at: Sample,
        values: &mut [f64],
        gradients: &mut [f64],
    ) {
        let n_x = gradients.len() / values.len().max(1);
        for (k, r) in self.responses.iter().enumerate() {
            let Some(a) = r.aggregation() else { continue };
            let peak = r.peak(ctx, at);
            if peak > self.references[k] {
                let factor = a.rescale(self.references[k], peak);
                values[k] *= factor;
                gradients
                    .iter_mut()
                    .skip(k * n_x)
                    .take(n_x)
                    .for_each(|g| *g *= factor);
                self.references[k] = peak;
            }
        }
    }

    /// Turns the sums of the aggregates into their means, and their gradient rows
    /// (row-major, possibly empty) by the chain rule.
    pub(crate) fn finish(&self, values: &mut [f64], gradients: &mut [f64]) {
        let n_x = gradients.len() / values.len().max(1);
        for (k, r) in self.responses.iter().enumerate() {
            if let Some(a) = r.aggregation() {
                let (mean, slope) = a.mean(values[k], self.references[k]);
                values[k] = mean;
                gradients
                    .iter_mut()
                    .skip(k * n_x)
                    .take(n_x)
                    .for_each(|g| *g *= slope);
            }
        }
    }

    /// `G_k` of response `k` at state `n` as its time sum weighs it (per unit time for a
    /// mean), with the references of the whole run; `None` for a response that is not a sum
    /// over the run's states ([`Response::per_time`]).
    pub(crate) fn integrand(&self, ctx: &Context, k: usize, n: usize, at: Sample) -> Option<f64> {
        let r = &self.responses[k];
        let factor = r.per_time(self.analysis, self.grid.duration())?;
        Some(factor * r.integrand(ctx, at, self.known(k, n)))
    }

    /// The peaks of the aggregates over the states observed.
    pub(crate) fn peaks(&self) -> Vec<Option<f64>> {
        self.responses
            .iter()
            .zip(&self.references)
            .map(|(r, &p)| r.aggregation().map(|_| p))
            .collect()
    }

    /// Adds `wₙ G_k(qₙ, λₙ)` to each value (and the explicit responses once, at `n = 0`).
    pub(crate) fn add_values(&self, ctx: &Context, n: usize, at: Sample, values: &mut [f64]) {
        for (k, r) in self.responses.iter().enumerate() {
            if !r.depends_on_states() {
                if n == 0 {
                    values[k] += r.integrand(ctx, at, Known::default());
                }
                continue;
            }
            let w = r.weight(self.analysis, n, self.grid);
            if w != 0.0 {
                values[k] += w * r.integrand(ctx, at, self.known(k, n));
            }
        }
    }

    /// Adds `wₙ G_q` of response `k` at state `n` to `g_q`, `wₙ G_λ` to `g_lam` and
    /// `wₙ G_x` to `g_x`, then `wₙ G_p` of the parameters to its last entries, and
    /// `wₙ G_q̇` to `g_v` for a response that reads velocities (explicit responses
    /// contribute their gradient at `n = 0`).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn add_partials(
        &self,
        ctx: &Context,
        k: usize,
        n: usize,
        at: Sample,
        g_q: &mut [f64],
        g_lam: &mut [f64],
        g_x: &mut [f64],
        g_v: &mut [f64],
    ) {
        let r = &self.responses[k];
        let w = if r.depends_on_states() {
            r.weight(self.analysis, n, self.grid)
        } else {
            f64::from(u8::from(n == 0))
        };
        if w != 0.0 {
            let g = Partials {
                q: g_q,
                lam: g_lam,
                x: g_x,
            };
            r.add_partials(ctx, at, self.known(k, n), w, g);
            let first = g_x.len() - self.parameters.len();
            let known = self.known(k, n);
            for ((g, p), rates) in g_x[first..]
                .iter_mut()
                .zip(self.parameters)
                .zip(&self.rigid_rates[k])
            {
                *g += w * r.parameter_partial(ctx, at, known, p);
                if let Some(&rate) = rates.get(n) {
                    *g += w * r.rigid_partial(ctx, at, known, rate);
                }
            }
            if r.reads_velocities() {
                r.add_rate_partials(ctx, at, w, g_v);
            }
        }
    }

    /// Whether a response reads the velocities, which a run must then keep.
    pub(crate) fn read_velocities(&self) -> bool {
        self.responses.iter().any(Response::reads_velocities)
    }
}
