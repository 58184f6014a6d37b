//! Four-node plane-stress quadrilateral of a continuum member: total Lagrangian, a
//! St. Venant–Kirchhoff law, 2 × 2 Gauss points; plain (compatible strain, [`CellKind::Plain`])
//! or enhanced by four condensed incompatible modes ([`CellKind::Enhanced`], the members'
//! default: [`super::enhanced`], where `E` below is `E_c + Γ α(u)` and `B` in the tangent
//! and the damping is `B̄ = B + Γ ∂α/∂u`).
//!
//! Its unknowns are the translations of its four nodes, `u = [u₁, v₁, …, u₄, v₄]`, counted
//! anticlockwise; it has no rotations (its nodes' rotations are no unknowns unless something
//! else turns them: [`crate::mechanism::model::Model::absent_rotations`]). With the bilinear
//! shape functions `N_a(ξ, η)` and their gradients `g_a = ∂N_a/∂X` in the reference
//! configuration:
//!
//! * deformation gradient `F = I + Σ_a u_a g_aᵀ`, Green–Lagrange strain `E = ½ (FᵀF − I)`,
//!   in Voigt form `ε = [E₁₁, E₂₂, 2E₁₂]`;
//! * second Piola–Kirchhoff stress `S = C ε`, `C = E/(1 − ν²) [[1, ν, 0], [ν, 1, 0],
//!   [0, 0, (1 − ν)/2]]` (plane stress);
//! * strain energy `U = Σ_gp t det J ½ εᵀ C ε`, internal force `f = ∂U/∂u = Σ_gp t det J Bᵀ S`
//!   with `B = ∂ε/∂u`, and its exact tangent `K = Σ_gp t det J (Bᵀ C B + (g_aᵀ S g_b) I₂)`;
//! * mass `M_ab = ρ t ∫ N_a N_b dA I₂`, constant (2 × 2 Gauss integrates it exactly on any
//!   quadrilateral);
//! * Rayleigh damping `C = αM + βK`: `αM` constant, and `βK` as Kelvin–Voigt on the strain
//!   rate, `S_d = β C Ė` with `Ė = sym(FᵀḞ) = B q̇`, which vanishes in any rigid motion:
//!   `f_d = Σ_gp t det J Bᵀ S_d`, `∂f_d/∂q̇ = β Σ t det J BᵀCB`, and `∂f_d/∂q` the symmetric
//!   `(g_aᵀ S_d g_b) I₂` plus `β Σ t det J Bᵀ C B(Ḟ)` (`B` built on `Ḟ` instead of `F`:
//!   `δĖ = sym(Ḟᵀ δF)`), not symmetric.
//!
//! A rigid motion has `FᵀF = I`, so strain, stress and internal force vanish to round-off at
//! any rotation: the mass matrix being constant, the index-3 generalized-α integrator and
//! the sensitivities carry over with these element terms only. Everything is at full
//! density; a design scales stiffness by `s(x)` and mass by `m(x)` outside, as for the
//! bars (paper Eq. 33–34).

use nalgebra::{Matrix2, SMatrix, SVector, Vector2, Vector3};

use super::enhanced::{enhanced_operator, Condensed, Enhancement};
use crate::mechanism::element::beam::Damping;
use crate::settings::MassKind;

/// A vector on a quadrilateral's eight DOFs.
pub type Vector8 = SVector<f64, 8>;
/// A matrix on a quadrilateral's eight DOFs.
pub type Matrix8 = SMatrix<f64, 8, 8>;

/// Natural coordinates `(ξ_a, η_a)` of the four corners, anticlockwise.
const CORNERS: [(f64, f64); 4] = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];

/// An isotropic linear elastic material in plane stress, at full density.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlaneMaterial {
    /// Young's modulus `E` (Pa).
    pub young: f64,
    /// Poisson's ratio `ν`.
    pub poisson: f64,
    /// Density `ρ` (kg/m³).
    pub density: f64,
    /// Thickness `t` (m).
    pub thickness: f64,
    /// Rayleigh's mass-proportional damping `α` (1/s).
    pub alpha: f64,
    /// Rayleigh's stiffness-proportional damping `β` (s).
    pub beta: f64,
}

impl PlaneMaterial {
    /// The plane-stress elasticity matrix `C` on `[E₁₁, E₂₂, 2E₁₂]` (Pa).
    pub fn elasticity(&self) -> SMatrix<f64, 3, 3> {
        let (e, nu) = (self.young, self.poisson);
        let c = e / (1.0 - nu * nu);
        SMatrix::<f64, 3, 3>::new(
            c,
            c * nu,
            0.0,
            c * nu,
            c,
            0.0,
            0.0,
            0.0,
            c * (1.0 - nu) / 2.0,
        )
    }
}

/// What the reference configuration fixes at one Gauss point.
#[derive(Debug, Clone, Copy, PartialEq)]
struct GaussPoint {
    /// Shape functions `N_a`.
    shape: [f64; 4],
    /// Their reference gradients `g_a = ∂N_a/∂X` (1/m).
    gradient: [Vector2<f64>; 4],
    /// Weight times `det J` times the thickness (m³).
    volume: f64,
}

/// Which strain a cell interpolates.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum CellKind {
    /// The compatible bilinear strain alone: the 88-line code's element at small strain,
    /// locking in bending.
    Plain,
    /// Enhanced by four condensed incompatible modes ([`super::enhanced`]): exact in pure
    /// bending on rectangles, the members' default.
    #[default]
    Enhanced,
}

impl CellKind {
    /// The kind's name in a scene.
    pub fn name(self) -> &'static str {
        match self {
            CellKind::Plain => "plain",
            CellKind::Enhanced => "enhanced",
        }
    }
}

/// A four-node plane-stress quadrilateral at full density.
#[derive(Debug, Clone, PartialEq)]
pub struct Quad {
    /// Its material and thickness.
    pub material: PlaneMaterial,
    /// Reference area (m²).
    pub area: f64,
    points: [GaussPoint; 4],
    elasticity: SMatrix<f64, 3, 3>,
    /// The condensed incompatible modes of an enhanced cell.
    enhancement: Option<Enhancement>,
    /// The small-strain stiffness `K₀`, the tangent at `u = 0` (condensed where enhanced).
    small_strain: Matrix8,
    /// Reference corners `X_a` (m), relative to their centroid.
    centred: [Vector2<f64>; 4],
}

/// Why a quadrilateral cannot be built.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum QuadDefect {
    /// Its corners are not anticlockwise and convex: `det J ≤ 0` at a Gauss point.
    Inverted,
}

/// A cell's kinematics at displacements `u`, per Gauss point: the compatible strain's
/// derivative `B`, and the strain `E` (enhanced where the
/// cell is), with `A = ∂α/∂u` where it is enhanced.
struct Kinematics {
    operator: [SMatrix<f64, 3, 8>; 4],
    strain: [Vector3<f64>; 4],
    rate: Option<Condensed>,
}

impl Quad {
    /// The quadrilateral of `kind` with reference corners `x` (anticlockwise).
    ///
    /// # Errors
    /// [`QuadDefect::Inverted`] if the corners are clockwise, crossed or not convex.
    pub fn new(
        x: [Vector2<f64>; 4],
        material: PlaneMaterial,
        kind: CellKind,
    ) -> Result<Self, QuadDefect> {
        let g = 1.0 / 3.0_f64.sqrt();
        let natural = [(-g, -g), (g, -g), (g, g), (-g, g)];
        let mut points = [GaussPoint {
            shape: [0.0; 4],
            gradient: [Vector2::zeros(); 4],
            volume: 0.0,
        }; 4];
        let mut dets = [0.0; 4];
        for ((point, det), &(xi, eta)) in points.iter_mut().zip(&mut dets).zip(&natural) {
            let shape = CORNERS.map(|(a, b)| 0.25 * (1.0 + a * xi) * (1.0 + b * eta));
            let jacobian = Self::jacobian(&x, xi, eta);
            *det = jacobian.determinant();
            let inverse = jacobian.try_inverse().filter(|_| *det > 0.0);
            let inverse = inverse.ok_or(QuadDefect::Inverted)?;
            *point = GaussPoint {
                shape,
                gradient: Self::natural_gradients(xi, eta).map(|n| inverse.transpose() * n),
                volume: *det * material.thickness,
            };
        }
        let elasticity = material.elasticity();
        let enhancement = match kind {
            CellKind::Plain => None,
            CellKind::Enhanced => {
                let at = std::array::from_fn(|p| {
                    (natural[p].0, natural[p].1, dets[p], points[p].volume)
                });
                let centre = Self::jacobian(&x, 0.0, 0.0);
                Some(Enhancement::new(&centre, at, &elasticity).map_err(|_| QuadDefect::Inverted)?)
            }
        };
        let mut quad = Self {
            material,
            area: points.iter().map(|p| p.volume).sum::<f64>() / material.thickness,
            points,
            elasticity,
            enhancement,
            small_strain: Matrix8::zeros(),
            centred: x.map(|p| p - x.iter().sum::<Vector2<f64>>() / 4.0),
        };
        quad.small_strain = quad.internal_force_and_tangent(&Vector8::zeros()).1;
        Ok(quad)
    }

    /// The small-strain (linear) stiffness `K₀ = K(0)` (N/m): the linear cell's energy is
    /// `½ uᵀ K₀ u`, an enhanced cell's condensed exactly at `u = 0`.
    pub fn small_strain_stiffness(&self) -> &Matrix8 {
        &self.small_strain
    }

    /// The reference corners relative to their centroid, `X_a − X̄` (m).
    pub fn centred_corners(&self) -> &[Vector2<f64>; 4] {
        &self.centred
    }

    /// `∂N_a/∂(ξ, η)` of the four shape functions.
    fn natural_gradients(xi: f64, eta: f64) -> [Vector2<f64>; 4] {
        CORNERS.map(|(a, b)| Vector2::new(0.25 * a * (1.0 + b * eta), 0.25 * b * (1.0 + a * xi)))
    }

    /// The reference Jacobian `J_ij = ∂X_i/∂ξ_j` at `(ξ, η)`.
    fn jacobian(x: &[Vector2<f64>; 4], xi: f64, eta: f64) -> Matrix2<f64> {
        let natural = Self::natural_gradients(xi, eta);
        (0..4).map(|k| x[k] * natural[k].transpose()).sum()
    }

    /// Which strain the cell interpolates.
    pub fn kind(&self) -> CellKind {
        if self.enhancement.is_some() {
            CellKind::Enhanced
        } else {
            CellKind::Plain
        }
    }

    /// The displacement gradient `H = F − I = Σ_a u_a g_aᵀ` at a Gauss point.
    fn displacement_gradient(point: &GaussPoint, u: &Vector8) -> Matrix2<f64> {
        let mut h = Matrix2::zeros();
        for (a, g) in point.gradient.iter().enumerate() {
            h += Vector2::new(u[2 * a], u[2 * a + 1]) * g.transpose();
        }
        h
    }

    /// The smallest `det F` over the Gauss points: the local ratio of the deformed area to
    /// the reference one, at or below zero where the cell has turned inside out.
    pub fn smallest_area_ratio(&self, u: &Vector8) -> f64 {
        self.points
            .iter()
            .map(|p| (Self::displacement_gradient(p, u) + Matrix2::identity()).determinant())
            .fold(f64::INFINITY, f64::min)
    }

    /// Green–Lagrange strain `[E₁₁, E₂₂, 2E₁₂]` as `½ (H + Hᵀ + HᵀH)`: from `H`, not
    /// `F`, so that small strains keep their digits.
    fn strain(h: &Matrix2<f64>) -> Vector3<f64> {
        let e = (h + h.transpose() + h.transpose() * h) * 0.5;
        Vector3::new(e[(0, 0)], e[(1, 1)], 2.0 * e[(0, 1)])
    }

    /// `B = ∂ε/∂u` at a Gauss point with deformation gradient `f`.
    fn strain_operator(point: &GaussPoint, f: &Matrix2<f64>) -> SMatrix<f64, 3, 8> {
        let mut b = SMatrix::<f64, 3, 8>::zeros();
        for (a, g) in point.gradient.iter().enumerate() {
            for i in 0..2 {
                // δF = e_i g_aᵀ: δE₁₁ = F_i1 g₁, δE₂₂ = F_i2 g₂, 2δE₁₂ = F_i1 g₂ + F_i2 g₁.
                b[(0, 2 * a + i)] = f[(i, 0)] * g.x;
                b[(1, 2 * a + i)] = f[(i, 1)] * g.y;
                b[(2, 2 * a + i)] = f[(i, 0)] * g.y + f[(i, 1)] * g.x;
            }
        }
        b
    }

    /// The geometric stiffness `(g_aᵀ s g_b) I₂` of the stress `s` (times a volume) at a
    /// Gauss point, added to `k`: `∂(Bᵀ s)/∂u` at fixed `s`.
    fn add_geometric(point: &GaussPoint, s: &Vector3<f64>, k: &mut Matrix8) {
        let s = Matrix2::new(s[0], s[2], s[2], s[1]);
        for (a, ga) in point.gradient.iter().enumerate() {
            for (c, gc) in point.gradient.iter().enumerate() {
                let v = ga.dot(&(s * gc));
                k[(2 * a, 2 * c)] += v;
                k[(2 * a + 1, 2 * c + 1)] += v;
            }
        }
    }

    /// The deformation gradients `F` and the strains (enhanced where the cell is) at the
    /// Gauss points at `u`.
    fn deformation(&self, u: &Vector8) -> ([Matrix2<f64>; 4], [Vector3<f64>; 4]) {
        let h = self.points.map(|p| Self::displacement_gradient(&p, u));
        let mut strain = h.map(|h| Self::strain(&h));
        if let Some(enhancement) = &self.enhancement {
            enhancement.enhance(&mut strain);
        }
        (h.map(|h| h + Matrix2::identity()), strain)
    }

    /// The kinematics at `u`, with `A = ∂α/∂u` where the cell is enhanced.
    fn kinematics(&self, u: &Vector8) -> Kinematics {
        let (deformation, strain) = self.deformation(u);
        let operator =
            std::array::from_fn(|p| Self::strain_operator(&self.points[p], &deformation[p]));
        let condensed = (self.enhancement.as_ref()).map(|e| e.rate(&e.coupling(&operator)));
        Kinematics {
            operator,
            strain,
            rate: condensed,
        }
    }

    /// `B̄ = ∂E/∂u` at Gauss point `p`: `B`, plus `Γ A` where the cell is enhanced.
    fn total_operator(&self, k: &Kinematics, p: usize) -> SMatrix<f64, 3, 8> {
        match (&self.enhancement, &k.rate) {
            (Some(e), Some(a)) => enhanced_operator(&k.operator[p], e.modes(p), a),
            _ => k.operator[p],
        }
    }

    /// Green–Lagrange strains `[E₁₁, E₂₂, 2E₁₂]` at the four Gauss points (enhanced where
    /// the cell is).
    pub fn strains(&self, u: &Vector8) -> [Vector3<f64>; 4] {
        self.deformation(u).1
    }

    /// Strain energy `U(u)` (J), zero in any rigid motion.
    pub fn strain_energy(&self, u: &Vector8) -> f64 {
        let strain = self.strains(u);
        (0..4)
            .map(|p| {
                let e = strain[p];
                0.5 * self.points[p].volume * e.dot(&(self.elasticity * e))
            })
            .sum()
    }

    /// Internal force `f(u) = ∂U/∂u` (N): `Bᵀ S V` summed over the Gauss points, node
    /// `a`'s `V F S g_a` (an enhanced cell's `α` is at its condensed value, where
    /// `∂U/∂α = 0`).
    pub fn internal_force(&self, u: &Vector8) -> Vector8 {
        let (deformation, strain) = self.deformation(u);
        let mut force = Vector8::zeros();
        for (p, point) in self.points.iter().enumerate() {
            let s = self.elasticity * strain[p] * point.volume;
            let fs = deformation[p] * Matrix2::new(s[0], s[2], s[2], s[1]);
            for (a, g) in point.gradient.iter().enumerate() {
                let mut node = force.fixed_rows_mut::<2>(2 * a);
                node += fs * g;
            }
        }
        force
    }

    /// Internal force and its exact tangent `K = ∂f/∂u` (material and geometric parts;
    /// an enhanced cell's condensed, `K_uu − K_uα K_αα⁻¹ K_αu`).
    pub fn internal_force_and_tangent(&self, u: &Vector8) -> (Vector8, Matrix8) {
        let k = self.kinematics(u);
        let (mut force, mut tangent) = (Vector8::zeros(), Matrix8::zeros());
        for (p, point) in self.points.iter().enumerate() {
            let stress = self.elasticity * k.strain[p] * point.volume;
            let b = &k.operator[p];
            force += b.transpose() * stress;
            tangent += b.transpose() * self.elasticity * self.total_operator(&k, p) * point.volume;
            Self::add_geometric(point, &stress, &mut tangent);
        }
        (force, tangent)
    }

    /// Kelvin–Voigt damping `β K` at displacements `u` and velocities `v` (module
    /// documentation), at full density: on the rate `Ė = B̄ v` of the strain, enhanced
    /// where the cell is (`α̇ = A v`), from the dissipation `½ Σ V Ėᵀ β C Ė`.
    pub fn damping(&self, u: &Vector8, v: &Vector8) -> Damping<8> {
        let beta = self.material.beta;
        let k = self.kinematics(u);
        let h_v = self.points.map(|p| Self::displacement_gradient(&p, v));
        // D_p = B(H(v)): δ(B v) = D_p δu, since B is linear in F.
        let d_op: [SMatrix<f64, 3, 8>; 4] =
            std::array::from_fn(|p| Self::strain_operator(&self.points[p], &h_v[p]));
        let d_rate = self
            .enhancement
            .as_ref()
            .map(|e| e.rate(&e.coupling(&d_op)));
        let mut d = Damping {
            force: Vector8::zeros(),
            rate: Matrix8::zeros(),
            symmetric: Matrix8::zeros(),
            skew: Matrix8::zeros(),
        };
        let mut stresses = [Vector3::zeros(); 4];
        for (p, point) in self.points.iter().enumerate() {
            let b = self.total_operator(&k, p);
            let c = self.elasticity * (beta * point.volume);
            let stress = c * (b * v);
            d.force += b.transpose() * stress;
            d.rate += b.transpose() * c * b;
            let db = match (&self.enhancement, &d_rate) {
                (Some(e), Some(a)) => enhanced_operator(&d_op[p], e.modes(p), a),
                _ => d_op[p],
            };
            d.skew += b.transpose() * c * db;
            Self::add_geometric(point, &stress, &mut d.symmetric);
            stresses[p] = stress / point.volume;
        }
        if let Some(e) = &self.enhancement {
            // δAᵀ r with r = Σ V Γᵀ S_d: the geometric stiffness of −V C Γ K_αα⁻¹ r.
            let r = e.residual(&stresses, self.points.map(|p| p.volume));
            for (p, point) in self.points.iter().enumerate() {
                Self::add_geometric(point, &-e.back_stress(p, &r), &mut d.symmetric);
            }
        }
        d
    }

    /// The mass matrix: consistent, `ρ t ∫ N_a N_b dA I₂` (kg), or its row sums on the
    /// diagonal (lumped).
    pub fn mass_matrix(&self, kind: MassKind) -> Matrix8 {
        let consistent = self.consistent_mass();
        match kind {
            MassKind::Consistent | MassKind::BarLumped => consistent,
            MassKind::Lumped => Matrix8::from_diagonal(&consistent.column_sum()),
        }
    }

    fn consistent_mass(&self) -> Matrix8 {
        let mut mass = Matrix8::zeros();
        for p in &self.points {
            let w = self.material.density * p.volume;
            for a in 0..4 {
                for b in 0..4 {
                    let m = w * p.shape[a] * p.shape[b];
                    mass[(2 * a, 2 * b)] += m;
                    mass[(2 * a + 1, 2 * b + 1)] += m;
                }
            }
        }
        mass
    }

    /// Full-density volume `t A` (m³).
    pub fn volume(&self) -> f64 {
        self.material.thickness * self.area
    }

    /// Von Mises stress of the second Piola–Kirchhoff stress at the four Gauss points (Pa),
    /// `√(S₁₁² − S₁₁S₂₂ + S₂₂² + 3S₁₂²)` (plane stress; the Cauchy stress at small strain),
    /// with each point's share of the element's volume.
    pub fn von_mises(&self, u: &Vector8) -> [(f64, f64); 4] {
        let volume = self.volume();
        let strain = self.strains(u);
        std::array::from_fn(|p| {
            let stress = self.elasticity * strain[p];
            (von_mises(&stress), self.points[p].volume / volume)
        })
    }

    /// The von Mises stress at each Gauss point with its gradient `∂σ/∂u` (zero where the
    /// stress is) and the point's share of the element's volume.
    pub fn von_mises_and_gradient(&self, u: &Vector8) -> [(f64, Vector8, f64); 4] {
        let volume = self.volume();
        let k = self.kinematics(u);
        std::array::from_fn(|p| {
            let stress = self.elasticity * k.strain[p];
            let sigma = von_mises(&stress);
            // σ² = sᵀ P s with P = [[1, −½, 0], [−½, 1, 0], [0, 0, 3]]: ∂σ/∂s = P s / σ.
            let d_sigma = Vector3::new(
                stress[0] - 0.5 * stress[1],
                stress[1] - 0.5 * stress[0],
                3.0 * stress[2],
            );
            let b = self.total_operator(&k, p);
            let gradient = if sigma > 0.0 {
                b.transpose() * (self.elasticity * d_sigma) / sigma
            } else {
                Vector8::zeros()
            };
            (sigma, gradient, self.points[p].volume / volume)
        })
    }
}

/// `√(S₁₁² − S₁₁S₂₂ + S₂₂² + 3S₁₂²)` of a plane stress `[S₁₁, S₂₂, S₁₂]`.
fn von_mises(s: &Vector3<f64>) -> f64 {
    (s[0] * s[0] - s[0] * s[1] + s[1] * s[1] + 3.0 * s[2] * s[2]).sqrt()
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// Steel of `thickness` (m), damped by `β = 1e-4` s.
    pub(crate) fn steel(thickness: f64) -> PlaneMaterial {
        PlaneMaterial {
            young: 210e9,
            poisson: 0.3,
            density: 7800.0,
            thickness,
            alpha: 0.0,
            beta: 1e-4,
        }
    }

    /// A distorted (convex, not a parallelogram) quadrilateral, about 0.1 m across.
    pub(crate) fn corners() -> [Vector2<f64>; 4] {
        [
            Vector2::new(0.01, -0.005),
            Vector2::new(0.12, 0.0),
            Vector2::new(0.1, 0.09),
            Vector2::new(-0.01, 0.08),
        ]
    }

    /// A displacement of the corners that strains the element by about `scale`.
    pub(crate) fn strained(scale: f64) -> Vector8 {
        Vector8::from_fn(|i, _| scale * 0.1 * ((i as f64 * 1.7).sin() + 0.3))
    }

    fn rotated(x: &[Vector2<f64>; 4], angle: f64, shift: Vector2<f64>) -> Vector8 {
        let r = nalgebra::Rotation2::new(angle);
        let mut u = Vector8::zeros();
        for (a, p) in x.iter().enumerate() {
            let d = r * p + shift - p;
            u[2 * a] = d.x;
            u[2 * a + 1] = d.y;
        }
        u
    }

    #[test]
    fn the_area_ratio_is_one_in_rigid_motion_and_negative_once_turned_inside_out() {
        let x = corners();
        let quad = Quad::new(x, steel(0.01), CellKind::Plain).unwrap();
        let ratio = quad.smallest_area_ratio(&rotated(&x, 2.0, Vector2::new(1.0, 4.0)));
        assert!((ratio - 1.0).abs() < 1e-14, "{ratio}");
        // Stretched by 2 along x and 1.5 along y: det F = 3 everywhere.
        let stretch = Vector8::from_fn(|i, _| x[i / 2][i % 2] * [1.0, 0.5][i % 2]);
        assert!((quad.smallest_area_ratio(&stretch) - 3.0).abs() < 1e-13);
        // Mirrored through the y axis: det F = −1.
        let mirrored = Vector8::from_fn(|i, _| if i % 2 == 0 { -2.0 * x[i / 2].x } else { 0.0 });
        assert!((quad.smallest_area_ratio(&mirrored) + 1.0).abs() < 1e-14);
    }

    #[test]
    fn rigid_motion_gives_no_force_at_any_angle() {
        let (x, material) = (corners(), steel(0.01));
        let quad = Quad::new(x, material, CellKind::Plain).unwrap();
        // A unit-strain force: E t times the element's size.
        let unit = material.young * material.thickness * 0.1;
        for k in 0..=64 {
            let angle = 2.0 * PI * f64::from(k) / 64.0;
            let u = rotated(&x, angle, Vector2::new(3.0, -2.0));
            let f = quad.internal_force(&u);
            assert!(
                f.amax() < 1e-12 * unit,
                "angle {angle}: {}",
                f.amax() / unit
            );
            assert!(quad.strain_energy(&u).abs() < 1e-24 * unit * 0.1);
        }
    }

    /// The damping's force against its derivatives by central differences, at a large
    /// strain; none in a rigid motion at any angle and rate of turn; `∂f_d/∂q̇ = β K` at
    /// the reference.
    #[test]
    fn damping_derivatives_are_exact_and_rigid_motion_is_not_damped() {
        let quad = Quad::new(corners(), steel(0.01), CellKind::Plain).unwrap();
        let (u, v) = (strained(0.2), strained(3.0).map(|x| x.sin()));
        let d = quad.damping(&u, &v);
        let h = 1e-7;
        for j in 0..8 {
            let e = Vector8::from_fn(|i, _| if i == j { h } else { 0.0 });
            let fq =
                (quad.damping(&(u + e), &v).force - quad.damping(&(u - e), &v).force) / (2.0 * h);
            let fv =
                (quad.damping(&u, &(v + e)).force - quad.damping(&u, &(v - e)).force) / (2.0 * h);
            let exact = (d.symmetric + d.skew).column(j).into_owned();
            assert!(
                (exact - fq).amax() <= 1e-6 * (d.symmetric + d.skew).amax(),
                "∂f_d/∂q column {j}"
            );
            assert!(
                (d.rate.column(j) - fv).amax() <= 1e-7 * d.rate.amax(),
                "∂f_d/∂q̇ column {j}"
            );
        }
        assert!((d.symmetric - d.symmetric.transpose()).amax() <= 1e-12 * d.symmetric.amax());
        let x = corners();
        for angle in [0.3, 2.0, 5.5] {
            let (turned, spin) = (rotated(&x, angle, Vector2::new(0.1, -0.2)), 7.0);
            // The velocity of a rigid spin about the origin: ω J (X + u).
            let v = Vector8::from_fn(|i, _| {
                let (a, k) = (i / 2, i % 2);
                let p = x[a] + Vector2::new(turned[2 * a], turned[2 * a + 1]);
                spin * if k == 0 { -p.y } else { p.x }
            });
            let f = quad.damping(&turned, &v).force;
            assert!(
                f.amax() <= 1e-9 * d.force.amax(),
                "angle {angle}: {}",
                f.amax()
            );
        }
        let k = quad.internal_force_and_tangent(&Vector8::zeros()).1;
        let rate = quad.damping(&Vector8::zeros(), &v).rate;
        assert!((rate - k * 1e-4).amax() <= 1e-12 * rate.amax());
    }

    #[test]
    fn tangent_and_force_are_exact_derivatives() {
        let quad = Quad::new(corners(), steel(0.01), CellKind::Plain).unwrap();
        for scale in [1e-3, 0.2] {
            let u = strained(scale);
            let (f, k) = quad.internal_force_and_tangent(&u);
            assert!((f - quad.internal_force(&u)).amax() <= 1e-12 * f.amax());
            let h = 1e-7;
            for j in 0..8 {
                let mut up = u;
                up[j] += h;
                let mut um = u;
                um[j] -= h;
                let column = (quad.internal_force(&up) - quad.internal_force(&um)) / (2.0 * h);
                let error = (column - k.column(j)).amax();
                assert!(error < 1e-6 * k.amax(), "tangent column {j}: {error}");
                let de = (quad.strain_energy(&up) - quad.strain_energy(&um)) / (2.0 * h);
                assert!((de - f[j]).abs() < 1e-6 * f.amax(), "energy gradient {j}");
            }
            assert!((k - k.transpose()).amax() < 1e-9 * k.amax(), "symmetric");
        }
    }

    /// The small-strain stiffness of a unit square of unit thickness is the 88-line code's
    /// `KE` (Andreassen et al. 2011, Eq. 9 with E = 1): its closed form, node order and DOF
    /// order are the same as ours (lower-left anticlockwise).
    #[test]
    fn small_strain_stiffness_is_the_88_line_codes() {
        let nu = 0.3;
        let material = PlaneMaterial {
            young: 1.0,
            poisson: nu,
            density: 1.0,
            thickness: 1.0,
            alpha: 0.0,
            beta: 0.0,
        };
        let x = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)].map(|(a, b)| Vector2::new(a, b));
        let (_, k) = Quad::new(x, material, CellKind::Plain)
            .unwrap()
            .internal_force_and_tangent(&Vector8::zeros());
        let a11 = [
            12.0, 3.0, -6.0, -3.0, 3.0, 12.0, 3.0, 0.0, -6.0, 3.0, 12.0, -3.0, -3.0, 0.0, -3.0,
            12.0,
        ];
        let a12 = [
            -6.0, -3.0, 0.0, 3.0, -3.0, -6.0, -3.0, -6.0, 0.0, -3.0, -6.0, 3.0, 3.0, -6.0, 3.0,
            -6.0,
        ];
        let b11 = [
            -4.0, 3.0, -2.0, 9.0, 3.0, -4.0, -9.0, 4.0, -2.0, -9.0, -4.0, -3.0, 9.0, 4.0, -3.0,
            -4.0,
        ];
        let b12 = [
            2.0, -3.0, 4.0, -9.0, -3.0, 2.0, 9.0, -2.0, 4.0, 9.0, 2.0, 3.0, -9.0, -2.0, 3.0, 2.0,
        ];
        let block = |a: [f64; 16], b: [f64; 16], i: usize, j: usize| {
            (a[4 * i + j] + nu * b[4 * i + j]) / (24.0 * (1.0 - nu * nu))
        };
        // KE = [[A11, A12], [A12ᵀ, A11]] + ν [[B11, B12], [B12ᵀ, B11]], over 24(1 − ν²).
        let ke = Matrix8::from_fn(|i, j| match (i / 4, j / 4) {
            (0, 0) | (1, 1) => block(a11, b11, i % 4, j % 4),
            (0, 1) => block(a12, b12, i % 4, j % 4),
            _ => block(a12, b12, j % 4, i % 4),
        });
        assert!((k - ke).amax() < 1e-14, "{}", (k - ke).amax());
    }

    #[test]
    fn a_constant_strain_field_is_reproduced_exactly() {
        // The patch test: a linear displacement gives its strain at every Gauss point.
        let x = corners();
        let quad = Quad::new(x, steel(0.01), CellKind::Plain).unwrap();
        let grad = Matrix2::new(1e-4, 3e-5, -2e-5, 2e-4);
        let mut u = Vector8::zeros();
        for (a, p) in x.iter().enumerate() {
            let d = grad * p;
            u[2 * a] = d.x;
            u[2 * a + 1] = d.y;
        }
        let h = grad;
        let e = (h + h.transpose() + h.transpose() * h) * 0.5;
        for strain in quad.strains(&u) {
            let expected = Vector3::new(e[(0, 0)], e[(1, 1)], 2.0 * e[(0, 1)]);
            assert!(
                (strain - expected).amax() < 1e-15 * expected.amax(),
                "{}",
                (strain - expected).amax()
            );
        }
    }

    #[test]
    fn mass_carries_the_element_and_its_inertia() {
        let (x, material) = (corners(), steel(0.01));
        let quad = Quad::new(x, material, CellKind::Plain).unwrap();
        let m = quad.mass_matrix(MassKind::Consistent);
        let lumped = quad.mass_matrix(MassKind::Lumped);
        assert!(
            (lumped.trace() - 2.0 * quad.volume() * material.density).abs()
                < 1e-12 * lumped.trace()
        );
        // Shoelace area of the corners.
        let area = 0.5 * (0..4).map(|a| x[a].perp(&x[(a + 1) % 4])).sum::<f64>();
        assert!((quad.area - area).abs() < 1e-15);
        let total = material.density * material.thickness * area;
        let ones = Vector8::from_fn(|i, _| if i % 2 == 0 { 1.0 } else { 0.0 });
        assert!(((ones.transpose() * m * ones)[0] - total).abs() < 1e-12 * total);
        // Polar moment about the origin: ρ t ∫ |X|² dA, against the exact polygon formula.
        let spin = Vector8::from_fn(|i, _| {
            let p = x[i / 2];
            if i % 2 == 0 {
                -p.y
            } else {
                p.x
            }
        });
        let polar = material.density * material.thickness / 12.0
            * (0..4)
                .map(|a| {
                    let (p, q) = (x[a], x[(a + 1) % 4]);
                    p.perp(&q) * (p.norm_squared() + p.dot(&q) + q.norm_squared())
                })
                .sum::<f64>();
        assert!(((spin.transpose() * m * spin)[0] - polar).abs() < 1e-12 * polar);
    }

    #[test]
    fn von_mises_gradients_are_exact() {
        let quad = Quad::new(corners(), steel(0.01), CellKind::Plain).unwrap();
        let u = strained(1e-3);
        let h = 1e-9;
        for (k, (sigma, gradient, share)) in quad.von_mises_and_gradient(&u).into_iter().enumerate()
        {
            assert!((sigma - quad.von_mises(&u)[k].0).abs() < 1e-12 * sigma);
            assert!(share > 0.0 && share < 1.0 && share == quad.von_mises(&u)[k].1);
            for j in 0..8 {
                let (mut up, mut um) = (u, u);
                up[j] += h;
                um[j] -= h;
                let fd = (quad.von_mises(&up)[k].0 - quad.von_mises(&um)[k].0) / (2.0 * h);
                assert!((fd - gradient[j]).abs() < 1e-6 * gradient.amax(), "{k} {j}");
            }
        }
    }

    #[test]
    fn inverted_corners_are_refused() {
        let mut x = corners();
        x.swap(1, 3);
        assert_eq!(
            Quad::new(x, steel(0.01), CellKind::Plain),
            Err(QuadDefect::Inverted)
        );
    }
}
