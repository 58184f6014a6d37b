//! Void cells that cannot stop a run: each cell's strain energy interpolated between its
//! nonlinear and its linear (small-strain) form by its density, after Wang, Lazarov &
//! Sigmund (2014, "Interpolation scheme for fictitious domain techniques and topology
//! optimization of finite strain elastic problems", CMAME 276).
//!
//! With `u_γ = γ(x) u` the cell's energy (at full density; the design scales it by `s(x)`
//! outside, as before) is
//!
//! ```text
//! Ψ(u, x) = Ψ_NL(γ u) − Ψ_L(γ u) + Ψ_L(u),        Ψ_L(u) = ½ uᵀ K₀ u,
//! f(u)    = γ f_NL(γ u) + (1 − γ²) K₀ u,
//! K(u)    = γ² K_NL(γ u) + (1 − γ²) K₀,
//! ```
//!
//! `K₀` the cell's small-strain stiffness ([`Quad::small_strain_stiffness`]). A solid cell
//! (`γ = 1`) is the nonlinear cell, bit for bit; a void cell (`γ → 0`) is the linear one,
//! whose energy stays a positive quadratic however the cell is distorted: it cannot turn
//! inside out in the energy's sense, nor make the tangent indefinite.
//!
//! In this fixed frame ([`FixedFrame`], the paper's form) the linear energy is not
//! objective: a void cell turned rigidly by `θ` stores `½ uᵀ K₀ u` with `u = (R(θ) − I) X`,
//! a spurious force `s(x_min) (1 − cos θ) K₀ (−X)` (this module's tests); and a cell in the
//! step (`0 < γ < 1`) sees `γ u` of a rotation as a strain `−γ(1 − γ)(1 − cos θ) I`. The
//! paper's fictitious domains do not turn; a mechanism's links turn by tens of degrees,
//! and on the continuum arm the fixed-frame scheme put 99 % of the cells' strain energy
//! in the void cells of a random design and moved its tip deflection by 64 % (BENCHMARKS,
//! "Void cells"). So a member's cell ([`Blended`]) applies the interpolation to its
//! co-rotated displacement `d(u) = Rᵀ(θ)(X + u) − X`, `θ` the cell's least-squares
//! rotation (`tan θ = Σ X_a × x_a / Σ X_a · x_a` about the centroid), `Ψ(u) = Φ(d(u))` with
//! `Φ` the fixed-frame energy above: objective at every density (a rigid motion makes `d`
//! a translation), and `Ψ_NL(d) = Ψ_NL(u)`, so solid cells are unchanged.
//!
//! The blend is the paper's smoothed Heaviside step
//!
//! ```text
//! γ(x) = (tanh(β₁ η₁) + tanh(β₁ (x − η₁))) / (tanh(β₁ η₁) + tanh(β₁ (1 − η₁))),
//! ```
//!
//! `γ(0) = 0`, `γ(1) = 1`. The paper takes `β₁ = 500`, `η₁ = 0.01` with `x_min` near zero
//! (`E_min = 10⁻⁹ E`); here the densities' floor is `x_min = 0.01`, so the default
//! threshold is raised to `η₁ = 0.05` ([`EnergyInterpolation::DEFAULT`]): `γ(0.01) = 0` and
//! `γ(x) = 1` in double precision above `x ≈ 0.12`, so every design with no cell below that
//! is unchanged.
//!
//! For an enhanced cell each of the three energies is condensed in its own modes: `Ψ_NL`
//! at `γ u` exactly as [`super::enhanced`] condenses it, and `Ψ_L` is the condensed small-
//! strain energy `½ uᵀ K₀ u`, whose modes are linear in `u` (`α = −K_αα⁻¹ K_αu(0) u`): each
//! part stays a pure function of `u`, exact at any strain, with no state kept.
//!
//! Kelvin–Voigt damping is interpolated the same way on the dissipation,
//! `D(u, v) = D_NL(γ u, γ v) − ½ γ² vᵀ βK₀ v + ½ vᵀ βK₀ v`: `f_d = γ f_d,NL(γu, γv) + (1 −
//! γ²) βK₀ v`, `∂f_d/∂v = γ² ∂f_d,NL/∂v + (1 − γ²) βK₀`, `∂f_d/∂u = γ² ∂f_d,NL/∂u`, so
//! `∂f_d/∂v = β K` at the reference, as for the nonlinear cell.
//!
//! A density moves `s(x) f` through both `s` and `γ`: the pseudo-load is
//! `s'(x) f + s(x) γ'(x) ∂f/∂γ` with `∂f/∂γ = f_NL(γu) + γ K_NL(γu) u − 2γ K₀ u` in the
//! fixed frame, `Gᵀ` of it at `d` co-rotated (`G = ∂d/∂u` does not depend on `x`).

use std::ops::AddAssign;

use nalgebra::{Matrix2, SMatrix, Vector2};

use super::beam::Damping;
use super::quad::{Matrix8, Quad, Vector8};

/// The blend `γ(x)` of a cell's nonlinear and linear energies, a smoothed Heaviside step
/// at the threshold `η₁` of sharpness `β₁` (module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EnergyInterpolation {
    /// The density `η₁` where `γ = ½` (approximately).
    pub threshold: f64,
    /// The step's sharpness `β₁`.
    pub sharpness: f64,
}

impl Default for EnergyInterpolation {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl EnergyInterpolation {
    /// `η₁ = 0.05`, `β₁ = 500` (the paper's `β₁`; `η₁` above the floor `x_min = 0.01`).
    pub const DEFAULT: Self = Self {
        threshold: 0.05,
        sharpness: 500.0,
    };

    fn denominator(&self) -> f64 {
        let (b, t) = (self.sharpness, self.threshold);
        (b * t).tanh() + (b * (1.0 - t)).tanh()
    }

    /// `γ(x)`, 0 at `x = 0`, 1 at `x = 1`.
    pub fn blend(&self, x: f64) -> f64 {
        let (b, t) = (self.sharpness, self.threshold);
        ((b * t).tanh() + (b * (x - t)).tanh()) / self.denominator()
    }

    /// `γ'(x) = β₁ (1 − tanh²(β₁ (x − η₁))) / (tanh(β₁ η₁) + tanh(β₁ (1 − η₁)))`.
    pub fn blend_rate(&self, x: f64) -> f64 {
        let th = (self.sharpness * (x - self.threshold)).tanh();
        self.sharpness * (1.0 - th * th) / self.denominator()
    }
}

/// A cell of blend `γ` in the paper's fixed frame, `Φ(u) = Ψ_NL(γu) − Ψ_L(γu) + Ψ_L(u)`:
/// the interpolated energy and what derives from it. Not objective where `γ < 1`; a
/// member's cells use it co-rotated ([`Blended`]).
#[derive(Debug, Clone, Copy)]
pub struct FixedFrame<'a> {
    quad: &'a Quad,
    gamma: f64,
}

impl Quad {
    /// This cell with its energy blended by `gamma` in the fixed frame (`γ(x)`; 1: the
    /// nonlinear cell).
    pub fn fixed_frame(&self, gamma: f64) -> FixedFrame<'_> {
        FixedFrame { quad: self, gamma }
    }

    /// This cell with its energy blended by `gamma` on its co-rotated displacement
    /// (`γ(x)`; 1: the nonlinear cell): what a member's cells are.
    pub fn blended(&self, gamma: f64) -> Blended<'_> {
        Blended {
            frame: FixedFrame { quad: self, gamma },
        }
    }
}

impl FixedFrame<'_> {
    fn solid(&self) -> bool {
        self.gamma == 1.0
    }

    fn linear(&self) -> &Matrix8 {
        self.quad.small_strain_stiffness()
    }

    /// `Ψ(u) = Ψ_NL(γu) + ½ (1 − γ²) uᵀ K₀ u` (J).
    pub fn strain_energy(&self, u: &Vector8) -> f64 {
        if self.solid() {
            return self.quad.strain_energy(u);
        }
        let g = self.gamma;
        self.quad.strain_energy(&(u * g)) + 0.5 * (1.0 - g * g) * u.dot(&(self.linear() * u))
    }

    /// `f(u) = γ f_NL(γu) + (1 − γ²) K₀ u` (N).
    pub fn internal_force(&self, u: &Vector8) -> Vector8 {
        if self.solid() {
            return self.quad.internal_force(u);
        }
        let g = self.gamma;
        self.quad.internal_force(&(u * g)) * g + self.linear() * u * (1.0 - g * g)
    }

    /// The force and its exact tangent `γ² K_NL(γu) + (1 − γ²) K₀`.
    pub fn internal_force_and_tangent(&self, u: &Vector8) -> (Vector8, Matrix8) {
        if self.solid() {
            return self.quad.internal_force_and_tangent(u);
        }
        let g = self.gamma;
        let (f, k) = self.quad.internal_force_and_tangent(&(u * g));
        let rest = 1.0 - g * g;
        (
            f * g + self.linear() * u * rest,
            k * (g * g) + self.linear() * rest,
        )
    }

    /// Kelvin–Voigt damping on the blended dissipation (module documentation).
    pub fn damping(&self, u: &Vector8, v: &Vector8) -> Damping<8> {
        if self.solid() {
            return self.quad.damping(u, v);
        }
        let g = self.gamma;
        let d = self.quad.damping(&(u * g), &(v * g));
        let linear = self.linear() * (self.quad.material.beta * (1.0 - g * g));
        Damping {
            force: d.force * g + linear * v,
            rate: d.rate * (g * g) + linear,
            symmetric: d.symmetric * (g * g),
            skew: d.skew * (g * g),
        }
    }

    /// `∂Ψ/∂γ = f_NL(γu)ᵀ u − γ uᵀ K₀ u` (J).
    pub fn energy_rate(&self, u: &Vector8) -> f64 {
        let g = self.gamma;
        self.quad.internal_force(&(u * g)).dot(u) - g * u.dot(&(self.linear() * u))
    }

    /// `∂f/∂γ = f_NL(γu) + γ K_NL(γu) u − 2γ K₀ u` (N).
    pub fn force_rate(&self, u: &Vector8) -> Vector8 {
        let g = self.gamma;
        let (f, k) = self.quad.internal_force_and_tangent(&(u * g));
        f + (k * u - self.linear() * u * 2.0) * g
    }

    /// `∂f_d/∂γ = 2 f_d,NL + γ (∂f_d,NL/∂u) u − 2γ βK₀ v` at `(γu, γv)` (N): `f_d,NL` is
    /// linear in the velocity, so its share `γ (∂f_d,NL/∂v) v` is `f_d,NL` again.
    pub fn damping_rate(&self, u: &Vector8, v: &Vector8) -> Vector8 {
        let g = self.gamma;
        let d = self.quad.damping(&(u * g), &(v * g));
        let beta = self.quad.material.beta;
        d.force * 2.0 + ((d.symmetric + d.skew) * u - self.linear() * v * (2.0 * beta)) * g
    }

    /// `∂K/∂γ = 2γ (K_NL(γu) − K₀) + γ² (∂K_NL/∂u)[u]` (N/m); the last term the central
    /// difference `(K_NL(γu + u) − K_NL(γu − u))/2`, exact because a St. Venant–Kirchhoff
    /// cell's tangent is quadratic in `u` (its strain, enhanced or not, is).
    pub fn tangent_rate(&self, u: &Vector8) -> Matrix8 {
        let g = self.gamma;
        let at = |w: Vector8| self.quad.internal_force_and_tangent(&w).1;
        let k = at(u * g);
        let directional: SMatrix<f64, 8, 8> = (at(u * g + u) - at(u * g - u)) * 0.5;
        (k - self.linear()) * (2.0 * g) + directional * (g * g)
    }

    /// The smallest `det(I + γ H)` over the Gauss points: where the nonlinear part of the
    /// energy sees the cell turned inside out (1 for a void cell, `γ = 0`).
    pub fn smallest_area_ratio(&self, u: &Vector8) -> f64 {
        self.quad.smallest_area_ratio(&(u * self.gamma))
    }
}

/// The cell's least-squares rotation `θ(u) = atan2(B, A)`, `A = Σ P_a · x_a`, `B = Σ P_a ×
/// x_a` (`P_a` the reference corners about their centroid, `x_a = P_a + u_a`), and the
/// co-rotated displacement `d(u) = Rᵀ(θ) x − P` with its derivatives: `G = ∂d/∂u =
/// diag(Rᵀ) + w θ_uᵀ` (`w_a = Rᵀ' x_a`), and `Σ_i φ_i ∂²d_i/∂u²` for a force `φ` on `d`.
/// A rigid motion `x = R(φ) P + c` has `θ = φ` and `d = Rᵀ c`, a translation.
struct CoRotation {
    /// `dRᵀ/dθ`.
    drt: Matrix2<f64>,
    /// `d(u)`.
    d: Vector8,
    /// `G = ∂d/∂u`.
    g: Matrix8,
    /// `θ_u = ∂θ/∂u`.
    theta: Vector8,
    /// `∂²θ/∂u²`.
    hessian: Matrix8,
    /// `w = [Rᵀ' x_a]` and `w₂ = [Rᵀ'' x_a] = −[Rᵀ x_a]`.
    w: Vector8,
    w2: Vector8,
}

impl CoRotation {
    fn new(quad: &Quad, u: &Vector8) -> Self {
        let p = quad.centred_corners();
        let x: [Vector2<f64>; 4] =
            std::array::from_fn(|a| p[a] + Vector2::new(u[2 * a], u[2 * a + 1]));
        let (a, b) = (0..4).fold((0.0, 0.0), |(a, b), k| {
            (a + p[k].dot(&x[k]), b + p[k].perp(&x[k]))
        });
        let (c, s) = {
            let r = a.hypot(b);
            (a / r, b / r)
        };
        let rt = Matrix2::new(c, s, -s, c);
        let drt = Matrix2::new(-s, c, -c, -s);
        // ∂A/∂u_a = P_a, ∂B/∂u_a = (−P_a.y, P_a.x): constant.
        let da = Vector8::from_fn(|i, _| p[i / 2][i % 2]);
        let db = Vector8::from_fn(|i, _| if i % 2 == 0 { -p[i / 2].y } else { p[i / 2].x });
        let r2 = a * a + b * b;
        let n = db * a - da * b;
        let theta = n / r2;
        let hessian = (db * da.transpose() - da * db.transpose()) / r2
            - n * (da * a + db * b).transpose() * (2.0 / (r2 * r2));
        let stack = |m: &Matrix2<f64>| {
            let y: [Vector2<f64>; 4] = std::array::from_fn(|k| m * x[k]);
            Vector8::from_fn(|i, _| y[i / 2][i % 2])
        };
        let (w, rx) = (stack(&drt), stack(&rt));
        let d = rx - da;
        let mut g = w * theta.transpose();
        for k in 0..4 {
            g.fixed_view_mut::<2, 2>(2 * k, 2 * k).add_assign(&rt);
        }
        Self {
            drt,
            d,
            g,
            theta,
            hessian,
            w,
            w2: -rx,
        }
    }

    /// `Σ_i φ_i ∂²d_i/∂u² = v θ_uᵀ + θ_u vᵀ + (φ·w₂) θ_u θ_uᵀ + (φ·w) ∂²θ/∂u²`, with
    /// `v_a = Rᵀ'ᵀ φ_a`.
    fn contract(&self, phi: &Vector8) -> Matrix8 {
        let v = self.per_node(&self.drt.transpose(), phi);
        let t = &self.theta;
        v * t.transpose()
            + t * v.transpose()
            + t * t.transpose() * phi.dot(&self.w2)
            + self.hessian * phi.dot(&self.w)
    }

    /// `∂(G v)/∂u = [Rᵀ' v_a] θ_uᵀ + (θ_u·v) (w₂ θ_uᵀ + diag(Rᵀ')) + w (∂²θ/∂u² v)ᵀ`.
    fn velocity_term(&self, v: &Vector8) -> Matrix8 {
        let t = &self.theta;
        let tv = t.dot(v);
        let mut q = self.per_node(&self.drt, v) * t.transpose()
            + (self.w2 * t.transpose()) * tv
            + self.w * (self.hessian * v).transpose();
        for k in 0..4 {
            q.fixed_view_mut::<2, 2>(2 * k, 2 * k)
                .add_assign(&(self.drt * tv));
        }
        q
    }

    /// `[m y_a]` of a vector `y` on the four corners.
    fn per_node(&self, m: &Matrix2<f64>, y: &Vector8) -> Vector8 {
        let mut out = Vector8::zeros();
        for k in 0..4 {
            let z = m * Vector2::new(y[2 * k], y[2 * k + 1]);
            out[2 * k] = z.x;
            out[2 * k + 1] = z.y;
        }
        out
    }
}

/// A member's cell of blend `γ`: [`FixedFrame`]'s energy `Φ` on the cell's co-rotated
/// displacement `d(u)`, `Ψ(u) = Φ(d(u))` (module documentation), objective at every
/// density: `f = Gᵀ φ(d)`, `K = Gᵀ K_Φ(d) G + Σ_i φ_i ∂²d_i/∂u²`, the damping on `ḋ = G v`.
/// At `γ = 1`, `Ψ_NL(d) = Ψ_NL(u)` and the nonlinear cell is evaluated on `u` directly.
#[derive(Debug, Clone, Copy)]
pub struct Blended<'a> {
    frame: FixedFrame<'a>,
}

impl Blended<'_> {
    fn solid(&self) -> Option<&Quad> {
        (self.frame.gamma == 1.0).then_some(self.frame.quad)
    }

    fn corotation(&self, u: &Vector8) -> CoRotation {
        CoRotation::new(self.frame.quad, u)
    }

    /// `Ψ(u) = Φ(d(u))` (J).
    pub fn strain_energy(&self, u: &Vector8) -> f64 {
        if let Some(quad) = self.solid() {
            return quad.strain_energy(u);
        }
        self.frame.strain_energy(&self.corotation(u).d)
    }

    /// `f = Gᵀ φ(d)` (N).
    pub fn internal_force(&self, u: &Vector8) -> Vector8 {
        if let Some(quad) = self.solid() {
            return quad.internal_force(u);
        }
        let c = self.corotation(u);
        c.g.transpose() * self.frame.internal_force(&c.d)
    }

    /// The force and its exact tangent `Gᵀ K_Φ G + Σ_i φ_i ∂²d_i/∂u²`.
    pub fn internal_force_and_tangent(&self, u: &Vector8) -> (Vector8, Matrix8) {
        if let Some(quad) = self.solid() {
            return quad.internal_force_and_tangent(u);
        }
        let c = self.corotation(u);
        let (phi, k) = self.frame.internal_force_and_tangent(&c.d);
        (
            c.g.transpose() * phi,
            c.g.transpose() * k * c.g + c.contract(&phi),
        )
    }

    /// Kelvin–Voigt damping on the co-rotated rate `ḋ = G v`: `f_d = Gᵀ f_d,Φ(d, ḋ)`,
    /// `∂f_d/∂v = Gᵀ C_Φ G`, `∂f_d/∂u = Σ_i f_d,Φ,i ∂²d_i/∂u² + Gᵀ (∂f_d,Φ/∂d) G + Gᵀ C_Φ
    /// ∂(G v)/∂u`; none in a rigid motion.
    pub fn damping(&self, u: &Vector8, v: &Vector8) -> Damping<8> {
        if let Some(quad) = self.solid() {
            return quad.damping(u, v);
        }
        let c = self.corotation(u);
        let d = self.frame.damping(&c.d, &(c.g * v));
        let gt = c.g.transpose();
        Damping {
            force: gt * d.force,
            rate: gt * d.rate * c.g,
            symmetric: gt * d.symmetric * c.g + c.contract(&d.force),
            skew: gt * d.skew * c.g + gt * d.rate * c.velocity_term(v),
        }
    }

    /// `∂Ψ/∂γ` at fixed `u` (J).
    pub fn energy_rate(&self, u: &Vector8) -> f64 {
        self.frame.energy_rate(&self.corotation(u).d)
    }

    /// `∂f/∂γ = Gᵀ ∂φ/∂γ` (N).
    pub fn force_rate(&self, u: &Vector8) -> Vector8 {
        let c = self.corotation(u);
        c.g.transpose() * self.frame.force_rate(&c.d)
    }

    /// `∂f_d/∂γ = Gᵀ ∂f_d,Φ/∂γ` (N).
    pub fn damping_rate(&self, u: &Vector8, v: &Vector8) -> Vector8 {
        let c = self.corotation(u);
        c.g.transpose() * self.frame.damping_rate(&c.d, &(c.g * v))
    }

    /// `∂K/∂γ = Gᵀ ∂K_Φ/∂γ G + Σ_i ∂φ_i/∂γ ∂²d_i/∂u²` (N/m).
    pub fn tangent_rate(&self, u: &Vector8) -> Matrix8 {
        let c = self.corotation(u);
        c.g.transpose() * self.frame.tangent_rate(&c.d) * c.g
            + c.contract(&self.frame.force_rate(&c.d))
    }

    /// The smallest `det(I + γ ∇d)` over the Gauss points: where the nonlinear part of the
    /// energy sees the cell turned inside out (1 for a void cell, `γ = 0`).
    pub fn smallest_area_ratio(&self, u: &Vector8) -> f64 {
        if let Some(quad) = self.solid() {
            return quad.smallest_area_ratio(u);
        }
        self.frame.smallest_area_ratio(&self.corotation(u).d)
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{Rotation2, Vector2};

    use super::*;
    use crate::mechanism::element::quad::tests::{corners, steel, strained};
    use crate::mechanism::element::quad::CellKind;

    const KINDS: [CellKind; 2] = [CellKind::Plain, CellKind::Enhanced];
    /// The densities the tests visit: solid, grey, the step's middle, void.
    const DENSITIES: [f64; 4] = [1.0, 0.5, 0.05, 0.01];

    fn law() -> EnergyInterpolation {
        EnergyInterpolation::DEFAULT
    }

    /// About 20 % strain, the cell turned by 0.7 rad.
    fn large() -> Vector8 {
        let (x, u, r) = (corners(), strained(0.2), Rotation2::new(0.7));
        Vector8::from_fn(|i, _| {
            let p = x[i / 2] + Vector2::new(u[i / 2 * 2], u[i / 2 * 2 + 1]);
            (r * p - x[i / 2])[i % 2]
        })
    }

    /// Squeezed to a quarter of its area (`det F = 0.2`, sheared) and turned by 2.5 rad,
    /// as a void cell between solid islands.
    fn squeezed() -> Vector8 {
        let f = Rotation2::new(2.5).matrix() * Matrix2::new(0.25, 0.3, 0.0, 0.8);
        let x = corners();
        Vector8::from_fn(|i, _| ((f - Matrix2::identity()) * x[i / 2])[i % 2] + strained(0.02)[i])
    }

    fn unit(j: usize, h: f64) -> Vector8 {
        Vector8::from_fn(|i, _| if i == j { h } else { 0.0 })
    }

    fn rotated(x: &[Vector2<f64>; 4], angle: f64) -> Vector8 {
        let r = Rotation2::new(angle);
        Vector8::from_fn(|i, _| {
            let p = x[i / 2];
            (r * p - p)[i % 2]
        })
    }

    #[test]
    fn the_blend_is_a_step_from_void_to_solid_with_its_exact_rate() {
        let law = law();
        assert_eq!(law.blend(1.0), 1.0);
        assert_eq!(law.blend(0.0), 0.0);
        assert!(law.blend(0.01) < 1e-15 && law.blend(0.2) == 1.0);
        assert!((law.blend(0.05) - 0.5).abs() < 1e-10);
        for x in [0.03, 0.05, 0.06, 0.5] {
            let h = 1e-7;
            let fd = (law.blend(x + h) - law.blend(x - h)) / (2.0 * h);
            let exact = law.blend_rate(x);
            assert!(
                (fd - exact).abs() <= 1e-6 * exact.max(1.0),
                "{x}: {fd} {exact}"
            );
        }
    }

    /// Force against the energy's differences, tangent against the force's, at a large
    /// strain (about 20 %) and rotation (0.7 rad) and x ∈ {1, 0.5, 0.05, 0.01}, for either
    /// cell.
    #[test]
    fn force_and_tangent_are_exact_derivatives_at_every_density() {
        for (u, kind) in [large(), squeezed()]
            .into_iter()
            .flat_map(|u| KINDS.map(|k| (u, k)))
        {
            let quad = Quad::new(corners(), steel(0.01), kind).unwrap();
            for x in DENSITIES {
                let cell = quad.blended(law().blend(x));
                let (f, k) = cell.internal_force_and_tangent(&u);
                assert!((f - cell.internal_force(&u)).amax() <= 1e-12 * f.amax());
                let h = 1e-7;
                for j in 0..8 {
                    let (up, um) = (u + unit(j, h), u - unit(j, h));
                    let column = (cell.internal_force(&up) - cell.internal_force(&um)) / (2.0 * h);
                    let error = (column - k.column(j)).amax();
                    assert!(
                        error < 1e-6 * k.amax(),
                        "{kind:?} x {x} column {j}: {error}"
                    );
                    let de = (cell.strain_energy(&up) - cell.strain_energy(&um)) / (2.0 * h);
                    assert!(
                        (de - f[j]).abs() < 1e-6 * f.amax(),
                        "{kind:?} x {x} energy {j}"
                    );
                }
                assert!((k - k.transpose()).amax() < 1e-9 * k.amax());
            }
        }
    }

    /// The density derivatives (`∂Ψ/∂x`, `∂f/∂x`, `∂K/∂x`, `∂f_d/∂x` through `γ`) against
    /// central differences in `x` at a large strain and rotation.
    #[test]
    fn density_derivatives_are_exact() {
        let (u, v) = (large(), strained(3.0).map(f64::sin));
        let law = law();
        for kind in KINDS {
            let quad = Quad::new(corners(), steel(0.01), kind).unwrap();
            for x in DENSITIES {
                let (g, rate) = (law.blend(x), law.blend_rate(x));
                let h = 1e-7;
                let at = |x: f64| quad.blended(law.blend(x));
                let (p, m) = (at(x + h), at(x - h));
                let cell = quad.blended(g);
                let de = (p.strain_energy(&u) - m.strain_energy(&u)) / (2.0 * h);
                let exact = rate * cell.energy_rate(&u);
                let scale = cell.strain_energy(&u).max(quad.strain_energy(&u) * 1e-9);
                assert!((de - exact).abs() <= 1e-6 * scale, "{kind:?} {x} energy");
                let df = (p.internal_force(&u) - m.internal_force(&u)) / (2.0 * h);
                let exact = cell.force_rate(&u) * rate;
                let scale = quad.internal_force(&u).amax() * rate.max(1e-9);
                assert!((df - exact).amax() <= 1e-6 * scale, "{kind:?} {x} force");
                let dk = (p.internal_force_and_tangent(&u).1 - m.internal_force_and_tangent(&u).1)
                    / (2.0 * h);
                let exact = cell.tangent_rate(&u) * rate;
                let scale = quad.internal_force_and_tangent(&u).1.amax() * rate.max(1e-9);
                assert!((dk - exact).amax() <= 1e-6 * scale, "{kind:?} {x} tangent");
                let dd = (p.damping(&u, &v).force - m.damping(&u, &v).force) / (2.0 * h);
                let exact = cell.damping_rate(&u, &v) * rate;
                let scale = quad.damping(&u, &v).force.amax() * rate.max(1e-9);
                assert!((dd - exact).amax() <= 1e-6 * scale, "{kind:?} {x} damping");
            }
        }
    }

    /// The blended damping's force against its derivatives by central differences, at a
    /// large strain and rotation; `∂f_d/∂v = β K₀` at the reference.
    #[test]
    fn damping_derivatives_are_exact_at_every_density() {
        let (u, v) = (large(), strained(3.0).map(f64::sin));
        for kind in KINDS {
            let quad = Quad::new(corners(), steel(0.01), kind).unwrap();
            for x in DENSITIES {
                let cell = quad.blended(law().blend(x));
                let d = cell.damping(&u, &v);
                let exact = d.symmetric + d.skew;
                let h = 1e-7;
                for j in 0..8 {
                    let e = unit(j, h);
                    let fq = (cell.damping(&(u + e), &v).force - cell.damping(&(u - e), &v).force)
                        / (2.0 * h);
                    let fv = (cell.damping(&u, &(v + e)).force - cell.damping(&u, &(v - e)).force)
                        / (2.0 * h);
                    let scale = exact.amax().max(d.rate.amax() * 1e-3);
                    assert!(
                        (exact.column(j) - fq).amax() <= 1e-6 * scale,
                        "{kind:?} {x} ∂q {j}"
                    );
                    assert!((d.rate.column(j) - fv).amax() <= 1e-7 * d.rate.amax());
                }
                let k0 = quad.small_strain_stiffness();
                let at_rest = cell.damping(&Vector8::zeros(), &v).rate;
                assert!((at_rest - k0 * quad.material.beta).amax() <= 1e-12 * at_rest.amax());
            }
        }
    }

    /// Solid is the nonlinear cell bit for bit. Void is the linear cell: in the fixed
    /// frame `f = K₀ u`, `K = K₀`, energy `½ uᵀ K₀ u` at a strain where the nonlinear
    /// cell differs by far; co-rotated, `½ dᵀ K₀ d` of the co-rotated displacement, which
    /// at small strain and rotation is the linear cell's response to 1e-3.
    #[test]
    fn solid_is_the_nonlinear_cell_and_void_the_linear_one() {
        let u = strained(0.2);
        for kind in KINDS {
            let quad = Quad::new(corners(), steel(0.01), kind).unwrap();
            let solid = quad.blended(law().blend(1.0));
            assert_eq!(
                solid.internal_force_and_tangent(&u),
                quad.internal_force_and_tangent(&u)
            );
            assert_eq!(solid.strain_energy(&u), quad.strain_energy(&u));
            let void = law().blend(0.01);
            let fixed = quad.fixed_frame(void);
            let k0 = quad.small_strain_stiffness();
            let (f, k) = fixed.internal_force_and_tangent(&u);
            let linear = k0 * u;
            assert!((f - linear).amax() <= 1e-12 * linear.amax(), "{kind:?}");
            assert!((k - k0).amax() <= 1e-12 * k0.amax());
            let energy = 0.5 * u.dot(&linear);
            assert!((fixed.strain_energy(&u) - energy).abs() <= 1e-12 * energy);
            // The nonlinear cell's force at this strain is not the linear one.
            assert!((quad.internal_force(&u) - linear).amax() > 0.1 * linear.amax());
            let c = CoRotation::new(&quad, &u);
            let corotated = 0.5 * c.d.dot(&(k0 * c.d));
            let blended = quad.blended(void).strain_energy(&u);
            assert!((blended - corotated).abs() <= 1e-12 * corotated, "{kind:?}");
            assert_eq!(quad.blended(void).smallest_area_ratio(&u), 1.0);
            let small = strained(1e-4);
            let f = quad.blended(void).internal_force(&small);
            let linear = k0 * small;
            assert!(
                (f - linear).amax() <= 1e-3 * linear.amax(),
                "{kind:?} small"
            );
        }
    }

    /// A rigid rotation by θ: no force in a solid cell (objective). In the paper's fixed
    /// frame a void cell's linear energy is not objective: the linearized strain of
    /// `u = (R − I) X` is the uniform contraction `(cos θ − 1) I` (the `sin θ` part is an
    /// infinitesimal rotation, in `K₀`'s null space), so its force is `s(x_min) (1 − cos θ)
    /// K₀ (−X)` exactly: 1e-6 (SIMP p = 3 at x_min = 0.01) times `(1 − cos θ)` times the
    /// force of a unit strain of the solid. Co-rotated (a member's cells), none at any
    /// density, and a strained cell turned rigidly has its force turned with it.
    #[test]
    fn a_rotated_void_cell_has_a_spurious_force_in_the_fixed_frame_only() {
        let (x, material) = (corners(), steel(0.01));
        let unit_force = material.young * material.thickness * 0.1;
        let s_min = 0.01_f64.powi(3);
        let reference = Vector8::from_fn(|i, _| x[i / 2][i % 2]);
        let strain = strained(0.05);
        for kind in KINDS {
            let quad = Quad::new(x, material, kind).unwrap();
            let contraction = quad.small_strain_stiffness() * reference;
            // A unit uniform strain's force is of the order of E t times the cell's size.
            let unit = contraction.amax() / unit_force;
            assert!(unit > 0.3 && unit < 3.0, "{kind:?}: {unit}");
            for angle in [0.1, 1.0, std::f64::consts::PI] {
                let u = rotated(&x, angle);
                let solid = quad.blended(1.0).internal_force(&u);
                assert!(solid.amax() < 1e-12 * unit_force, "{kind:?} {angle}");
                let spurious = quad.fixed_frame(law().blend(0.01)).internal_force(&u) * s_min;
                let expected = contraction * (s_min * (angle.cos() - 1.0));
                let error = (spurious - expected).amax();
                assert!(error < 1e-9 * expected.amax(), "{kind:?} {angle}: {error}");
                let r = Rotation2::new(angle);
                for density in DENSITIES {
                    let cell = quad.blended(law().blend(density));
                    let f = cell.internal_force(&u);
                    assert!(f.amax() < 1e-12 * unit_force, "{kind:?} {angle} {density}");
                    // x = R (X + u): the force turns with the cell.
                    let turned = Vector8::from_fn(|i, _| {
                        let p = x[i / 2] + Vector2::new(strain[i / 2 * 2], strain[i / 2 * 2 + 1]);
                        (r * p - x[i / 2])[i % 2]
                    });
                    let (f0, f1) = (cell.internal_force(&strain), cell.internal_force(&turned));
                    let back = Vector8::from_fn(|i, _| {
                        let k = i / 2;
                        (r.inverse() * Vector2::new(f1[2 * k], f1[2 * k + 1]))[i % 2]
                    });
                    assert!(
                        (back - f0).amax() < 1e-10 * f0.amax(),
                        "{kind:?} {angle} {density}"
                    );
                }
            }
        }
    }
}
