//! Co-rotational two-node truss bar: pin-jointed, axial force only, geometrically exact.
//!
//! On the element DOFs `u = [u₁, v₁, φ₁, u₂, v₂, φ₂]` of [`super::Kernel`] (its rows and
//! columns on `φ₁, φ₂` are zero), with the chord of [`super::Chord`] — current length `l`,
//! stretch `e = l − L₀` computed without cancellation, `r = ∂l/∂u`, `t = l ∂α/∂u`:
//!
//! * axial force `N = (EA/L₀) e` (tension positive);
//! * internal force `f = N r`;
//! * tangent `K = (EA/L₀) r rᵀ + N t tᵀ/l` (material and geometric parts, exact);
//! * strain energy `U = ½ (EA/L₀) e²`, zero in any rigid motion to round-off;
//! * Kelvin–Voigt damping `f_d = β (EA/L₀) r rᵀ q̇`: rate `β (EA/L₀) r rᵀ`, symmetric part
//!   `w t tᵀ/l` with `w = β (EA/L₀) ṙ`, `ṙ = r·q̇`, and the rest `β (EA/L₀) r (t·q̇/l) tᵀ`;
//! * mass `ρA L₀/6 [[2, 1], [1, 2]]` per translation (linear interpolation; the bar's
//!   inertia about its own centre, `ρA L₀³/12`, is in it), or its lumped form; none on the
//!   rotations.
//!
//! A truss bar is one element: a chain of pin-jointed elements would be a mechanism, and
//! the axial behaviour of one is exact. Its own transverse vibrations are not modelled
//! (the truss idealization); its Euler buckling is a response ([`crate::response`]).

use nalgebra::{SMatrix, Vector2, Vector3};

use super::beam::two_node_mass;
use super::{Chord, Damping, Formulation, Kernel, Matrix6, Vector6};
use crate::mechanism::section::Section;
use crate::settings::MassKind;

/// A co-rotational truss bar between two nodes, at full density.
#[derive(Debug, Clone, PartialEq)]
pub struct Truss {
    /// Reference chord `d₀ = X₂ − X₁` (m).
    pub chord: Vector2<f64>,
    /// Reference length `L₀ = |d₀|` (m).
    pub length: f64,
    /// Section at full density (`EA`, `ρA`; `EI` for its Euler load).
    pub section: Section,
}

impl Truss {
    /// A truss bar with reference end positions `x1`, `x2`.
    pub fn new(x1: Vector2<f64>, x2: Vector2<f64>, section: Section) -> Self {
        let chord = x2 - x1;
        Self {
            chord,
            length: chord.norm(),
            section,
        }
    }

    /// Axial stiffness `EA/L₀` of a section (N/m).
    fn axial(&self, section: &Section) -> f64 {
        section.ea / self.length
    }

    fn chord(&self, u: &Vector6) -> Chord {
        Chord::of(&self.chord, self.length, u)
    }
}

impl Kernel for Truss {
    fn length(&self) -> f64 {
        self.length
    }

    fn section(&self) -> &Section {
        &self.section
    }

    fn turns_nodes(&self) -> bool {
        false
    }

    /// `f = N r`.
    fn internal_force(&self, u: &Vector6) -> Vector6 {
        let c = self.chord(u);
        c.r * (self.axial(&self.section) * c.stretch)
    }

    /// `K = (EA/L₀) r rᵀ + N t tᵀ/l`.
    fn internal_force_and_tangent(&self, u: &Vector6) -> (Vector6, Matrix6) {
        let c = self.chord(u);
        let k = self.axial(&self.section);
        let n = k * c.stretch;
        let tangent = c.r * c.r.transpose() * k + c.t * c.t.transpose() * (n / c.l);
        (c.r * n, tangent)
    }

    /// `U = ½ (EA/L₀) e²`.
    fn strain_energy(&self, u: &Vector6) -> f64 {
        let e = self.chord(u).stretch;
        0.5 * self.axial(&self.section) * e * e
    }

    /// `[N, 0, 0]`.
    fn section_forces(&self, u: &Vector6) -> Vector3<f64> {
        Vector3::new(self.axial(&self.section) * self.chord(u).stretch, 0.0, 0.0)
    }

    /// `[N, 0, 0]` and `∂N/∂u = (EA/L₀) rᵀ` in the first row.
    fn section_forces_and_jacobian(&self, u: &Vector6) -> (Vector3<f64>, SMatrix<f64, 3, 6>) {
        let c = self.chord(u);
        let k = self.axial(&self.section);
        let mut jacobian = SMatrix::<f64, 3, 6>::zeros();
        jacobian.set_row(0, &(c.r * k).transpose());
        (Vector3::new(k * c.stretch, 0.0, 0.0), jacobian)
    }

    /// `[N, 0, 0]` and `[(EA'/L₀) e, 0, 0]`.
    fn section_forces_and_rate(&self, u: &Vector6, rate: &Section) -> (Vector3<f64>, Vector3<f64>) {
        let e = self.chord(u).stretch;
        (
            Vector3::new(self.axial(&self.section) * e, 0.0, 0.0),
            Vector3::new(self.axial(rate) * e, 0.0, 0.0),
        )
    }

    /// `(EA'/L₀) e r`.
    fn internal_force_rate(&self, u: &Vector6, rate: &Section) -> Vector6 {
        let c = self.chord(u);
        c.r * (self.axial(rate) * c.stretch)
    }

    /// `½ (EA'/L₀) e²`.
    fn strain_energy_rate(&self, u: &Vector6, rate: &Section) -> f64 {
        let e = self.chord(u).stretch;
        0.5 * self.axial(rate) * e * e
    }

    fn mass_matrix(&self, kind: MassKind) -> Matrix6 {
        let m = self.section.rho_a * self.length;
        two_node_mass(kind, [m, m, 0.0])
    }

    fn with_section(&self, section: Section) -> Formulation {
        Formulation::Truss(Self {
            section,
            ..self.clone()
        })
    }

    /// See the module documentation.
    fn damping(&self, u: &Vector6, v: &Vector6) -> Damping {
        let c = self.chord(u);
        let k = self.section.beta * self.axial(&self.section);
        let (rd, td) = (c.r.dot(v), c.t.dot(v));
        let rate = c.r * c.r.transpose() * k;
        Damping {
            force: c.r * (k * rd),
            rate,
            symmetric: c.t * c.t.transpose() * (k * rd / c.l),
            skew: c.r * c.t.transpose() * (k * td / c.l),
        }
    }

    /// `(β' EA/L₀ + β EA'/L₀) r rᵀ q̇`.
    fn damping_force_rate(
        &self,
        u: &Vector6,
        v: &Vector6,
        beta_rate: f64,
        rate: &Section,
    ) -> Vector6 {
        let c = self.chord(u);
        let k = beta_rate * self.axial(&self.section) + self.section.beta * self.axial(rate);
        c.r * (k * c.r.dot(v))
    }

    /// The chord's midpoint; no rotation (a truss bar turns no node).
    fn middle(&self, u: &Vector6) -> [f64; 3] {
        [0.5 * (u[0] + u[3]), 0.5 * (u[1] + u[4]), 0.0]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn truss() -> Truss {
        let (a, i, kappa) = Section::solid_circle(0.02, 0.32);
        let section = Section::new(70e9, 70e9 / 2.64, a, i, kappa, 2700.0).with_rayleigh(0.0, 3e-4);
        Truss::new(Vector2::new(0.1, -0.2), Vector2::new(0.4, 0.2), section)
    }

    /// A rigid motion: translation and rotation by `angle` about node 1 (the nodes'
    /// rotations, which a truss bar does not read, set to nonsense).
    fn rigid(b: &Truss, angle: f64) -> Vector6 {
        let (c, s) = (angle.cos(), angle.sin());
        let d = b.chord;
        let rotated = Vector2::new(c * d.x - s * d.y, s * d.x + c * d.y);
        Vector6::from([
            0.3,
            -0.7,
            5.0,
            0.3 + rotated.x - d.x,
            -0.7 + rotated.y - d.y,
            -2.0,
        ])
    }

    /// Central difference of `f` at `u0` along DOF `j`.
    fn central<T>(f: impl Fn(&Vector6) -> T, u0: &Vector6, j: usize) -> T
    where
        T: std::ops::Sub<Output = T> + std::ops::Div<f64, Output = T>,
    {
        let h = 1e-7;
        (f(&(u0 + Vector6::ith(j, h))) - f(&(u0 - Vector6::ith(j, h)))) / (2.0 * h)
    }

    /// Any rigid rotation, up to a full turn and beyond, leaves the force at round-off of
    /// a unit-strain force `EA` and the energy at zero.
    #[test]
    fn rigid_rotations_are_force_free() {
        let b = truss();
        for k in 0..=64 {
            let angle = -7.0 + 14.0 * f64::from(k) / 64.0;
            let u = rigid(&b, angle);
            assert!(
                b.internal_force(&u).amax() <= 1e-13 * b.section.ea,
                "angle {angle}"
            );
            assert!(b.strain_energy(&u) <= 1e-26 * b.section.ea * b.length);
        }
    }

    /// The tangent against differences of the force, the force against differences of the
    /// energy, the section force's Jacobian against its differences, on a stretched and
    /// turned bar; no entry on the rotations.
    #[test]
    fn derivatives_equal_central_differences() {
        let b = truss();
        let u0 = rigid(&b, 1.1) + Vector6::from([1e-3, -2e-3, 0.0, 3e-3, 1e-3, 0.0]);
        let (f, k) = b.internal_force_and_tangent(&u0);
        let (_, jac) = b.section_forces_and_jacobian(&u0);
        for j in 0..6 {
            let fd = central(|u| b.internal_force(u), &u0, j);
            assert!((k.column(j) - fd).amax() <= 1e-6 * k.amax(), "K column {j}");
            let energy = central(|u| b.strain_energy(u), &u0, j);
            assert!((energy - f[j]).abs() <= 1e-6 * f.amax(), "f[{j}]");
            let n = central(|u| b.section_forces(u), &u0, j);
            assert!(
                (jac.column(j) - n).amax() <= 1e-6 * jac.amax(),
                "N column {j}"
            );
        }
        assert!((k - k.transpose()).amax() <= 1e-9 * k.amax());
        for i in [2, 5] {
            assert_eq!(k.row(i).amax() + k.column(i).amax() + f[i].abs(), 0.0);
        }
    }

    /// The damping's derivatives against differences of its force; a rigid motion's
    /// velocity is not damped.
    #[test]
    fn damping_derivatives_equal_central_differences() {
        let b = truss();
        let u = rigid(&b, 0.7) + Vector6::from([1e-3, -2e-3, 0.0, 3e-3, 1e-3, 0.0]);
        let v = Vector6::from([0.4, -0.3, 2.0, -0.2, 0.5, -1.5]);
        let d = b.damping(&u, &v);
        let total = d.symmetric + d.skew;
        for j in 0..6 {
            let fq = central(|w| b.damping(w, &v).force, &u, j);
            assert!(
                (total.column(j) - fq).norm() <= 1e-6 * total.norm(),
                "column {j}"
            );
            let fv = central(|w| b.damping(&u, w).force, &v, j);
            assert!((d.rate.column(j) - fv).norm() <= 1e-7 * d.rate.norm());
        }
        let turning = Vector6::from([0.0, 0.0, 0.0, -b.chord.y, b.chord.x, 0.0]);
        assert!(b.damping(&Vector6::zeros(), &turning).force.norm() <= 1e-12 * d.force.norm());
    }

    /// Small stretch: `N = EA e/L₀` along the chord, the linear truss stiffness
    /// `EA/L₀ n nᵀ` at the reference, and the mass of a rod: total `ρA L₀` in a translation,
    /// `ρA L₀³/12` about its centre in a rotation.
    #[test]
    fn linear_limit_and_mass_are_those_of_a_rod() {
        let b = truss();
        let n = b.chord / b.length;
        let k = b.internal_force_and_tangent(&Vector6::zeros()).1;
        let ka = b.section.ea / b.length;
        let nn = Vector6::from([-n.x, -n.y, 0.0, n.x, n.y, 0.0]);
        assert!((k - nn * nn.transpose() * ka).amax() <= 1e-12 * ka);
        let m = b.mass_matrix(MassKind::Consistent);
        let total = b.section.rho_a * b.length;
        let ux = Vector6::from([1.0, 0.0, 0.0, 1.0, 0.0, 0.0]);
        assert!((ux.dot(&(m * ux)) - total).abs() <= 1e-12 * total);
        let spin = Vector6::from([
            b.chord.y / 2.0,
            -b.chord.x / 2.0,
            1.0,
            -b.chord.y / 2.0,
            b.chord.x / 2.0,
            1.0,
        ]);
        let inertia = total * b.length.powi(2) / 12.0;
        assert!((spin.dot(&(m * spin)) - inertia).abs() <= 1e-12 * inertia);
    }
}
