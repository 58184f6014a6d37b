//! A spatial rigid body: its node at the centre of mass, its mass and full inertia tensor,
//! and the inertia forces of the Newton–Euler equations in the Lie-group form
//! (Brüls, Cardona & Arnold 2012, Eq. 36):
//!
//! ```text
//! f_inertia = [ m (u̇ − g) ;  J Ω̇ + Ω × J Ω ]
//! ```
//!
//! with `u̇` the centre of mass's acceleration in the inertial frame, `Ω` the body's angular
//! velocity in its own frame and `J` the inertia tensor about the centre of mass in that
//! frame; gravity `g` enters as the weight `m g`. The force does not depend on the
//! configuration, so a body adds no stiffness: only `β' M + γ' C_t`, with the gyroscopic
//! matrix `C_t = Ω̃ J − (J Ω)~`.

use nalgebra::{Matrix3, Matrix6, Vector3};

use crate::group::so3::hat;
use crate::group::{split, NV};

/// A rigid body in space.
#[derive(Debug, Clone, PartialEq)]
pub struct Body {
    /// Its name in the scene.
    pub name: String,
    /// The node at its centre of mass.
    pub node: usize,
    /// Mass (kg).
    pub mass: f64,
    /// Inertia tensor about the centre of mass in the body's frame (kg m²).
    pub inertia: Matrix3<f64>,
}

impl Body {
    /// The inertia forces `[m (u̇ − g); J Ω̇ + Ω × J Ω]` at velocity `v` and acceleration
    /// `vdot` (module docs).
    pub fn inertia_force(&self, v: &[f64; NV], vdot: &[f64; NV], g: &Vector3<f64>) -> [f64; NV] {
        let (_, omega) = split(v);
        let (udot, omegadot) = split(vdot);
        let f = (udot - g) * self.mass;
        let m = self.inertia * omegadot + omega.cross(&(self.inertia * omega));
        [f.x, f.y, f.z, m.x, m.y, m.z]
    }

    /// The mass matrix `diag(m I, J)`.
    pub fn mass_matrix(&self) -> Matrix6<f64> {
        let mut m = Matrix6::zeros();
        m.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&(Matrix3::identity() * self.mass));
        m.fixed_view_mut::<3, 3>(3, 3).copy_from(&self.inertia);
        m
    }

    /// `β' M + γ' C_t` at velocity `v`: the body's block of the iteration matrix.
    pub fn iteration_block(
        &self,
        v: &[f64; NV],
        beta_prime: f64,
        gamma_prime: f64,
    ) -> Matrix6<f64> {
        let (_, omega) = split(v);
        let gyroscopic = hat(&omega) * self.inertia - hat(&(self.inertia * omega));
        let mut block = self.mass_matrix() * beta_prime;
        let mut rot = block.fixed_view_mut::<3, 3>(3, 3);
        rot += gyroscopic * gamma_prime;
        block
    }

    /// Kinetic energy `½ m |u̇|² + ½ Ωᵀ J Ω` (J).
    pub fn kinetic_energy(&self, v: &[f64; NV]) -> f64 {
        let (u, omega) = split(v);
        0.5 * self.mass * u.norm_squared() + 0.5 * omega.dot(&(self.inertia * omega))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The gyroscopic matrix is the derivative of `Ω × JΩ`: central differences.
    #[test]
    fn iteration_block_is_the_derivative_of_the_inertia_force() {
        let body = Body {
            name: "b".into(),
            node: 0,
            mass: 2.0,
            inertia: Matrix3::new(3.0, 0.2, -0.1, 0.2, 2.0, 0.3, -0.1, 0.3, 1.5),
        };
        let g = Vector3::new(0.0, 0.0, -9.81);
        let v = [0.1, -0.2, 0.3, 4.0, -1.0, 2.5];
        let vdot = [1.0, 2.0, -1.0, 0.5, 0.2, -0.3];
        let (bp, gp) = (3.0, 0.7);
        // d/dε f(v + γ'εe, v̇ + β'εe) = (β' M + γ' C_t) e.
        let block = body.iteration_block(&v, bp, gp);
        let eps = 1e-6;
        for k in 0..NV {
            let moved = |e: f64| {
                let (mut vv, mut aa) = (v, vdot);
                vv[k] += gp * e;
                aa[k] += bp * e;
                body.inertia_force(&vv, &aa, &g)
            };
            let (p, m) = (moved(eps), moved(-eps));
            for i in 0..NV {
                let fd = (p[i] - m[i]) / (2.0 * eps);
                assert!(
                    (fd - block[(i, k)]).abs() < 1e-7,
                    "({i}, {k}): {fd} against {}",
                    block[(i, k)]
                );
            }
        }
    }
}
