//! A spatial truss bar: two nodes' origins joined by an axial member, pin-ended.
//!
//! With `d = x_B − x_A`, `l = |d|`, `n = d/l` and its length `L` at the start, the strain
//! `ε = (l − L)/L` and its rate `ε̇ = nᵀ(u̇_B − u̇_A)/L` give the axial force
//! `N = EA (ε + β ε̇)` (Kelvin–Voigt) and the forces `f_B = −f_A = N n`; energy `½ EA L ε²`.
//! The exact tangent on B's position, the opposite on A's:
//!
//! ```text
//! ∂f_B/∂x_B = EA/L n nᵀ + N/l (I − n nᵀ) + β EA/(L l) n wᵀ (I − n nᵀ),   w = u̇_B − u̇_A
//! ∂f_B/∂u̇_B = β EA/L n nᵀ
//! ```
//!
//! Mass consistent with linear interpolation, `ρAL/6 [2I I; I 2I]`, on positions only; weight
//! `ρAL/2` at each end; Rayleigh's `α M`. A bar turns no node: a node only bars meet has
//! no rotation ([`crate::spatial::model::SpatialModel::add_truss`]).

use std::f64::consts::PI;

use nalgebra::{Matrix3, Vector3};

use crate::group::pair::{Pair, Stiffness};
use crate::group::Frame;
use crate::spatial::element::{consistent_mass, Derivatives, Element, Terms};
use crate::spatial::force::Local;
use crate::spatial::section::{Section, MAX_FIBRES};

/// A truss bar (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct Truss {
    /// Its name in the scene.
    pub name: String,
    /// Cross-section area `A` (m²), for volumes.
    pub area: f64,
    /// Axial stiffness `EA` (N).
    pub ea: f64,
    /// Mass per length `ρA` (kg/m).
    pub rho_a: f64,
    /// Rayleigh damping `C = α M + β K`: `α` (1/s), `β` (s).
    pub rayleigh: [f64; 2],
    /// Its length at the start `L` (m).
    pub length: f64,
    /// The solid material's Young's modulus `E` (Pa): its stress at any density.
    pub modulus: f64,
    /// The density its design variable gives it, 1 where none does (the stress's
    /// relaxation reads it).
    pub density: f64,
    /// The compressive strain `π² I_min/(A L²)` at which it buckles, pin-ended, of the
    /// solid section (`I_min` its smaller second moment).
    pub euler_strain: f64,
    pub(crate) pair: Pair,
}

impl Truss {
    /// The bar between nodes at `a` and `b` of `section` (its `EA`, `ρA` and Rayleigh
    /// coefficients); `None` where they coincide.
    pub(crate) fn new(
        name: &str,
        nodes: [usize; 2],
        a: &Vector3<f64>,
        b: &Vector3<f64>,
        section: &Section,
    ) -> Option<Self> {
        let length = (b - a).norm();
        (length.is_finite() && length > 0.0).then(|| Self {
            name: name.to_string(),
            area: section.area,
            ea: section.c_n[0],
            rho_a: section.rho_a,
            rayleigh: [section.alpha, section.beta],
            length,
            modulus: section.moduli[0],
            density: 1.0,
            euler_strain: PI * PI * section.c_m[1].min(section.c_m[2])
                / (section.moduli[0] * section.area * length * length),
            pair: Pair {
                nodes: [Some(nodes[0]), Some(nodes[1])],
                arms: [Vector3::zeros(); 2],
            },
        })
    }

    /// Its `EA` scaled by `stiffness` (its Kelvin–Voigt damping with it) and its mass by
    /// `mass` (its weight and `α M` damping with it): a density's `s(x)` and `m(x)`.
    pub(crate) fn scale(&mut self, stiffness: f64, mass: f64) {
        self.ea *= stiffness;
        self.rho_a *= mass;
    }

    /// `(n, l, ε)` at `q`.
    fn geometry(&self, q: &[f64]) -> (Vector3<f64>, f64, f64) {
        let [a, b] = self.nodes().map(|n| Frame::read(q, n).x);
        let d = b - a;
        let l = d.norm();
        (d / l, l, (l - self.length) / self.length)
    }

    /// A pair of forces `∓ n t` on A's and B's positions.
    fn along(n: &Vector3<f64>, t: f64) -> Local {
        let mut out = Local::zeros();
        out.fixed_rows_mut::<3>(0).copy_from(&(-n * t));
        out.fixed_rows_mut::<3>(6).copy_from(&(n * t));
        out
    }

    /// Writes `block` into a local matrix on B's position, its opposite on A's.
    fn on_positions(block: &Matrix3<f64>) -> Stiffness {
        let mut out = Stiffness::zeros();
        for (r, c, sign) in [(0, 0, 1.0), (0, 6, -1.0), (6, 0, -1.0), (6, 6, 1.0)] {
            out.fixed_view_mut::<3, 3>(r, c).copy_from(&(block * sign));
        }
        out
    }
}

impl Element for Truss {
    fn pair(&self) -> &Pair {
        &self.pair
    }

    fn terms(
        &self,
        q: &[f64],
        v: &[f64],
        vdot: Option<&[f64]>,
        g: &Vector3<f64>,
        tangent: Option<&mut Derivatives>,
    ) -> Terms {
        let (n, l, strain) = self.geometry(q);
        let rates = self.local(v);
        let w = rates.fixed_rows::<3>(6) - rates.fixed_rows::<3>(0);
        let [alpha, beta] = self.rayleigh;
        let axial = self.ea * (strain + beta * n.dot(&w) / self.length);
        let internal = Self::along(&n, axial);
        let mass = self.mass_matrix();
        let accelerations = vdot.map_or_else(Local::zeros, |a| self.local(a));
        let mut inertia = mass * (accelerations + rates * alpha);
        for side in 0..2 {
            let mut f = inertia.fixed_rows_mut::<3>(6 * side);
            f -= g * (0.5 * self.mass());
        }
        if let Some(out) = tangent {
            let (along, across) = (n * n.transpose(), Matrix3::identity() - n * n.transpose());
            let k = self.ea / self.length;
            let stiffness =
                along * k + across * (axial / l) + n * (w.transpose() * across) * (k * beta / l);
            out.stiffness = Self::on_positions(&stiffness);
            out.damping = Self::on_positions(&(along * (k * beta))) + mass * alpha;
        }
        Terms { internal, inertia }
    }

    fn mass_matrix(&self) -> Stiffness {
        consistent_mass(self.mass())
    }

    fn mass(&self) -> f64 {
        self.rho_a * self.length
    }

    fn strain_energy(&self, q: &[f64]) -> f64 {
        let (_, _, strain) = self.geometry(q);
        0.5 * self.ea * self.length * strain * strain
    }

    fn elastic_force(&self, q: &[f64]) -> Local {
        let (n, _, strain) = self.geometry(q);
        Self::along(&n, self.ea * strain)
    }

    fn length(&self) -> f64 {
        self.length
    }

    fn density(&self) -> f64 {
        self.density
    }

    /// Its axial stress `E (l − L)/L`, signed.
    fn stresses(&self, q: &[f64], out: &mut [f64; MAX_FIBRES]) -> usize {
        out[0] = self.modulus * self.geometry(q).2;
        1
    }

    fn stress_gradient(&self, q: &[f64], weights: &[f64]) -> Local {
        let (n, ..) = self.geometry(q);
        Self::along(&n, weights[0] * self.modulus / self.length)
    }

    /// `max(−ε, 0)/ε_E` (module docs of [`Element::buckling`]).
    fn buckling(&self, q: &[f64]) -> (f64, Local) {
        let (n, _, strain) = self.geometry(q);
        if strain >= 0.0 {
            return (0.0, Local::zeros());
        }
        let per = 1.0 / self.euler_strain;
        (-strain * per, Self::along(&n, -per / self.length))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spatial::section::Shape;
    use nalgebra::UnitQuaternion;

    /// `K` and `C` against central differences, the bar stretched, turned and damped.
    #[test]
    fn tangent_and_damping_against_differences() {
        let circle = Shape::SolidCircle { d: 0.01 }.geometry(0.3).unwrap();
        let section = Section::new(&circle, 2e11, 8e10, 7850.0).with_rayleigh(0.3, 1e-3);
        let (a, b) = (Vector3::new(0.1, 0.2, -0.1), Vector3::new(0.8, -0.3, 0.4));
        let bar = Truss::new("bar", [0, 1], &a, &b, &section).unwrap();
        let mut q = vec![0.0; 14];
        Frame::new(
            a + Vector3::new(0.01, 0.0, 0.02),
            UnitQuaternion::identity(),
        )
        .write(&mut q, 0);
        Frame::new(
            b - Vector3::new(0.0, 0.03, 0.01),
            UnitQuaternion::identity(),
        )
        .write(&mut q, 1);
        let v: Vec<f64> = (0..12).map(|i| ((i as f64) * 1.1).sin() * 5.0).collect();
        let vdot: Vec<f64> = (0..12).map(|i| ((i as f64) * 0.7).cos()).collect();
        crate::spatial::element::check_derivatives(&bar, &q, &v, &vdot, 1e-7);
    }
}
