//! Co-rotational planar beam with the exact Timoshenko local stiffness.
//!
//! Each element carries a local frame that follows its chord (Crisfield, *Non-linear
//! finite element analysis of solids and structures*, vol. 1, §7.4). Large rigid motions
//! are handled exactly by the frame; the deformation measured in it — the stretch of the
//! chord and the two end rotations relative to the chord — is small and resisted by the
//! **exact** stiffness of a linear Timoshenko beam. That stiffness solves the beam
//! equations for end loads exactly, so a bar loaded at its ends (every bar of a ground
//! structure) is exact in the linear range with one element, shear included; a linear
//! two-node Simo–Reissner element with one-point integration is about ten times too stiff
//! in double curvature. Splitting a bar into `m` elements refines the nonlinear and
//! inertial behaviour.
//!
//! Element DOFs `u = [u₁, v₁, φ₁, u₂, v₂, φ₂]` are nodal displacements and rotations from
//! the reference configuration, in the global frame. With chord `d = d₀ + (u₂ − u₁, v₂ − v₁)`,
//! `l = |d|`, chord rotation `α = ∠(d₀, d)`:
//!
//! * stretch `e = l − L₀`, local end rotations `θᵢ = φᵢ − α` (wrapped to `(−π, π]`);
//! * local forces `N = (EA/L₀) e`, `[M₁, M₂] = k_b [θ₁, θ₂]` with
//!   `k_b = EI/(L₀(1+Φ)) [[4+Φ, 2−Φ], [2−Φ, 4+Φ]]`, `Φ = 12 EI/(κGA L₀²)`;
//! * internal force `f = Bᵀ [N, M₁, M₂]` with `B = ∂(e, θ₁, θ₂)/∂u`;
//! * tangent `K = Bᵀ D B + N t tᵀ/l + (M₁ + M₂)(r tᵀ + t rᵀ)/l²`, where
//!   `r = ∂l/∂u = [−c, −s, 0, c, s, 0]`, `t = l ∂α/∂u = [s, −c, 0, −s, c, 0]`;
//! * strain energy `U = ½ (EA/L₀) e² + ½ θᵀ k_b θ`.
//!
//! Rayleigh damping `C = αM + βK` of the section: the mass part `α M q̇` (constant `M`),
//! and the stiffness part as a Kelvin–Voigt material in the co-rotated frame,
//! `f_d = β Bᵀ D ė` with `ė = B q̇` the rate of the local deformation — rigid motions are
//! not damped. Its derivatives: `∂f_d/∂q̇ = β BᵀDB`, and `∂f_d/∂q = Σᵢ wᵢ Hᵢ + β Bᵀ D G`
//! with `w = β D ė`, `Hᵢ = ∂²eᵢ/∂u²` (`t tᵀ/l` for the stretch, `(r tᵀ + t rᵀ)/l²` for
//! both end rotations) and `G = ∂(B q̇)/∂q`, rows `(Hᵢ q̇)ᵀ`: a symmetric part and one
//! that is not ([`Damping`]).
//!
//! Inertia uses linear interpolation of the absolute displacement and rotation fields,
//! which gives a constant mass matrix in these coordinates (no gyroscopic term in 2D):
//! `ρA L₀/6 [[2, 1], [1, 2]]` per translation, `ρI L₀/6 [[2, 1], [1, 2]]` for rotation;
//! or its row-sum lumped form.

use nalgebra::{Matrix3, SMatrix, SVector, Vector2, Vector3};

use super::{Chord, Formulation, Kernel};
use crate::mechanism::section::Section;
use crate::settings::MassKind;

/// Six element DOFs.
pub type Vector6 = SVector<f64, 6>;
/// A 6×6 element matrix.
pub type Matrix6 = SMatrix<f64, 6, 6>;

/// A co-rotational Timoshenko beam between two nodes, at full density.
#[derive(Debug, Clone, PartialEq)]
pub struct Beam {
    /// Reference chord `d₀ = X₂ − X₁` (m).
    pub chord: Vector2<f64>,
    /// Reference length `L₀ = |d₀|` (m).
    pub length: f64,
    /// Section at full density.
    pub section: Section,
}

/// A damping force at a state with its derivatives: an element's stiffness-proportional
/// damping (at full density), or a damper's on a distance ([`crate::mechanism::spring::Spring::damper`]).
/// On `N` DOFs: six for a beam or a damper, eight for a continuum cell.
#[derive(Debug, Clone, Copy)]
pub struct Damping<const N: usize = 6> {
    /// `f_d = β Bᵀ D B q̇`.
    pub force: SVector<f64, N>,
    /// `∂f_d/∂q̇ = β BᵀDB`.
    pub rate: SMatrix<f64, N, N>,
    /// The symmetric part of `∂f_d/∂q`, `Σᵢ wᵢ Hᵢ`.
    pub symmetric: SMatrix<f64, N, N>,
    /// The rest of `∂f_d/∂q`, `β Bᵀ D G`, not symmetric.
    pub skew: SMatrix<f64, N, N>,
}

impl<const N: usize> Damping<N> {
    /// The force and its derivatives times `s` (a design's stiffness scaling).
    pub fn scaled(self, s: f64) -> Self {
        Self {
            force: self.force * s,
            rate: self.rate * s,
            symmetric: self.symmetric * s,
            skew: self.skew * s,
        }
    }
}

/// Chord geometry and local deformation of a deformed beam.
#[derive(Debug, Clone, Copy)]
struct Deformation {
    /// The chord ([`Chord`]: `l`, `r = ∂l/∂u`, `t = l ∂α/∂u`).
    chord: Chord,
    /// Local deformation `[e, θ₁, θ₂]`.
    local: Vector3<f64>,
}

impl Beam {
    /// A beam with reference end positions `x1`, `x2`.
    pub fn new(x1: Vector2<f64>, x2: Vector2<f64>, section: Section) -> Self {
        let chord = x2 - x1;
        Self {
            chord,
            length: chord.norm(),
            section,
        }
    }

    /// Local stiffness `D = diag(EA/L₀, k_b)` of the exact Timoshenko beam.
    pub fn local_stiffness(&self) -> Matrix3<f64> {
        let (l0, s) = (self.length, &self.section);
        let phi = 12.0 * s.ei / (s.gak * l0 * l0);
        let k = s.ei / (l0 * (1.0 + phi));
        let (a, b) = (k * (4.0 + phi), k * (2.0 - phi));
        Matrix3::new(s.ea / l0, 0.0, 0.0, 0.0, a, b, 0.0, b, a)
    }

    /// `∂D/∂p` for a section whose `EA`, `κGA`, `EI` change at the rates `rate.ea`,
    /// `rate.gak`, `rate.ei`: with `Φ' = Φ (EI'/EI − κGA'/κGA)` and
    /// `k' = k (EI'/EI − Φ'/(1 + Φ))`, `a' = k'(4 + Φ) + kΦ'`, `b' = k'(2 − Φ) − kΦ'`.
    pub fn local_stiffness_rate(&self, rate: &Section) -> Matrix3<f64> {
        let (l0, s) = (self.length, &self.section);
        let phi = 12.0 * s.ei / (s.gak * l0 * l0);
        let k = s.ei / (l0 * (1.0 + phi));
        let d_phi = phi * (rate.ei / s.ei - rate.gak / s.gak);
        let d_k = k * (rate.ei / s.ei - d_phi / (1.0 + phi));
        let (a, b) = (d_k * (4.0 + phi) + k * d_phi, d_k * (2.0 - phi) - k * d_phi);
        Matrix3::new(rate.ea / l0, 0.0, 0.0, 0.0, a, b, 0.0, b, a)
    }

    fn deformation(&self, u: &Vector6) -> Deformation {
        let chord = Chord::of(&self.chord, self.length, u);
        let d = chord.d;
        let alpha = (self.chord.x * d.y - self.chord.y * d.x).atan2(self.chord.dot(&d));
        let local = Vector3::new(
            chord.stretch,
            wrap_angle(u[2] - alpha),
            wrap_angle(u[5] - alpha),
        );
        Deformation { chord, local }
    }

    /// `B = ∂(e, θ₁, θ₂)/∂u`, one row per local deformation.
    fn strain_matrix(g: &Deformation) -> SMatrix<f64, 3, 6> {
        let mut b = SMatrix::<f64, 3, 6>::zeros();
        b.set_row(0, &g.chord.r.transpose());
        let dalpha = g.chord.t / g.chord.l;
        b.set_row(1, &(-dalpha).transpose());
        b.set_row(2, &(-dalpha).transpose());
        b[(1, 2)] += 1.0;
        b[(2, 5)] += 1.0;
        b
    }
}

impl Kernel for Beam {
    fn length(&self) -> f64 {
        self.length
    }

    fn section(&self) -> &Section {
        &self.section
    }

    fn turns_nodes(&self) -> bool {
        true
    }

    /// `f = Bᵀ D [e, θ₁, θ₂]`.
    fn internal_force(&self, u: &Vector6) -> Vector6 {
        let g = self.deformation(u);
        Self::strain_matrix(&g).transpose() * (self.local_stiffness() * g.local)
    }

    /// `K = Bᵀ D B + N t tᵀ/l + (M₁ + M₂)(r tᵀ + t rᵀ)/l²`.
    fn internal_force_and_tangent(&self, u: &Vector6) -> (Vector6, Matrix6) {
        let g = self.deformation(u);
        let b = Self::strain_matrix(&g);
        let d = self.local_stiffness();
        let s = d * g.local;
        let (n, m_sum) = (s[0], s[1] + s[2]);
        let (l, r, t) = (g.chord.l, g.chord.r, g.chord.t);
        let k = b.transpose() * d * b
            + t * t.transpose() * (n / l)
            + (r * t.transpose() + t * r.transpose()) * (m_sum / (l * l));
        (b.transpose() * s, k)
    }

    /// `U = ½ [e, θ₁, θ₂] D [e, θ₁, θ₂]ᵀ`.
    fn strain_energy(&self, u: &Vector6) -> f64 {
        let g = self.deformation(u);
        0.5 * g.local.dot(&(self.local_stiffness() * g.local))
    }

    /// `D [e, θ₁, θ₂]`.
    fn section_forces(&self, u: &Vector6) -> Vector3<f64> {
        self.local_stiffness() * self.deformation(u).local
    }

    /// `D [e, θ₁, θ₂]` and `D B`.
    fn section_forces_and_jacobian(&self, u: &Vector6) -> (Vector3<f64>, SMatrix<f64, 3, 6>) {
        let g = self.deformation(u);
        let d = self.local_stiffness();
        (d * g.local, d * Self::strain_matrix(&g))
    }

    /// `D [e, θ₁, θ₂]` and `(∂D/∂p) [e, θ₁, θ₂]` ([`Beam::local_stiffness_rate`]).
    fn section_forces_and_rate(&self, u: &Vector6, rate: &Section) -> (Vector3<f64>, Vector3<f64>) {
        let local = self.deformation(u).local;
        (
            self.local_stiffness() * local,
            self.local_stiffness_rate(rate) * local,
        )
    }

    /// `Bᵀ (∂D/∂p) [e, θ₁, θ₂]`; `B` does not depend on the section.
    fn internal_force_rate(&self, u: &Vector6, rate: &Section) -> Vector6 {
        let g = self.deformation(u);
        Self::strain_matrix(&g).transpose() * (self.local_stiffness_rate(rate) * g.local)
    }

    /// `½ [e, θ₁, θ₂] (∂D/∂p) [e, θ₁, θ₂]ᵀ`.
    fn strain_energy_rate(&self, u: &Vector6, rate: &Section) -> f64 {
        let g = self.deformation(u);
        0.5 * g.local.dot(&(self.local_stiffness_rate(rate) * g.local))
    }

    /// `ρA L₀/6 [[2, 1], [1, 2]]` per translation, `ρI L₀/6 [[2, 1], [1, 2]]` for rotation
    /// (consistent), or their row sums on the diagonal (lumped).
    fn mass_matrix(&self, kind: MassKind) -> Matrix6 {
        let (ma, mi) = (
            self.section.rho_a * self.length,
            self.section.rho_i * self.length,
        );
        two_node_mass(kind, [ma, ma, mi])
    }

    fn with_section(&self, section: Section) -> Formulation {
        Formulation::Beam(Self {
            section,
            ..self.clone()
        })
    }

    /// See the module documentation.
    fn damping(&self, u: &Vector6, v: &Vector6) -> Damping {
        let g = self.deformation(u);
        let b = Self::strain_matrix(&g);
        let d = self.local_stiffness() * self.section.beta;
        let w = d * (b * v);
        let (l, r, t) = (g.chord.l, g.chord.r, g.chord.t);
        let (td, rd) = (t.dot(v), r.dot(v));
        let he = t * t.transpose() / l;
        let ht = (r * t.transpose() + t * r.transpose()) / (l * l);
        let mut grad = SMatrix::<f64, 3, 6>::zeros();
        grad.set_row(0, &(t * (td / l)).transpose());
        let turning = (r * td + t * rd) / (l * l);
        grad.set_row(1, &turning.transpose());
        grad.set_row(2, &turning.transpose());
        Damping {
            force: b.transpose() * w,
            rate: b.transpose() * d * b,
            symmetric: he * w[0] + ht * (w[1] + w[2]),
            skew: b.transpose() * d * grad,
        }
    }

    /// `β' Bᵀ D B q̇ + β Bᵀ D' B q̇`.
    fn damping_force_rate(
        &self,
        u: &Vector6,
        v: &Vector6,
        beta_rate: f64,
        rate: &Section,
    ) -> Vector6 {
        let g = self.deformation(u);
        let b = Self::strain_matrix(&g);
        let d = self.local_stiffness() * beta_rate
            + self.local_stiffness_rate(rate) * self.section.beta;
        b.transpose() * (d * (b * v))
    }

    /// The middle on the element's co-rotated cubic: the chord's midpoint moved by the
    /// deflection `l(θ₁ − θ₂)/8` along the chord's normal, turned by the chord's rotation
    /// plus the cubic's slope `−(θ₁ + θ₂)/4` there (`θ₁, θ₂` the end rotations relative to
    /// the chord).
    fn middle(&self, u: &Vector6) -> [f64; 3] {
        let g = self.deformation(u);
        let (theta_a, theta_b) = (g.local[1], g.local[2]);
        let d = g.chord.d;
        let normal = Vector2::new(-d.y, d.x) / g.chord.l;
        let mid = Vector2::new(u[0], u[1])
            + 0.5 * (d - self.chord)
            + g.chord.l * (theta_a - theta_b) / 8.0 * normal;
        [mid.x, mid.y, u[2] - theta_a - 0.25 * (theta_a + theta_b)]
    }
}

/// The constant mass matrix of linear interpolation between two nodes, with `totals` the
/// element's mass in x, in y (kg) and its rotary inertia (kg m²): `total/6 [[2, 1], [1, 2]]`
/// per coordinate (consistent), or `total/2` on the diagonal (lumped).
pub(super) fn two_node_mass(kind: MassKind, totals: [f64; 3]) -> Matrix6 {
    let mut m = Matrix6::zeros();
    for (k, total) in totals.into_iter().enumerate() {
        let (diag, off) = match kind {
            MassKind::Consistent => (total / 3.0, total / 6.0),
            // A bar's end nodes are coupled outside (`crate::mechanism::bar_mass`).
            MassKind::Lumped | MassKind::BarLumped => (total / 2.0, 0.0),
        };
        m[(k, k)] = diag;
        m[(k + 3, k + 3)] = diag;
        m[(k, k + 3)] = off;
        m[(k + 3, k)] = off;
    }
    m
}

/// `a` wrapped to `(−π, π]`.
fn wrap_angle(a: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    a - TAU * ((a + PI) / TAU).ceil() + TAU
}

#[cfg(test)]
mod tests {
    use super::*;

    fn section() -> Section {
        let (a, i, kappa) = Section::solid_circle(0.02, 0.32);
        Section::new(70e9, 70e9 / 2.64, a, i, kappa, 2700.0)
    }

    fn beam() -> Beam {
        Beam::new(Vector2::new(0.1, -0.2), Vector2::new(0.4, 0.2), section())
    }

    /// A rigid motion (translation + rotation about node 1) of amplitude `angle`.
    fn rigid(b: &Beam, angle: f64) -> Vector6 {
        let (c, s) = (angle.cos(), angle.sin());
        let d = b.chord;
        let rotated = Vector2::new(c * d.x - s * d.y, s * d.x + c * d.y);
        let (t1, t2) = (0.3, -0.7);
        Vector6::from([
            t1,
            t2,
            angle,
            t1 + rotated.x - d.x,
            t2 + rotated.y - d.y,
            angle,
        ])
    }

    /// The damping's `∂f_d/∂u` (symmetric part plus the rest) against central
    /// differences of its force, on a deformed beam in rigid rotation, and the rate part
    /// `∂f_d/∂v`; a rigid motion's velocity is not damped.
    #[test]
    fn damping_derivatives_equal_central_differences() {
        let mut b = beam();
        b.section = b.section.with_rayleigh(0.0, 2e-4);
        let u = rigid(&b, 0.7) + Vector6::from([1e-3, -2e-3, 0.02, 3e-3, 1e-3, -0.03]);
        let v = Vector6::from([0.4, -0.3, 2.0, -0.2, 0.5, -1.5]);
        let d = b.damping(&u, &v);
        let h = 1e-7;
        for j in 0..6 {
            let e = Vector6::ith(j, h);
            let fd = (b.damping(&(u + e), &v).force - b.damping(&(u - e), &v).force) / (2.0 * h);
            let exact = (d.symmetric + d.skew).column(j).into_owned();
            assert!(
                (exact - fd).norm() <= 1e-6 * (d.symmetric + d.skew).norm(),
                "column {j}"
            );
            let fv = (b.damping(&u, &(v + e)).force - b.damping(&u, &(v - e)).force) / (2.0 * h);
            assert!((d.rate.column(j) - fv).norm() <= 1e-7 * d.rate.norm());
        }
        assert!((d.symmetric - d.symmetric.transpose()).norm() <= 1e-12 * d.symmetric.norm());
        let turning = Vector6::from([0.0, 0.0, 1.0, -b.chord.y, b.chord.x, 1.0]);
        assert!(b.damping(&Vector6::zeros(), &turning).force.norm() <= 1e-12 * d.force.norm());
    }

    /// `∂D/∂p` against central differences of `D` for a section moved along `rate`.
    #[test]
    fn stiffness_rate_equals_central_differences() {
        let b = beam();
        let rate = Section {
            ea: 0.3 * b.section.ea,
            gak: -0.7 * b.section.gak,
            ei: 1.9 * b.section.ei,
            ..Section::new(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        };
        let moved = |t: f64| {
            let s = &b.section;
            let section = Section {
                ea: s.ea + t * rate.ea,
                gak: s.gak + t * rate.gak,
                ei: s.ei + t * rate.ei,
                ..*s
            };
            Beam {
                section,
                ..b.clone()
            }
            .local_stiffness()
        };
        let h = 1e-6;
        let fd = (moved(h) - moved(-h)) / (2.0 * h);
        let exact = b.local_stiffness_rate(&rate);
        assert!((exact - fd).norm() <= 1e-8 * b.local_stiffness().norm());
    }

    #[test]
    fn rigid_motions_are_stress_free() {
        let b = beam();
        for angle in [0.3, 2.5, -3.0, 7.0] {
            let u = rigid(&b, angle);
            let f = b.internal_force(&u);
            assert!(f.amax() < 1e-6 * b.section.ea, "f = {f}");
            assert!(b.strain_energy(&u).abs() < 1e-12);
        }
    }

    /// Central difference of `f` at `u0` along DOF `j`.
    fn central<T: std::ops::Sub<Output = T> + std::ops::Div<f64, Output = T>>(
        f: impl Fn(&Vector6) -> T,
        u0: &Vector6,
        j: usize,
    ) -> T {
        let eps = 1e-7;
        let (mut up, mut um) = (*u0, *u0);
        up[j] += eps;
        um[j] -= eps;
        (f(&up) - f(&um)) / (2.0 * eps)
    }

    #[test]
    fn tangent_matches_central_differences_of_the_force() {
        let b = beam();
        let u0 = rigid(&b, 1.2) + Vector6::from([1e-3, -2e-3, 0.05, 3e-3, 1e-3, -0.08]);
        let (_, k) = b.internal_force_and_tangent(&u0);
        for j in 0..6 {
            let fd = central(|u| b.internal_force(u), &u0, j);
            for i in 0..6 {
                let err = (fd[i] - k[(i, j)]).abs();
                assert!(
                    err < 1e-6 * k.amax(),
                    "K[{i},{j}] = {} vs {}",
                    k[(i, j)],
                    fd[i]
                );
            }
        }
        assert!(
            (k - k.transpose()).amax() < 1e-9 * k.amax(),
            "tangent of a conservative force is symmetric"
        );
    }

    #[test]
    fn section_force_jacobian_matches_central_differences() {
        let b = beam();
        let u0 = rigid(&b, 0.7) + Vector6::from([1e-3, -2e-3, 0.05, 3e-3, 1e-3, -0.08]);
        let (_, jac) = b.section_forces_and_jacobian(&u0);
        for j in 0..6 {
            let fd = central(|u| b.section_forces(u), &u0, j);
            assert!(
                (jac.column(j) - fd).amax() <= 1e-6 * jac.amax(),
                "column {j}"
            );
        }
    }

    #[test]
    fn force_is_the_gradient_of_the_strain_energy() {
        let b = beam();
        let u0 = rigid(&b, -0.4) + Vector6::from([2e-3, 1e-3, -0.03, -1e-3, 2e-3, 0.06]);
        let f = b.internal_force(&u0);
        for j in 0..6 {
            let fd = central(|u| b.strain_energy(u), &u0, j);
            assert!(
                (fd - f[j]).abs() < 1e-6 * f.amax(),
                "f[{j}] = {} vs {fd}",
                f[j]
            );
        }
    }

    #[test]
    fn cantilever_tip_load_is_exact_timoshenko() {
        // Horizontal beam, node 1 clamped, tip load P: v = PL³/(3EI) + PL/(κGA), φ = PL²/(2EI).
        let b = Beam::new(Vector2::zeros(), Vector2::new(0.7, 0.0), section());
        let k = b.internal_force_and_tangent(&Vector6::zeros()).1;
        let kff = k.fixed_view::<3, 3>(3, 3).into_owned();
        let p = 1.0;
        let u = kff.lu().solve(&Vector3::new(0.0, p, 0.0)).unwrap();
        let (l, s) = (b.length, b.section);
        let v = p * l.powi(3) / (3.0 * s.ei) + p * l / s.gak;
        let phi = p * l * l / (2.0 * s.ei);
        assert!((u[1] / v - 1.0).abs() < 1e-12, "{} vs {v}", u[1]);
        assert!((u[2] / phi - 1.0).abs() < 1e-12);
    }

    #[test]
    fn mass_matrices_carry_the_element_mass() {
        let b = beam();
        let total = b.section.rho_a * b.length;
        for kind in [MassKind::Consistent, MassKind::Lumped] {
            let m = b.mass_matrix(kind);
            // A unit translation in x has kinetic energy ½ m_total.
            let ux = Vector6::from([1.0, 0.0, 0.0, 1.0, 0.0, 0.0]);
            assert!((ux.dot(&(m * ux)) - total).abs() < 1e-12 * total);
        }
    }

    #[test]
    fn wrap_angle_maps_to_half_open_interval() {
        use std::f64::consts::PI;
        assert!((wrap_angle(2.0 * PI + 0.1) - 0.1).abs() < 1e-12);
        assert!((wrap_angle(-0.1) + 0.1).abs() < 1e-15);
        assert!((wrap_angle(PI) - PI).abs() < 1e-15);
        assert!((wrap_angle(-PI) - PI).abs() < 1e-15);
    }
}
