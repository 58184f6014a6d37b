//! The restart of generalized-α at a kink of a drive's law, where the grid lands.
//!
//! Where a trapezoidal law changes phase its prescribed acceleration `g̈` jumps by `Δg̈`.
//! Positions, velocities and forces are continuous there, so the accelerations and
//! multipliers jump by the solution of
//!
//! ```text
//! [M, Φ_qᵀ; Φ_q, 0] [Δq̈; Δλ] = [0; Δg̈]          at (qₖ, tₖ)
//! ```
//!
//! A step that starts on such a kink first adds `Δq̈` to `q̈ₖ` and to the
//! pseudo-accelerations `aₖ` ([`Jump::apply`]); `λₖ` stays the left limit the step to
//! `tₖ` found. Without the restart, `a` carries the old law's accelerations into the next
//! steps and `q̈` and `λ` answer with an algorithmic oscillation that decays by about `ρ∞`
//! per step: joint reactions alternate in sign after the kink, by an amount that does not
//! fall with `h`. Adding the jump to `a` keeps what `a − q̈ ≈ Δ_α h q⃛` carries of the
//! smooth motion on the old side ([`crate::solver::alpha::rescale_pseudo_accelerations`]).
//!
//! The sensitivities differentiate `Δq̈(qₖ, x)` ([`crate::sensitivity`]'s `kink`). Where the
//! kinks lie and whether a row's acceleration jumps is the same in both engines ([`Kinks`],
//! [`jumps`]); the spatial engine solves its jump on the group (`spatial::integrator`).

use crate::error::SolveError;
use crate::mechanism::model::Model;
use crate::solver::newton::Newton;

/// A kink lies on a node when it is within this fraction of the step that reached the node;
/// a jump below this fraction of its size is none.
const ON_NODE: f64 = 1e-9;

/// The times where a drive's prescribed acceleration may jump.
#[derive(Debug, Clone, Default)]
pub struct Kinks {
    /// Times (s) after `t = 0`, sorted, without repeats.
    times: Vec<f64>,
}

impl Kinks {
    /// The kinks of `model`'s drives (not those of loads or motors: forces are continuous
    /// at theirs, so the accelerations are too).
    pub fn of(model: &Model) -> Self {
        let drives = model.joints.iter().filter_map(|j| j.drive.as_ref());
        Self::from_times(drives.flat_map(|m| m.kinks()))
    }

    /// The kinks among `times` (those after `t = 0`), sorted, without repeats.
    pub(crate) fn from_times(times: impl IntoIterator<Item = f64>) -> Self {
        let mut times: Vec<f64> = times.into_iter().filter(|&t| t > 0.0).collect();
        times.sort_by(f64::total_cmp);
        times.dedup();
        Self { times }
    }

    /// The kink at `t`, reached by a step of size `h`, if one lies there (`h = 0`, the
    /// initial state, has none: the initial accelerations are consistent already).
    pub(crate) fn at(&self, t: f64, h: f64) -> Option<f64> {
        let near = |k: f64| (k - t).abs() <= ON_NODE * h;
        let i = self.times.partition_point(|&k| k < t - ON_NODE * h);
        self.times.get(i).copied().filter(|&k| h > 0.0 && near(k))
    }

    /// `Δg̈ = g̈(tₖ⁺) − g̈(tₖ⁻)` of every constraint row at the kink on `t` (the law's two
    /// pieces read at the neighbouring floating-point times), or `None` where there is no
    /// kink or no acceleration jumps there (a kink of the jerk only).
    pub fn jump_at(&self, model: &Model, t: f64, h: f64) -> Option<(f64, Vec<f64>)> {
        let kink = self.at(t, h)?;
        let jump = |k: usize| {
            let before = model.constraints().prescribed(k, kink.next_down())[2];
            let after = model.constraints().prescribed(k, kink.next_up())[2];
            if jumps(before, after) {
                after - before
            } else {
                0.0
            }
        };
        // Allocates only where the scheme restarts: a table's knots pass without.
        let rows = 0..model.n_constraints();
        rows.clone()
            .any(|k| jump(k) != 0.0)
            .then(|| (kink, rows.map(jump).collect()))
    }
}

/// Whether a prescribed acceleration (or a row's `b`) jumps from `before` to `after`: by more
/// than a negligible fraction of its size.
pub(crate) fn jumps(before: f64, after: f64) -> bool {
    (after - before).abs() > ON_NODE * (after.abs() + before.abs())
}

/// The jump of accelerations and multipliers at a kink.
#[derive(Debug, Clone, PartialEq)]
pub struct Jump {
    /// The kink `tₖ` (s).
    pub t: f64,
    /// `qₖ`.
    pub q: Vec<f64>,
    /// `Δq̈`.
    pub dacc: Vec<f64>,
    /// `Δλ`.
    pub dlam: Vec<f64>,
}

impl Jump {
    /// Solves `[M, Φ_qᵀ; Φ_q, 0] [Δq̈; Δλ] = [0; Δg̈]` at `q` ([`Newton::acceleration_jump`]).
    ///
    /// # Errors
    /// [`SolveError::Singular`] if `M` is singular on the constraint manifold.
    pub fn solve(newton: &mut Newton, q: &[f64], t: f64, dg: &[f64]) -> Result<Self, SolveError> {
        let mut dacc = vec![0.0; q.len()];
        let mut dlam = vec![0.0; dg.len()];
        newton.acceleration_jump(q, t, dg, &mut dacc, &mut dlam)?;
        Ok(Self {
            t,
            q: q.to_vec(),
            dacc,
            dlam,
        })
    }

    /// `q̈ += Δq̈`, `a += Δq̈`.
    pub fn apply(&self, qddot: &mut [f64], a: &mut [f64]) {
        for ((acc, a), d) in qddot.iter_mut().zip(a.iter_mut()).zip(&self.dacc) {
            *acc += d;
            *a += d;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model(toml: &str) -> Model {
        crate::scene::build(&crate::scene::parse_toml(toml).unwrap()).unwrap()
    }

    /// The arm's trapezoidal drives (2 rad/s² up to 0.5 rad/s over π/6): the phases end at
    /// 0.25 s, π/3 s and π/3 + 0.25 s, where `g̈` jumps by −2, −2 and +2 rad/s² on
    /// the two driven rows and nowhere else; no kink between nodes or at the start.
    #[test]
    fn the_arms_drives_jump_at_their_phase_changes() {
        let arm = model(include_str!("../../examples/robot_arm.toml"));
        let kinks = Kinks::of(&arm);
        let third = std::f64::consts::FRAC_PI_3;
        let expected = [0.25, third, third + 0.25];
        assert_eq!(kinks.times.len(), 3);
        for (t, e) in kinks.times.iter().zip(expected) {
            assert!((t - e).abs() < 1e-12, "{t} against {e}");
        }
        let h = 0.01;
        for (t, jump) in expected.iter().zip([-2.0, -2.0, 2.0]) {
            // Reached by accumulated steps: a few ulps off the kink.
            let (kink, dg) = kinks.jump_at(&arm, t + 4.0 * f64::EPSILON, h).unwrap();
            assert_eq!(
                kink,
                *kinks.times.iter().find(|k| (*k - t).abs() < 1e-12).unwrap()
            );
            for (row, g) in arm.rows.iter().zip(&dg) {
                let want = if row.driven { jump } else { 0.0 };
                assert!(
                    (g - want).abs() < 1e-9,
                    "row of joint {}: {g} against {want}",
                    row.joint
                );
            }
        }
        assert!(
            kinks.jump_at(&arm, 0.25 + 1e-6, h).is_none(),
            "a kink between nodes"
        );
        assert!(
            kinks.jump_at(&arm, 0.25, 0.0).is_none(),
            "the initial state"
        );
    }

    /// A cubic spline's second derivative is continuous at its inner knots: the
    /// slider-crank's table drive, knots every 0.5 ms, gives no restart at any of them; at
    /// its last knot the table goes on at its end velocity, and the acceleration drops to 0.
    #[test]
    fn a_splines_inner_knots_are_no_jumps_and_its_end_is_one() {
        let crank = model(include_str!("../../examples/slider_crank.toml"));
        let kinks = Kinks::of(&crank);
        let (last, inner) = kinks.times.split_last().unwrap();
        assert!(inner.len() > 100);
        for &t in inner {
            assert!(kinks.jump_at(&crank, t, 5e-4).is_none(), "knot at {t}");
        }
        let (_, dg) = kinks.jump_at(&crank, *last, 5e-4).unwrap();
        let (row, jump) = crank
            .rows
            .iter()
            .zip(&dg)
            .find(|(_, g)| **g != 0.0)
            .unwrap();
        assert!(
            row.driven && *jump < 0.0,
            "the crank still accelerates at its last sample"
        );
        assert_eq!(dg.iter().filter(|g| **g != 0.0).count(), 1);
    }
}
