//! Motors: a torque (a slider's force) applied on a joint's own coordinate `s`
//! ([`crate::joint::planar::Joint::coordinate`]), constant, scaled by a time table, or a PD
//! servo following a motion law.
//!
//! A motor acts where `s` is linear in `q` (a pin, a hinge, a slider on a ground axis), so
//! its generalized force `τ ∂s/∂q` has a constant direction. A PD servo
//! `τ = k_p (θ_r − s) + k_d (θ̇_r − ṡ)` is a spring-damper on `s` (`k_p`, `k_d`, among the
//! model's springs, in the exact tangent) plus the applied part `k_p θ_r(t) + k_d θ̇_r(t)`,
//! with `θ_r(t) − θ_r(0)` from the scene's configuration. Units: N m and rad at a pin or
//! hinge, N and m along a slider.

use crate::joint::motion::Motion;
use crate::mechanism::load::TimeFunction;

/// How a motor's applied torque follows time.
#[derive(Debug, Clone, PartialEq)]
pub enum MotorLaw {
    /// `τ(t) = value · g(t)`.
    Torque {
        /// Torque at `g = 1`.
        value: f64,
        /// Time scaling.
        time: TimeFunction,
    },
    /// The applied part of a PD servo following `motion` (its spring-damper is a
    /// [`crate::mechanism::spring::Spring`]).
    Servo {
        /// Proportional gain `k_p` (N m/rad or N/m).
        kp: f64,
        /// Derivative gain `k_d` (N m s/rad or N s/m).
        kd: f64,
        /// The reference `θ_r(t)`.
        motion: Motion,
        /// Its spring-damper's index in [`crate::mechanism::model::Model::springs`].
        spring: usize,
    },
}

/// A named motor on a joint's coordinate.
#[derive(Debug, Clone, PartialEq)]
pub struct Motor {
    /// Name, for messages.
    pub name: String,
    /// The coordinate's DOFs `[x_a, y_a, φ_a, x_b, y_b, φ_b]` (`None` on the ground).
    pub dofs: [Option<usize>; 6],
    /// `∂s/∂q` on those DOFs (constant).
    pub direction: [f64; 6],
    /// How the torque follows time.
    pub law: MotorLaw,
}

impl Motor {
    /// The applied torque `τ(t)`: the servo's feed of its reference, its rate only in
    /// `motion` (a static equilibrium has no `k_d ṡ` to balance `k_d θ̇_r`).
    pub fn applied(&self, t: f64, motion: bool) -> f64 {
        match &self.law {
            MotorLaw::Torque { value, time } => value * time.at(t),
            MotorLaw::Servo {
                kp,
                kd,
                motion: law,
                ..
            } => {
                let (now, start) = (law.at(t), law.at(0.0));
                let rate = if motion { kd * now.velocity } else { 0.0 };
                kp * (now.angle - start.angle) + rate
            }
        }
    }

    /// Times where the torque's rate jumps (a table's samples, a law's kinks).
    pub fn kinks(&self) -> Vec<f64> {
        match &self.law {
            MotorLaw::Torque { time, .. } => time.kinks(),
            MotorLaw::Servo { motion, .. } => motion.kinks(),
        }
    }

    /// Adds `factor · τ(t) ∂s/∂q` to the nodal forces `f` (of a motion, or of a static
    /// equilibrium).
    pub fn add_force(&self, t: f64, factor: f64, motion: bool, f: &mut [f64]) {
        let torque = factor * self.applied(t, motion);
        for (d, g) in self.dofs.iter().zip(self.direction) {
            if let Some(d) = d {
                f[*d] += torque * g;
            }
        }
    }
}
