//! The geometrically exact spatial beam (Simo–Reissner) on two nodes of `ℝ³ × SO(3)`,
//! integrated at one point.
//!
//! Each node carries the element's frame through a constant offset, `Λ = R E` (`E` the
//! element's axes `e₁` along the bar, `e₂, e₃` the section's, in the node's frame at the
//! start). With `d = x_B − x_A`, `pᵢ = Λᵢᵀ d` and the relative rotation `ψ = log(Λ_Aᵀ Λ_B)`,
//! the strains of the element of length `L` are
//!
//! ```text
//! Γ = (p_A + p_B)/(2L) − Γ₀          (axial and shear: the chord in the mean of the end frames)
//! κ = (ψ − ψ₀)/L                      (torsion and bending: a rotation of constant curvature)
//! W = L/2 (Γᵀ C_N Γ + κᵀ C_M κ)       (section.rs; Γ₀, ψ₀ their values at the start)
//! ```
//!
//! Both strains are unchanged by any rigid motion, so a rigid motion strains nothing at any
//! rotation. Linearized about a straight bar they are the reduced-integration Timoshenko
//! element's, with no shear locking; the shear stiffness carries MacNeal's residual bending
//! flexibility, `1/(κGA)_eff = 1/(κGA) + L²/(12 EI)`, which makes the element's linear
//! stiffness the exact one of a Timoshenko bar: one element per bar gives a cantilever's tip
//! deflection `PL³/3EI + PL/κGA` and rotation exactly.
//!
//! Variations on the element's rotations `a = E_Aᵀ δθ_A`, `b = E_Bᵀ δθ_B` (right-trivialized):
//!
//! ```text
//! δΓ = [p̃_A a + p̃_B b + (Λ_A + Λ_B)ᵀ (δx_B − δx_A)]/(2L)
//! δψ = T⁻¹(ψ) b − T⁻¹(−ψ) a          (so3.rs: T⁻¹(ψ) exp(−ψ̃) = T⁻¹(−ψ))
//! ```
//!
//! so `f = L Bᵀ σ`, `σ = [N; M] = C ε + β C ε̇` (Kelvin–Voigt), and the tangent
//! `K = L Bᵀ C B + G(σ) + L Bᵀ β C R(v)` is exact: `G` the derivative of `Bᵀ` at fixed
//! stresses, `R` of `B v` at fixed rates, both through `∂(T⁻¹(θ) w)/∂θ`.
//!
//! Inertia: the translational mass consistent with linear interpolation,
//! `ρAL/6 [2I I; I 2I]`, and half the element's rotary inertia at each end, a rigid body's
//! `J Ω̇ + Ω × JΩ` there; gravity as `ρAL/2` at each end; Rayleigh's `α M` on both.

use std::f64::consts::PI;

use nalgebra::{Matrix3, Rotation3, SMatrix, UnitQuaternion, Vector3, Vector6};

use crate::group::pair::{Pair, Stiffness};
use crate::group::so3::{hat, log, InverseTangent};
use crate::group::{six, split, Frame};
use crate::spatial::element::{consistent_mass, Derivatives, Element, Terms};
use crate::spatial::force::Local;
use crate::spatial::section::{Dimension, Section, MAX_FIBRES};
use crate::spatial::stress::{von_mises, von_mises_rate};

/// The strain–displacement matrix `B` on the twelve local unknowns.
type Strain = SMatrix<f64, 6, 12>;

/// A two-node spatial beam (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct Beam {
    /// Its name in the scene.
    pub name: String,
    /// Its section, scaled as the element sees it (MacNeal's shear stiffness included).
    pub section: Section,
    /// Its length at the start `L` (m).
    pub length: f64,
    /// The element's axes in each node's frame, `E_A` and `E_B`.
    pub(crate) offsets: [UnitQuaternion<f64>; 2],
    /// `Γ₀` and `ψ₀`: the strains' values at the start.
    pub(crate) reference: Vector6<f64>,
    pub(crate) pair: Pair,
    /// The density its design variable gives it, 1 where none does (the stresses'
    /// relaxation reads it).
    pub density: f64,
    /// The length of the bar it is part of (m), what its Euler load reads: its own unless
    /// [`Beam::set_bar_length`] gave another.
    pub bar_length: f64,
    /// The solid section's smaller second moment `min(I₂, I₃)` (m⁴).
    i_min: f64,
    /// `E_A`, `E_B` as matrices, kept with the offsets.
    axes: [Matrix3<f64>; 2],
    /// `κ₂GA, κ₃GA` as its section gives them, scaled with it: before MacNeal's flexibility.
    shear: [f64; 2],
}

/// What the element's state gives, in its own axes.
struct Kinematics {
    /// `Λ_A, Λ_B` in the inertial frame.
    frames: [Matrix3<f64>; 2],
    /// `p_A, p_B`.
    chord: [Vector3<f64>; 2],
    psi: Vector3<f64>,
    /// `T⁻¹(±ψ)`'s coefficients.
    inverse: InverseTangent,
    /// `T⁻¹(ψ)`, `T⁻¹(−ψ)`.
    tinv: [Matrix3<f64>; 2],
}

impl Beam {
    /// The element between nodes `a` and `b` at `frames` (their initial frames), its
    /// section's `e₂` axis the component of `up` across the bar, of `section` at full
    /// density; `None` where the nodes coincide or `up` lies along the bar.
    pub(crate) fn new(
        name: &str,
        nodes: [usize; 2],
        frames: [&Frame; 2],
        up: &Vector3<f64>,
        section: &Section,
    ) -> Option<Self> {
        let d = frames[1].x - frames[0].x;
        let length = d.norm();
        if !length.is_finite() || length <= 0.0 {
            return None;
        }
        let e1 = d / length;
        let across = up - e1 * e1.dot(up);
        if across.norm() <= 1e-9 * up.norm() || across.norm().is_nan() {
            return None;
        }
        let e2 = across.normalize();
        let axes = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(
            Matrix3::from_columns(&[e1, e2, e1.cross(&e2)]),
        ));
        let offsets = frames.map(|f| f.r.inverse() * axes);
        let mut section = *section;
        let shear = [section.c_n[1], section.c_n[2]];
        // MacNeal's residual bending flexibility: shear along e₂ bends about e₃, and so on.
        for (k, bending) in [(1, 2), (2, 1)] {
            let flexible = 1.0 / section.c_n[k] + length * length / (12.0 * section.c_m[bending]);
            section.c_n[k] = 1.0 / flexible;
        }
        let mut beam = Self {
            name: name.to_string(),
            section,
            length,
            offsets,
            reference: Vector6::zeros(),
            pair: Pair {
                nodes: [Some(nodes[0]), Some(nodes[1])],
                arms: [Vector3::zeros(); 2],
            },
            density: 1.0,
            bar_length: length,
            i_min: section.c_m[1].min(section.c_m[2]) / section.moduli[0],
            axes: offsets.map(|e| e.to_rotation_matrix().into_inner()),
            shear,
        };
        beam.reference = beam.measures(&beam.kinematics_of(frames[0], frames[1]));
        Some(beam)
    }

    /// Makes it part of a bar of `length` (m): what its Euler load reads.
    pub(crate) fn set_bar_length(&mut self, length: f64) {
        self.bar_length = length;
    }

    /// The compressive strain `π² I_min/(A L_b²)` at which its bar buckles pin-ended.
    pub(crate) fn euler_strain(&self) -> f64 {
        PI * PI * self.i_min / (self.section.area * self.bar_length.powi(2))
    }

    /// The buckling ratio's rate at fixed strains as its section's size moves at `rate`
    /// ([`Beam::section_rate`]): `∂ ln b = A'/A − I_min'/I_min`, the smaller moment's
    /// rate (of the first where the two are equal).
    pub(crate) fn buckling_log_rate(&self, rate: &Section) -> f64 {
        let c = &self.section.c_m;
        let smaller = if c[1] <= c[2] { 1 } else { 2 };
        rate.area / self.section.area - rate.c_m[smaller] / c[smaller]
    }

    /// Its section's stiffnesses scaled by `stiffness` (its Kelvin–Voigt damping with them)
    /// and its mass and rotary inertia by `mass` (its weight and `α M` damping with them): a
    /// density's `s(x)` and `m(x)` (paper Eq. 1).
    pub(crate) fn scale(&mut self, stiffness: f64, mass: f64) {
        let s = &mut self.section;
        s.c_n
            .iter_mut()
            .chain(&mut s.c_m)
            .for_each(|c| *c *= stiffness);
        s.rho_a *= mass;
        s.rho_i.iter_mut().for_each(|r| *r *= mass);
        self.shear.iter_mut().for_each(|c| *c *= stiffness);
    }

    /// The derivative of its section, as the element sees it (scaled, MacNeal's shear
    /// stiffness included), to a `dimension` of its shape: a [`Section`] whose stiffnesses,
    /// inertias, area and fibres are rates (N/m, kg/m², …), its damping and moduli as they
    /// are; `None` where its section has no shape or the shape no such dimension.
    ///
    /// Each stiffness and inertia is a material constant times the design's factor times a
    /// property of the shape, so its rate is itself times the property's relative rate;
    /// MacNeal's `1/c = 1/(κGA) + L²/(12 EI)` then gives
    /// `c' = c² ((κGA)'/(κGA)² + L² (EI)'/(12 (EI)²))`.
    pub(crate) fn section_rate(&self, dimension: Dimension) -> Option<Section> {
        let s = &self.section;
        let (g, r) = s.geometry_rate(dimension)?;
        let area = r.area / g.area;
        let bending = [r.i2 / g.i2, r.i3 / g.i3];
        let raw = [0, 1].map(|k| self.shear[k] * (r.shear[k] / g.shear[k] + area));
        let c_m = [
            s.c_m[0] * r.torsion / g.torsion,
            s.c_m[1] * bending[0],
            s.c_m[2] * bending[1],
        ];
        let l2 = self.length * self.length;
        // Shear along e₂ bends about e₃ and the other way round (`Beam::new`).
        let macneal = |k: usize, about: usize| {
            let c = s.c_n[k];
            c * c
                * (raw[k - 1] / self.shear[k - 1].powi(2)
                    + l2 * c_m[about] / (12.0 * s.c_m[about].powi(2)))
        };
        Some(Section {
            area: r.area,
            c_n: [s.c_n[0] * area, macneal(1, 2), macneal(2, 1)],
            c_m,
            rho_a: s.rho_a * area,
            rho_i: [
                s.rho_i[0] * (r.i2 + r.i3) / (g.i2 + g.i3),
                s.rho_i[1] * bending[0],
                s.rho_i[2] * bending[1],
            ],
            fibres: r.fibres,
            ..*s
        })
    }

    fn kinematics(&self, q: &[f64]) -> Kinematics {
        let [a, b] = self.nodes().map(|n| Frame::read(q, n));
        self.kinematics_of(&a, &b)
    }

    fn kinematics_of(&self, a: &Frame, b: &Frame) -> Kinematics {
        let (la, lb) = (a.r * self.offsets[0], b.r * self.offsets[1]);
        let psi = log(&(la.inverse() * lb));
        let inverse = InverseTangent::new(&psi);
        let frames = [la, lb].map(|r| r.to_rotation_matrix().into_inner());
        let d = b.x - a.x;
        Kinematics {
            frames,
            chord: frames.map(|f| f.transpose() * d),
            psi,
            inverse,
            tinv: [inverse.at(1.0), inverse.at(-1.0)],
        }
    }

    /// `[(p_A + p_B)/(2L); ψ]`, the strains before their reference is taken off.
    fn measures(&self, k: &Kinematics) -> Vector6<f64> {
        let g = (k.chord[0] + k.chord[1]) / (2.0 * self.length);
        Vector6::new(g.x, g.y, g.z, k.psi.x, k.psi.y, k.psi.z)
    }

    /// The strains `ε = [Γ; κ]` at `q`.
    fn strains(&self, k: &Kinematics) -> Vector6<f64> {
        let mut e = self.measures(k) - self.reference;
        e.fixed_rows_mut::<3>(3).scale_mut(1.0 / self.length);
        e
    }

    /// `∂r/∂p` at `(q, v, v̇)` under gravity `g` of a dimension whose section rate is
    /// `rate` ([`Beam::section_rate`]): the forces of an element with that section.
    pub(crate) fn section_load(
        &self,
        rate: &Section,
        q: &[f64],
        v: &[f64],
        vdot: &[f64],
        g: &Vector3<f64>,
    ) -> Local {
        let terms = self.terms_of(rate, q, v, Some(vdot), g, None);
        terms.internal + terms.inertia
    }

    /// The tangent `∂f/∂q` at `q` at rest (`rest` the zero velocities) of the element with
    /// `section`: with a section rate, the tangent's rate.
    pub(crate) fn tangent_of(&self, section: &Section, q: &[f64], rest: &[f64]) -> Stiffness {
        let mut d = Derivatives::zeros();
        self.terms_of(section, q, rest, None, &Vector3::zeros(), Some(&mut d));
        d.stiffness
    }

    /// `L/2 εᵀ C ε` at `q` with `section`'s `C`: with a section rate, the strain energy's
    /// explicit rate.
    pub(crate) fn strain_energy_of(&self, section: &Section, q: &[f64]) -> f64 {
        let e = self.strains(&self.kinematics(q));
        0.5 * self.length * e.dot(&Self::elasticity(section).component_mul(&e))
    }

    /// `½ vᵀ M v` with `section`'s inertias: with a section rate, the kinetic energy's
    /// explicit rate.
    pub(crate) fn kinetic_energy_of(&self, section: &Section, v: &[f64]) -> f64 {
        let local = self.local(v);
        0.5 * local.dot(&(self.mass_matrix_of(section) * local))
    }

    /// The von Mises stresses' rates at the section's fibres at `q`, the strains held, as
    /// the fibres move with a dimension whose section rate is `rate` (Pa per unit of it).
    pub(crate) fn stress_rates(
        &self,
        rate: &Section,
        q: &[f64],
        out: &mut [f64; MAX_FIBRES],
    ) -> usize {
        let eps = self.strains(&self.kinematics(q));
        let fibres = self.section.fibres.iter().zip(rate.fibres.iter());
        for (o, (fibre, moved)) in out.iter_mut().zip(fibres) {
            *o = von_mises_rate(&eps, fibre, moved, self.section.moduli);
        }
        self.section.fibres.len()
    }

    /// `diag(C_N, C_M)` of `section`.
    fn elasticity(section: &Section) -> Vector6<f64> {
        let [n, m] = [section.c_n, section.c_m];
        Vector6::new(n[0], n[1], n[2], m[0], m[1], m[2])
    }

    /// `B` on the element's unknowns `(δx_A, a, δx_B, b)` (module docs).
    fn strain_matrix(&self, k: &Kinematics) -> Strain {
        let l = self.length;
        let mean = (k.frames[0] + k.frames[1]).transpose() / (2.0 * l);
        let mut b = Strain::zeros();
        b.fixed_view_mut::<3, 3>(0, 0).copy_from(&-mean);
        b.fixed_view_mut::<3, 3>(0, 6).copy_from(&mean);
        b.fixed_view_mut::<3, 3>(0, 3)
            .copy_from(&(hat(&k.chord[0]) / (2.0 * l)));
        b.fixed_view_mut::<3, 3>(0, 9)
            .copy_from(&(hat(&k.chord[1]) / (2.0 * l)));
        b.fixed_view_mut::<3, 3>(3, 3).copy_from(&(-k.tinv[1] / l));
        b.fixed_view_mut::<3, 3>(3, 9).copy_from(&(k.tinv[0] / l));
        b
    }

    /// Adds `P G(σ) Pᵀ` to `out`: `G(σ)` the derivative of `L Bᵀ σ` at fixed `σ = [N; M]` on
    /// the element's unknowns, read on the nodes' (`P = diag(I, E_A, I, E_B)`, each 3 × 3
    /// block turned as it is added).
    fn add_geometric(&self, k: &Kinematics, sigma: &Vector6<f64>, out: &mut Stiffness) {
        let (n, m) = (
            sigma.fixed_rows::<3>(0).into_owned(),
            sigma.fixed_rows::<3>(3).into_owned(),
        );
        let nt = hat(&n);
        let [la, lb] = k.frames;
        let e = &self.axes;
        let mut add = |r: usize, c: usize, block: Matrix3<f64>| {
            let mut v = out.fixed_view_mut::<3, 3>(r, c);
            v += block;
        };
        // δψ = T⁻¹(ψ) b − T⁻¹(−ψ) a, and the moments' derivatives through it.
        let (dpos, dneg) = (
            k.inverse.derivative(1.0, &m),
            k.inverse.derivative(-1.0, &m),
        );
        // Each 3 × 3 block's rotation rows and columns (block 1 at A's, 3 at B's) are read in
        // the nodes' frames, `E_A`, `E_B` on either side; a block put with both signs is
        // turned once.
        // f_x = ∓ ½ (Λ_A + Λ_B) N.
        let (xa, xb) = (
            la * nt * (0.5 * e[0].transpose()),
            lb * nt * (0.5 * e[1].transpose()),
        );
        for (row, sign) in [(0, 1.0), (6, -1.0)] {
            add(row, 3, xa * sign);
            add(row, 9, xb * sign);
        }
        // f_a = ½ N × p_A − T⁻¹(ψ) M, f_b = ½ N × p_B + T⁻¹(−ψ) M.
        for (row, frame, chord) in [(3, la, k.chord[0]), (9, lb, k.chord[1])] {
            let e = e[row / 6];
            let across = e * nt * (0.5 * frame.transpose());
            add(row, 0, -across);
            add(row, 6, across);
            let mut diagonal = nt * hat(&chord) * 0.5;
            if row == 3 {
                diagonal += dpos * k.tinv[1];
            } else {
                diagonal -= dneg * k.tinv[0];
            }
            add(row, row, e * diagonal * e.transpose());
        }
        add(3, 9, e[0] * (-dpos * k.tinv[0]) * e[1].transpose());
        add(9, 3, e[1] * (dneg * k.tinv[1]) * e[0].transpose());
    }

    /// `L Bᵀ C B` (`B` on the nodes' unknowns, `C = diag(c)`) into `out`, block by block: the
    /// strains' rows `Γ` reach every column, `κ`'s only the rotations'.
    fn material(b: &Strain, c: &Vector6<f64>, l: f64, out: &mut Stiffness) {
        // `Γ`'s rows on each node's translations and rotations: `γᵢᵀ C γⱼ` block by block,
        // the blocks below the diagonal the transposes of those above.
        let gamma: [Matrix3<f64>; 4] =
            std::array::from_fn(|k| b.fixed_view::<3, 3>(0, 3 * k).into());
        let weighted = gamma.map(|g| Matrix3::from_fn(|r, col| c[r] * l * g[(r, col)]));
        for (i, g) in gamma.iter().enumerate() {
            for (j, w) in weighted.iter().enumerate().skip(i) {
                let block = g.tr_mul(w);
                out.fixed_view_mut::<3, 3>(3 * i, 3 * j).copy_from(&block);
                out.fixed_view_mut::<3, 3>(3 * j, 3 * i)
                    .copy_from(&block.transpose());
            }
        }
        for i in [3, 9] {
            let kappa_i = b.fixed_view::<3, 3>(3, i);
            let weighted = Matrix3::from_fn(|r, col| c[3 + r] * l * kappa_i[(r, col)]);
            for j in [3, 9] {
                let mut block = out.fixed_view_mut::<3, 3>(j, i);
                block += b.fixed_view::<3, 3>(3, j).transpose() * weighted;
            }
        }
    }

    /// `R(v)`: the derivative of `B v` at fixed rates `v` (element unknowns).
    fn rate_derivative(&self, k: &Kinematics, v: &Local) -> Strain {
        let l = self.length;
        let w = v.fixed_rows::<3>(6) - v.fixed_rows::<3>(0);
        let omega = [
            v.fixed_rows::<3>(3).into_owned(),
            v.fixed_rows::<3>(9).into_owned(),
        ];
        let mut r = Strain::zeros();
        for (side, rate) in omega.iter().enumerate() {
            let (frame, chord) = (k.frames[side], k.chord[side]);
            let turn = 3 + 6 * side;
            // −ω̃ δp, δp = p̃ θ + Λᵀ (δx_B − δx_A); and δ(Λᵀ w) = (Λᵀw)~ θ.
            let mut block = r.fixed_view_mut::<3, 3>(0, turn);
            block += (-hat(rate) * hat(&chord) + hat(&(frame.transpose() * w))) / (2.0 * l);
            let across = -hat(rate) * frame.transpose() / (2.0 * l);
            let mut xa = r.fixed_view_mut::<3, 3>(0, 0);
            xa -= across;
            let mut xb = r.fixed_view_mut::<3, 3>(0, 6);
            xb += across;
        }
        // κ̇ = [T⁻¹(ψ) ω_b − T⁻¹(−ψ) ω_a]/L.
        let d = (k.inverse.derivative(1.0, &omega[1]) + k.inverse.derivative(-1.0, &omega[0])) / l;
        r.fixed_view_mut::<3, 3>(3, 3).copy_from(&(-d * k.tinv[1]));
        r.fixed_view_mut::<3, 3>(3, 9).copy_from(&(d * k.tinv[0]));
        r
    }

    /// `B Pᵀ`, `P = diag(I, E_A, I, E_B)`: a matrix on the element's unknowns `y = Pᵀ y_node`
    /// read on the nodes' (its rotation columns turned).
    fn on_nodes(m: Strain, e: &[Matrix3<f64>; 2]) -> Strain {
        let mut out = m;
        for (side, e) in e.iter().enumerate() {
            let at = 6 * side + 3;
            let turned = m.fixed_view::<6, 3>(0, at) * e.transpose();
            out.fixed_view_mut::<6, 3>(0, at).copy_from(&turned);
        }
        out
    }

    /// The two ends' mass matrices' rotary blocks `J` in the nodes' frames of `section`
    /// (kg m²).
    fn rotary_inertia(&self, section: &Section) -> [Matrix3<f64>; 2] {
        let j = Matrix3::from_diagonal(&Vector3::from(section.rho_i)) * (0.5 * self.length);
        self.axes.map(|e| e * j * e.transpose())
    }

    /// `M w` on the twelve local unknowns, block by block (`M` as [`Element::mass_matrix`]
    /// of mass `mass`, `j` the ends' [`Beam::rotary_inertia`]).
    fn mass_times(mass: f64, j: &[Matrix3<f64>; 2], w: &Local) -> Local {
        let m = mass / 6.0;
        let (xa, xb) = (w.fixed_rows::<3>(0), w.fixed_rows::<3>(6));
        let mut out = Local::zeros();
        out.fixed_rows_mut::<3>(0).copy_from(&((xa * 2.0 + xb) * m));
        out.fixed_rows_mut::<3>(6).copy_from(&((xa + xb * 2.0) * m));
        for (side, j) in j.iter().enumerate() {
            let at = 6 * side + 3;
            out.fixed_rows_mut::<3>(at)
                .copy_from(&(j * w.fixed_rows::<3>(at)));
        }
        out
    }

    /// `M` of the element with `section` on the twelve local unknowns (module docs).
    pub(crate) fn mass_matrix_of(&self, section: &Section) -> Stiffness {
        let mut out = consistent_mass(section.rho_a * self.length);
        for (side, j) in self.rotary_inertia(section).iter().enumerate() {
            out.fixed_view_mut::<3, 3>(6 * side + 3, 6 * side + 3)
                .copy_from(j);
        }
        out
    }

    /// The forces at `(q, v, v̇)` (`None`: at rest) under gravity `g` of the element with
    /// `section` (module docs); their derivatives into `tangent` where given. Both are
    /// linear in the section's stiffnesses and inertias: with a [`Beam::section_rate`] they
    /// are the forces' rates to the dimension.
    fn terms_of(
        &self,
        section: &Section,
        q: &[f64],
        v: &[f64],
        vdot: Option<&[f64]>,
        g: &Vector3<f64>,
        tangent: Option<&mut Derivatives>,
    ) -> Terms {
        let k = self.kinematics(q);
        let e = &self.axes;
        let rates = self.local(v);
        let accelerations = vdot.map_or_else(Local::zeros, |a| self.local(a));
        let c = Self::elasticity(section);
        let (l, beta, alpha) = (self.length, section.beta, section.alpha);
        // `B` itself only where the tangent or Kelvin–Voigt's `B v` reads it.
        let b =
            (tangent.is_some() || beta != 0.0).then(|| Self::on_nodes(self.strain_matrix(&k), e));
        let strain_rates = b.as_ref().map_or_else(Vector6::zeros, |b| b * rates * beta);
        let sigma = c.component_mul(&(self.strains(&k) + strain_rates));
        let mass = section.rho_a * l;
        let j = self.rotary_inertia(section);
        let mut inertia = Self::mass_times(mass, &j, &(accelerations + rates * alpha));
        let spins = self.nodes().map(|n| split(&six(v, n)).1);
        for side in 0..2 {
            let mut f = inertia.fixed_rows_mut::<3>(6 * side);
            f -= g * (0.5 * mass);
            let mut moment = inertia.fixed_rows_mut::<3>(6 * side + 3);
            moment += spins[side].cross(&(j[side] * spins[side]));
        }
        if let (Some(out), Some(b)) = (tangent, b) {
            Self::material(&b, &c, l, &mut out.stiffness);
            (out.damping).zip_apply(&out.stiffness, |d, m| *d = m * beta);
            self.add_geometric(&k, &sigma, &mut out.stiffness);
            if beta > 0.0 {
                let cb = Strain::from_fn(|r, col| c[r] * b[(r, col)]);
                // Kelvin–Voigt's `B v` moves with the configuration too.
                let mut element_rates = rates;
                for (side, e) in e.iter().enumerate() {
                    let turned = e.transpose() * rates.fixed_rows::<3>(6 * side + 3);
                    element_rates
                        .fixed_rows_mut::<3>(6 * side + 3)
                        .copy_from(&turned);
                }
                let r = Self::on_nodes(self.rate_derivative(&k, &element_rates), e);
                out.stiffness += cb.transpose() * r * (l * beta);
            }
            if alpha != 0.0 {
                out.damping += self.mass_matrix_of(section) * alpha;
            }
            for side in 0..2 {
                let (w, j, at) = (spins[side], j[side], 6 * side + 3);
                let mut gyroscopic = out.damping.fixed_view_mut::<3, 3>(at, at);
                gyroscopic += hat(&w) * j - hat(&(j * w));
            }
        }
        Terms {
            internal: self.b_transpose_times(&k, &sigma) * l,
            inertia,
        }
    }

    /// `Bᵀ σ` on the nodes' unknowns block by block, `σ = [N; M]` (module docs): `∓(Λ_A +
    /// Λ_B) N/(2L)` on the ends' translations, `E_A (N × p_A/(2L) − T⁻¹(−ψ)ᵀ M/L)` and
    /// `E_B (N × p_B/(2L) + T⁻¹(ψ)ᵀ M/L)` on their rotations.
    fn b_transpose_times(&self, k: &Kinematics, sigma: &Vector6<f64>) -> Local {
        let l2 = 2.0 * self.length;
        let (n, m) = (
            sigma.fixed_rows::<3>(0).into_owned(),
            sigma.fixed_rows::<3>(3).into_owned(),
        );
        let along = (k.frames[0] + k.frames[1]) * n / l2;
        let turn = [
            self.axes[0] * (n.cross(&k.chord[0]) / l2 - k.tinv[1].tr_mul(&m) / self.length),
            self.axes[1] * (n.cross(&k.chord[1]) / l2 + k.tinv[0].tr_mul(&m) / self.length),
        ];
        let mut out = Local::zeros();
        out.fixed_rows_mut::<3>(0).copy_from(&-along);
        out.fixed_rows_mut::<3>(3).copy_from(&turn[0]);
        out.fixed_rows_mut::<3>(6).copy_from(&along);
        out.fixed_rows_mut::<3>(9).copy_from(&turn[1]);
        out
    }
}

impl Element for Beam {
    fn pair(&self) -> &Pair {
        &self.pair
    }

    /// The element's mass `ρAL` (kg).
    fn mass(&self) -> f64 {
        self.section.rho_a * self.length
    }

    /// `M` on the twelve local unknowns (module docs).
    fn mass_matrix(&self) -> Stiffness {
        self.mass_matrix_of(&self.section)
    }

    /// The forces at `(q, v, v̇)` (`None`: at rest) under gravity `g` (module docs); their
    /// derivatives into `tangent` where given.
    fn terms(
        &self,
        q: &[f64],
        v: &[f64],
        vdot: Option<&[f64]>,
        g: &Vector3<f64>,
        tangent: Option<&mut Derivatives>,
    ) -> Terms {
        self.terms_of(&self.section, q, v, vdot, g, tangent)
    }

    /// The elastic forces `L Bᵀ C ε` at `q`: the strain energy's derivative in the nodes'
    /// algebra.
    fn elastic_force(&self, q: &[f64]) -> Local {
        let k = self.kinematics(q);
        let sigma = Self::elasticity(&self.section).component_mul(&self.strains(&k));
        self.b_transpose_times(&k, &sigma) * self.length
    }

    /// Strain energy `L/2 εᵀ C ε` at `q` (J).
    fn strain_energy(&self, q: &[f64]) -> f64 {
        let e = self.strains(&self.kinematics(q));
        0.5 * self.length * e.dot(&Self::elasticity(&self.section).component_mul(&e))
    }

    fn length(&self) -> f64 {
        self.length
    }

    fn density(&self) -> f64 {
        self.density
    }

    /// The von Mises stresses at the section's fibres ([`crate::spatial::stress`]).
    fn stresses(&self, q: &[f64], out: &mut [f64; MAX_FIBRES]) -> usize {
        let eps = self.strains(&self.kinematics(q));
        let fibres = &self.section.fibres;
        for (o, fibre) in out.iter_mut().zip(fibres.iter()) {
            *o = von_mises(&eps, fibre, self.section.moduli).0;
        }
        fibres.len()
    }

    /// `Bᵀ Σ_k w_k ∂σ_k/∂ε`.
    fn stress_gradient(&self, q: &[f64], weights: &[f64]) -> Local {
        let k = self.kinematics(q);
        let eps = self.strains(&k);
        let slope: Vector6<f64> = (weights.iter())
            .zip(self.section.fibres.iter())
            .map(|(w, fibre)| von_mises(&eps, fibre, self.section.moduli).1 * *w)
            .sum();
        Self::on_nodes(self.strain_matrix(&k), &self.axes).transpose() * slope
    }

    /// `max(−Γ₁, 0)/ε_E` of the stretch `Γ₁` (module docs), `ε_E` from [`Beam::euler_strain`].
    fn buckling(&self, q: &[f64]) -> (f64, Local) {
        let k = self.kinematics(q);
        let stretch = self.strains(&k)[0];
        if stretch >= 0.0 {
            return (0.0, Local::zeros());
        }
        let per = 1.0 / self.euler_strain();
        let b = Self::on_nodes(self.strain_matrix(&k), &self.axes);
        (-stretch * per, -b.row(0).transpose() * per)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::group::so3::exp;
    use crate::spatial::section::Shape;
    use nalgebra::Matrix6;

    fn section() -> Section {
        let geometry = Shape::Rectangle { b: 0.03, h: 0.05 }.geometry(0.3).unwrap();
        Section::new(&geometry, 7.0e10, 2.7e10, 2700.0).with_rayleigh(0.8, 2e-3)
    }

    /// Two turned nodes, where the beam of [`beam_and_state`] starts.
    fn start() -> [Frame; 2] {
        [
            Frame::new(
                Vector3::new(0.1, -0.2, 0.3),
                exp(&Vector3::new(0.4, -0.2, 1.1)),
            ),
            Frame::new(
                Vector3::new(0.9, 0.3, 0.1),
                exp(&Vector3::new(-0.7, 0.5, 0.2)),
            ),
        ]
    }

    /// A beam between two turned nodes, and a state well away from its start: the ends
    /// turned by half a radian against each other, moving.
    fn beam_and_state() -> (Beam, Vec<f64>, Vec<f64>, Vec<f64>) {
        let [a, b] = start();
        let beam = Beam::new(
            "bar",
            [0, 1],
            [&a, &b],
            &Vector3::new(0.0, 0.3, 1.0),
            &section(),
        )
        .unwrap();
        let mut q = vec![0.0; 14];
        a.retract(&[0.01, 0.02, -0.01, 0.3, -0.1, 0.2])
            .write(&mut q, 0);
        b.retract(&[-0.02, 0.05, 0.03, -0.2, 0.4, 0.1])
            .write(&mut q, 1);
        let v = (0..12).map(|i| ((i as f64) * 1.3).sin() * 30.0).collect();
        let vdot = (0..12).map(|i| ((i as f64) * 0.7).cos() * 20.0).collect();
        (beam, q, v, vdot)
    }

    /// `K = ∂f/∂q` (right-trivialized) and `C = ∂f/∂v` against central differences, with
    /// Kelvin–Voigt and mass-proportional damping and the ends turned.
    #[test]
    fn tangent_and_damping_against_differences() {
        let (beam, q, v, vdot) = beam_and_state();
        crate::spatial::element::check_derivatives(&beam, &q, &v, &vdot, 1e-8);
    }

    /// A section size's rates — the forces (elastic, viscous, inertial, gyroscopic, weight),
    /// the strain and kinetic energies, the stresses at the moving fibres — against central
    /// differences of beams of the resized section, for every shape and dimension, a
    /// design's factors on it and MacNeal's shear stiffness included.
    #[test]
    fn section_rates_against_differences() {
        use crate::spatial::section::Dimension;
        fn tube(outer: f64, inner: f64) -> Shape {
            Shape::HollowCircle { outer, inner }
        }
        type Resized = fn(f64) -> Shape;
        let cases: [(Resized, f64, Dimension); 5] = [
            (|d| Shape::SolidCircle { d }, 0.04, Dimension::Diameter),
            (|o| tube(o, 0.03), 0.04, Dimension::Outer),
            (|i| tube(0.04, i), 0.03, Dimension::Inner),
            (|b| Shape::Rectangle { b, h: 0.05 }, 0.03, Dimension::Width),
            (|h| Shape::Rectangle { b: 0.03, h }, 0.05, Dimension::Height),
        ];
        let (_, q, v, vdot) = beam_and_state();
        let g = Vector3::new(0.0, -3.0, -9.81);
        let [a, b] = start();
        let beam_of = |shape: Shape| {
            let geometry = shape.geometry(0.3).unwrap();
            let section = Section::new(&geometry, 7.0e10, 7.0e10 / 2.6, 2700.0)
                .with_rayleigh(0.8, 2e-3)
                .with_shape(shape);
            let mut beam = Beam::new(
                "bar",
                [0, 1],
                [&a, &b],
                &Vector3::new(0.0, 0.3, 1.0),
                &section,
            )
            .unwrap();
            beam.scale(0.3, 0.5);
            beam
        };
        let step = 1e-6;
        for (shape, size, dimension) in cases {
            let beam = beam_of(shape(size));
            let rate = beam.section_rate(dimension).unwrap();
            let [up, down] = [step, -step].map(|by| beam_of(shape(size + by)));
            let load = |beam: &Beam| {
                let t = beam.terms(&q, &v, Some(&vdot), &g, None);
                t.internal + t.inertia
            };
            let fd = (load(&up) - load(&down)) / (2.0 * step);
            let exact = beam.section_load(&rate, &q, &v, &vdot, &g);
            assert!(
                (fd - exact).amax() <= 1e-6 * fd.amax(),
                "{dimension:?}: {}",
                (fd - exact).amax() / fd.amax()
            );
            let pairs = [
                (
                    (up.strain_energy(&q) - down.strain_energy(&q)) / (2.0 * step),
                    beam.strain_energy_of(&rate, &q),
                ),
                (
                    (up.kinetic_energy(&v) - down.kinetic_energy(&v)) / (2.0 * step),
                    beam.kinetic_energy_of(&rate, &v),
                ),
            ];
            for (fd, exact) in pairs {
                assert!(
                    (fd - exact).abs() <= 1e-6 * fd.abs(),
                    "{dimension:?}: {fd} {exact}"
                );
            }
            let stresses = |beam: &Beam| {
                let mut out = [0.0; MAX_FIBRES];
                let count = beam.stresses(&q, &mut out);
                (out, count)
            };
            let ((su, count), (sd, _)) = (stresses(&up), stresses(&down));
            let mut rates = [0.0; MAX_FIBRES];
            assert_eq!(beam.stress_rates(&rate, &q, &mut rates), count);
            for k in 0..count {
                let fd = (su[k] - sd[k]) / (2.0 * step);
                assert!(
                    (fd - rates[k]).abs() <= 1e-6 * su[k].abs() / size,
                    "{dimension:?} [{k}]: {fd} {}",
                    rates[k]
                );
            }
        }
    }

    /// A rigid motion — any rotation, any translation, any rigid velocity — changes no
    /// strain: the internal forces of a strained state turn with the motion (forces in
    /// space, moments in the nodes' frames), the viscous ones add nothing, to round-off.
    #[test]
    fn rigid_motion_strains_nothing() {
        let (beam, strained, _, _) = beam_and_state();
        let rest = beam.terms(&strained, &[0.0; 12], None, &Vector3::zeros(), None);
        let scale = rest.internal.amax();
        assert!(scale > 1e6, "the state is strained: {scale:e}");
        let turns = [
            (0.3, Vector3::x()),
            (2.9, Vector3::new(1.0, -2.0, 0.5)),
            (3.1, Vector3::z()),
        ];
        for (angle, axis) in turns {
            let turn = exp(&(axis.normalize() * angle));
            let (spin, drift) = (Vector3::new(2.0, -5.0, 1.0), Vector3::new(0.3, 0.1, -0.2));
            let (mut q, mut v) = (vec![0.0; 14], vec![0.0; 12]);
            for n in 0..2 {
                let f = Frame::read(&strained, n);
                let moved = Frame::new(turn * f.x + Vector3::new(4.0, -3.0, 7.0), turn * f.r);
                moved.write(&mut q, n);
                let u = drift + spin.cross(&moved.x);
                v[6 * n..6 * n + 3].copy_from_slice(u.as_slice());
                v[6 * n + 3..6 * n + 6].copy_from_slice((moved.r.inverse() * spin).as_slice());
            }
            let moved = beam.terms(&q, &v, None, &Vector3::zeros(), None).internal;
            for n in 0..2 {
                let f0 = turn * rest.internal.fixed_rows::<3>(6 * n).into_owned();
                let m0 = rest.internal.fixed_rows::<3>(6 * n + 3).into_owned();
                let df = (moved.fixed_rows::<3>(6 * n) - f0).amax();
                let dm = (moved.fixed_rows::<3>(6 * n + 3) - m0).amax();
                assert!(df.max(dm) < 1e-12 * scale, "{angle} rad: {df:e}, {dm:e}");
            }
        }
    }

    /// An unstrained element moved rigidly — its nodes placed at any rotation of the start,
    /// about random axes by angles up to 4π, and anywhere — has internal forces below 1e-12
    /// of a unit-strain force (`EA`, and `EI/L` for moments).
    #[test]
    fn rigid_placements_give_no_force() {
        let (beam, _, _, _) = beam_and_state();
        let start = start();
        let unit = beam.section.c_n[0].max(beam.section.c_m[1] / beam.length);
        let mut seed = 0.37_f64;
        let mut next = || {
            seed = (seed * 9301.0 + 0.49297).fract();
            seed
        };
        for _ in 0..50 {
            let axis = Vector3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize();
            let turn = exp(&(axis * (4.0 * std::f64::consts::PI * next())));
            let shift = Vector3::new(next(), next(), next()) * 100.0;
            let mut q = vec![0.0; 14];
            for (n, f) in start.iter().enumerate() {
                Frame::new(turn * f.x + shift, turn * f.r).write(&mut q, n);
            }
            let f = beam
                .terms(&q, &[0.0; 12], None, &Vector3::zeros(), None)
                .internal;
            assert!(f.amax() < 1e-12 * unit, "{:e} of {unit:e}", f.amax());
        }
    }

    /// Linearized at the start, one element is the exact Timoshenko cantilever: a tip force
    /// across the bar deflects it by `PL³/3EI + PL/κGA` and turns it by `PL²/2EI`, in either
    /// plane; an axial force stretches it by `PL/EA`, a torque twists it by `TL/GJ`.
    #[test]
    fn one_element_is_the_exact_linear_cantilever() {
        let geometry = Shape::Rectangle { b: 0.03, h: 0.05 }.geometry(0.3).unwrap();
        let section = Section::new(&geometry, 7.0e10, 2.7e10, 2700.0);
        let length = 0.7;
        let root = Frame::new(Vector3::zeros(), exp(&Vector3::new(0.2, 0.4, -0.3)));
        let tip = Frame::new(
            Vector3::new(0.3, 0.5, length * length - 0.34).normalize() * length,
            exp(&Vector3::new(-1.0, 0.3, 0.2)),
        );
        let beam = Beam::new(
            "bar",
            [0, 1],
            [&root, &tip],
            &Vector3::new(0.0, 0.0, 1.0),
            &section,
        )
        .unwrap();
        let mut q = vec![0.0; 14];
        root.write(&mut q, 0);
        tip.write(&mut q, 1);
        let mut d = Derivatives::zeros();
        beam.terms(&q, &[0.0; 12], None, &Vector3::zeros(), Some(&mut d));
        let k = d.stiffness;
        let k_tip: Matrix6<f64> = k.fixed_view::<6, 6>(6, 6).into_owned();
        let flexibility = k_tip.try_inverse().unwrap();
        // The tip's unknowns in the element's axes: (δx in space, δθ in the tip's frame).
        let axes = (tip.r * beam.offsets[1]).to_rotation_matrix().into_inner();
        let e = beam.offsets[1].to_rotation_matrix().into_inner();
        let load = |force: Vector3<f64>, moment: Vector3<f64>| {
            let mut f = Vector6::zeros();
            f.fixed_rows_mut::<3>(0).copy_from(&(axes * force));
            f.fixed_rows_mut::<3>(3).copy_from(&(e * moment));
            let u = flexibility * f;
            (
                axes.transpose() * u.fixed_rows::<3>(0),
                e.transpose() * u.fixed_rows::<3>(3),
            )
        };
        let [ea, ga2, ga3] = [section.c_n[0], section.c_n[1], section.c_n[2]];
        let [gj, ei2, ei3] = section.c_m;
        let close = |a: f64, b: f64| assert!((a / b - 1.0).abs() < 1e-9, "{a} against {b}");
        let (u, _) = load(Vector3::x(), Vector3::zeros());
        close(u.x, length / ea);
        let (_, t) = load(Vector3::zeros(), Vector3::x());
        close(t.x, length / gj);
        let (u, t) = load(Vector3::y(), Vector3::zeros());
        close(u.y, length.powi(3) / (3.0 * ei3) + length / ga2);
        close(t.z, length * length / (2.0 * ei3));
        let (u, t) = load(Vector3::z(), Vector3::zeros());
        close(u.z, length.powi(3) / (3.0 * ei2) + length / ga3);
        close(-t.y, length * length / (2.0 * ei2));
    }
}
