//! Stresses of spatial beams and bars, and their mean over a motion: the criterion of a
//! `stress` response.
//!
//! A beam's strains `ε = [Γ; κ]` (one point per element, [`crate::spatial::beam`]) give at a
//! fibre `(y, z)` of its section ([`crate::spatial::section::Fibre`]) the normal stress of
//! the stretch and both bendings and the shear stress of the torsion,
//!
//! ```text
//! σ = E (Γ₁ + κ₂ z − κ₃ y),   τ = G κ₁ c,   σ_vM = √(σ² + 3τ²)
//! ```
//!
//! read with the solid material's `E`, `G` at any density (a density scales the section's
//! stiffness, not the stresses its strains make: Le et al. 2010). The transverse shear is
//! left out: it vanishes at the fibres where the bending peaks. A truss bar's stress is
//! `E (l − L)/L`, signed.
//!
//! The response condenses `x^q σ` (each element's density `x`, the relaxation `q`) over the
//! run's states (trapezoidal weights over `t_f`; one state for an equilibrium), the elements
//! (weights by length) and their fibres (equal weights) by the p-mean or KS mean of
//! [`crate::response::aggregation`]: never above the peak, growing towards it with `p`.

use nalgebra::Vector6;

/// What a stress-like response reads at an element's points.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Criterion {
    /// The von Mises stress at each fibre of a beam's section, a truss bar's axial stress
    /// (Pa).
    VonMises,
    /// The buckling ratio, compression over its bar's Euler load (dimensionless, one point
    /// per element; [`crate::spatial::element::Element::buckling`]).
    Buckling,
}

use crate::spatial::section::Fibre;

/// The von Mises stress at `fibre` of strains `eps = [Γ; κ]` in a material of moduli
/// `[E, G]` (Pa), and its derivative to the strains (zero where it vanishes: a p-mean's
/// power `σ^p`, `p ≥ 2`, is flat there).
pub(crate) fn von_mises(
    eps: &Vector6<f64>,
    fibre: &Fibre,
    [e, g]: [f64; 2],
) -> (f64, Vector6<f64>) {
    let sigma = e * (eps[0] + eps[4] * fibre.z - eps[5] * fibre.y);
    let tau = g * eps[3] * fibre.torsion;
    let stress = (sigma * sigma + 3.0 * tau * tau).sqrt();
    if stress == 0.0 {
        return (0.0, Vector6::zeros());
    }
    let (s, t) = (e * sigma / stress, 3.0 * g * fibre.torsion * tau / stress);
    let slope = Vector6::new(s, 0.0, 0.0, t, s * fibre.z, -s * fibre.y);
    (stress, slope)
}

/// The von Mises stress's rate at fixed strains as the fibre moves at `rate` (its `y'`,
/// `z'`, `c'`): `(σ E (κ₂ z' − κ₃ y') + 3 τ G κ₁ c')/σ_vm`, 0 where the stress is.
pub(crate) fn von_mises_rate(
    eps: &Vector6<f64>,
    fibre: &Fibre,
    rate: &Fibre,
    [e, g]: [f64; 2],
) -> f64 {
    let sigma = e * (eps[0] + eps[4] * fibre.z - eps[5] * fibre.y);
    let tau = g * eps[3] * fibre.torsion;
    let stress = (sigma * sigma + 3.0 * tau * tau).sqrt();
    if stress == 0.0 {
        return 0.0;
    }
    let moved = e * (eps[4] * rate.z - eps[5] * rate.y);
    (sigma * moved + 3.0 * tau * g * eps[3] * rate.torsion) / stress
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The derivative against central differences, and pure torsion's `√3 τ`.
    #[test]
    fn von_mises_and_its_derivative() {
        let fibre = Fibre {
            y: 0.02,
            z: -0.01,
            torsion: 0.015,
        };
        let moduli = [2.1e11, 8.1e10];
        let eps = Vector6::new(1e-4, 3e-5, -2e-5, 0.02, -0.03, 0.01);
        let (_, slope) = von_mises(&eps, &fibre, moduli);
        for i in 0..6 {
            let step = Vector6::from_fn(|r, _| if r == i { 1e-7 } else { 0.0 });
            let fd = (von_mises(&(eps + step), &fibre, moduli).0
                - von_mises(&(eps - step), &fibre, moduli).0)
                / 2e-7;
            assert!(
                (fd - slope[i]).abs() <= 1e-6 * slope.abs().max(),
                "{i}: {fd} {}",
                slope[i]
            );
        }
        let rate = Fibre {
            y: 0.3,
            z: -0.7,
            torsion: 0.5,
        };
        let moved = |by: f64| Fibre {
            y: fibre.y + by * rate.y,
            z: fibre.z + by * rate.z,
            torsion: fibre.torsion + by * rate.torsion,
        };
        let fd = (von_mises(&eps, &moved(1e-7), moduli).0
            - von_mises(&eps, &moved(-1e-7), moduli).0)
            / 2e-7;
        let exact = von_mises_rate(&eps, &fibre, &rate, moduli);
        assert!((fd - exact).abs() <= 1e-6 * exact.abs(), "{fd} {exact}");
        let twist = Vector6::new(0.0, 0.0, 0.0, 0.02, 0.0, 0.0);
        let (stress, _) = von_mises(&twist, &fibre, moduli);
        assert!((stress - 3f64.sqrt() * 8.1e10 * 0.02 * 0.015).abs() < 1e-6 * stress);
    }
}
