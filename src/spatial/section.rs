//! A spatial beam's cross-section and material: the per-length stiffnesses and inertias of
//! a geometrically exact beam, in the section's axes `e₂, e₃` (the beam's axis is `e₁`).
//!
//! ```text
//! C_N = diag(EA, κ₂GA, κ₃GA)         (axial, shear along e₂ and e₃; N)
//! C_M = diag(GJ, EI₂, EI₃)           (torsion, bending about e₂ and e₃; N m²)
//! ρ A,  ρ diag(I₂ + I₃, I₂, I₃)       (mass and rotary inertia per length; kg/m, kg m)
//! ```
//!
//! `I₂ = ∫ x₃² dA` and `I₃ = ∫ x₂² dA` are the second moments about `e₂` and `e₃`, `J` the
//! torsion constant (the polar moment for a circle, less for a rectangle), `κ` Cowper's
//! shear coefficients. Units SI.
//!
//! A section also names the points where its stresses are read ([`Fibre`]): the solid and
//! hollow circles' outer edge every 45°, where bending about any axis peaks and the torsion's
//! shear `τ = T r/J` is largest; a rectangle's corners, where biaxial bending peaks and the
//! torsion's shear vanishes, and the middles of its long sides (all four of a square's),
//! where the torsion's shear peaks at Roark's
//! `τ_max = 3T/(8ab²) (1 + 0.6095 r + 0.8865 r² − 1.8023 r³ + 0.9100 r⁴)`, `2a ≥ 2b` the
//! sides, `r = b/a` (Roark's *Formulas for Stress and Strain*, table 10.7; within 1 %).

use std::f64::consts::PI;

/// The shape of a section, with the formulas of its properties.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// A solid circle of diameter `d` (m).
    SolidCircle {
        /// Diameter (m).
        d: f64,
    },
    /// A tube of outer and inner diameters (m).
    HollowCircle {
        /// Outer diameter (m).
        outer: f64,
        /// Inner diameter (m), less than the outer.
        inner: f64,
    },
    /// A rectangle `b` wide along `e₂` and `h` high along `e₃` (m).
    Rectangle {
        /// Width along `e₂` (m).
        b: f64,
        /// Height along `e₃` (m).
        h: f64,
    },
}

/// The most points a section's stresses are read at.
pub const MAX_FIBRES: usize = 8;

/// A point of a section where its stresses are read: `σ = E (Γ₁ + κ₂ z − κ₃ y)` from the
/// stretch and the bending, `τ = G κ₁ c` from the torsion.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Fibre {
    /// Its coordinate along `e₂` (m).
    pub y: f64,
    /// Its coordinate along `e₃` (m).
    pub z: f64,
    /// `c`, the torsion's shear stress there per `G κ₁` (m): a circle's radius.
    pub torsion: f64,
}

/// The points of a section where its stresses are read (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fibres {
    points: [Fibre; MAX_FIBRES],
    count: usize,
}

impl Fibres {
    fn new(points: &[Fibre]) -> Self {
        let mut all = [Fibre::default(); MAX_FIBRES];
        all[..points.len()].copy_from_slice(points);
        Self {
            points: all,
            count: points.len(),
        }
    }

    /// A circle's edge of radius `r` every 45°, its torsion's shear `G κ₁ r` there.
    fn circle(r: f64) -> Self {
        let at = |k: usize| {
            let phi = k as f64 * PI / 4.0;
            Fibre {
                y: r * phi.cos(),
                z: r * phi.sin(),
                torsion: r,
            }
        };
        Self::new(&std::array::from_fn::<_, MAX_FIBRES, _>(at))
    }

    /// A rectangle `b` along `e₂` by `h` along `e₃` of torsion constant `j`: its corners
    /// and the middles of its long sides (module docs).
    fn rectangle(b: f64, h: f64, j: f64) -> Self {
        let (a, t) = (0.5 * b.max(h), 0.5 * b.min(h));
        let r = t / a;
        // τ_max = T c / J with T = G J κ₁: c = J τ_max / T.
        let c = j * 3.0 / (8.0 * a * t * t)
            * (1.0 + 0.6095 * r + 0.8865 * r.powi(2) - 1.8023 * r.powi(3) + 0.91 * r.powi(4));
        let corner = |sy: f64, sz: f64| Fibre {
            y: sy * 0.5 * b,
            z: sz * 0.5 * h,
            torsion: 0.0,
        };
        let mut points = vec![
            corner(1.0, 1.0),
            corner(-1.0, 1.0),
            corner(-1.0, -1.0),
            corner(1.0, -1.0),
        ];
        let middle = |y: f64, z: f64| Fibre { y, z, torsion: c };
        if h >= b {
            points.extend([middle(0.5 * b, 0.0), middle(-0.5 * b, 0.0)]);
        }
        if b >= h {
            points.extend([middle(0.0, 0.5 * h), middle(0.0, -0.5 * h)]);
        }
        Self::new(&points)
    }

    /// The points.
    pub fn iter(&self) -> impl Iterator<Item = &Fibre> {
        self.points[..self.count].iter()
    }

    /// How many there are.
    pub fn len(&self) -> usize {
        self.count
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }
}

/// A section's geometry: area, second moments, torsion constant, shear coefficients, the
/// points its stresses are read at.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Geometry {
    /// Area `A` (m²).
    pub area: f64,
    /// `I₂ = ∫ x₃² dA` (m⁴), bending about `e₂`.
    pub i2: f64,
    /// `I₃ = ∫ x₂² dA` (m⁴), bending about `e₃`.
    pub i3: f64,
    /// Torsion constant `J` (m⁴).
    pub torsion: f64,
    /// Shear coefficients `κ₂, κ₃` (shear along `e₂`, along `e₃`).
    pub shear: [f64; 2],
    /// Where its stresses are read.
    pub fibres: Fibres,
}

impl Shape {
    /// The shape's geometry for Poisson's ratio `nu` (Cowper's shear coefficients depend on
    /// it); `None` where a dimension is not positive and finite or a tube has no wall.
    pub fn geometry(&self, nu: f64) -> Option<Geometry> {
        match *self {
            Shape::SolidCircle { d } => {
                positive(&[d])?;
                let kappa = 6.0 * (1.0 + nu) / (7.0 + 6.0 * nu);
                let i = PI * d.powi(4) / 64.0;
                Some(Geometry {
                    area: PI * d * d / 4.0,
                    i2: i,
                    i3: i,
                    torsion: 2.0 * i,
                    shear: [kappa; 2],
                    fibres: Fibres::circle(0.5 * d),
                })
            }
            Shape::HollowCircle { outer, inner } => {
                positive(&[outer, inner])?;
                (inner < outer).then_some(())?;
                let m2 = (inner / outer).powi(2);
                let kappa = 6.0 * (1.0 + nu) * (1.0 + m2).powi(2)
                    / ((7.0 + 6.0 * nu) * (1.0 + m2).powi(2) + (20.0 + 12.0 * nu) * m2);
                let i = PI * (outer.powi(4) - inner.powi(4)) / 64.0;
                Some(Geometry {
                    area: PI * (outer * outer - inner * inner) / 4.0,
                    i2: i,
                    i3: i,
                    torsion: 2.0 * i,
                    shear: [kappa; 2],
                    fibres: Fibres::circle(0.5 * outer),
                })
            }
            Shape::Rectangle { b, h } => {
                positive(&[b, h])?;
                let kappa = 10.0 * (1.0 + nu) / (12.0 + 11.0 * nu);
                // Saint-Venant's torsion constant, Roark's fit (under 0.5 % off):
                // J = a t³ (1/3 − 0.21 (t/a)(1 − t⁴/(12 a⁴))), a ≥ t the long and short sides.
                let (a, t) = (b.max(h), b.min(h));
                let r = t / a;
                let torsion = a * t.powi(3) * (1.0 / 3.0 - 0.21 * r * (1.0 - r.powi(4) / 12.0));
                Some(Geometry {
                    area: b * h,
                    i2: b * h.powi(3) / 12.0,
                    i3: h * b.powi(3) / 12.0,
                    torsion,
                    shear: [kappa; 2],
                    fibres: Fibres::rectangle(b, h, torsion),
                })
            }
        }
    }
}

/// A dimension of a section's shape, by the name a scene gives it: what a section-size
/// parameter moves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dimension {
    /// A solid circle's diameter.
    Diameter,
    /// A tube's outer diameter.
    Outer,
    /// A tube's inner diameter.
    Inner,
    /// A rectangle's width along `e₂`.
    Width,
    /// A rectangle's height along `e₃`.
    Height,
}

impl Dimension {
    /// Every dimension with its name in a scene.
    pub const NAMES: [(&'static str, Dimension); 5] = [
        ("diameter", Dimension::Diameter),
        ("outer", Dimension::Outer),
        ("inner", Dimension::Inner),
        ("width", Dimension::Width),
        ("height", Dimension::Height),
    ];
}

impl Shape {
    /// The derivative of [`Shape::geometry`] to `dimension`, as a [`Geometry`] of rates (m,
    /// m³, …; each fibre's `y'`, `z'`, `c'` in the same order); `None` where the shape has no
    /// such dimension or no geometry. A rectangle's torsion constant and peak shear follow
    /// its longer side as `a`: at a square (`b = h`) the rate is the one of `b` as the longer.
    pub fn rate(&self, nu: f64, dimension: Dimension) -> Option<Geometry> {
        let geometry = self.geometry(nu)?;
        let scaled = |fibres: &Fibres, by: [f64; 3]| {
            let mut out = *fibres;
            for f in &mut out.points[..out.count] {
                *f = Fibre {
                    y: f.y * by[0],
                    z: f.z * by[1],
                    torsion: f.torsion * by[2],
                };
            }
            out
        };
        match (*self, dimension) {
            (Shape::SolidCircle { d }, Dimension::Diameter) => {
                let i = PI * d.powi(3) / 16.0;
                Some(Geometry {
                    area: PI * d / 2.0,
                    i2: i,
                    i3: i,
                    torsion: 2.0 * i,
                    shear: [0.0; 2],
                    fibres: scaled(&geometry.fibres, [1.0 / d; 3]),
                })
            }
            (Shape::HollowCircle { outer, inner }, Dimension::Outer | Dimension::Inner) => {
                let is_outer = dimension == Dimension::Outer;
                let (side, sign) = if is_outer {
                    (outer, 1.0)
                } else {
                    (inner, -1.0)
                };
                // κ(m²), m² = (inner/outer)²: κ = N/D as in `geometry`.
                let m2 = (inner / outer).powi(2);
                let u = (1.0 + m2).powi(2);
                let (n, d) = (
                    6.0 * (1.0 + nu) * u,
                    (7.0 + 6.0 * nu) * u + (20.0 + 12.0 * nu) * m2,
                );
                let (dn, dd) = (
                    12.0 * (1.0 + nu) * (1.0 + m2),
                    2.0 * (7.0 + 6.0 * nu) * (1.0 + m2) + 20.0 + 12.0 * nu,
                );
                let dm2 = if is_outer {
                    -2.0 * inner * inner / outer.powi(3)
                } else {
                    2.0 * inner / (outer * outer)
                };
                let kappa = (dn * d - n * dd) / (d * d) * dm2;
                let i = sign * PI * side.powi(3) / 16.0;
                let moves = if is_outer { 1.0 / outer } else { 0.0 };
                Some(Geometry {
                    area: sign * PI * side / 2.0,
                    i2: i,
                    i3: i,
                    torsion: 2.0 * i,
                    shear: [kappa; 2],
                    fibres: scaled(&geometry.fibres, [moves; 3]),
                })
            }
            (Shape::Rectangle { b, h }, Dimension::Width | Dimension::Height) => {
                let width = dimension == Dimension::Width;
                let (a, t) = (b.max(h), b.min(h));
                // Which of the long side `a` and the short `t` the dimension is.
                let along_a = width == (b >= h);
                let (da, dt) = if along_a { (1.0, 0.0) } else { (0.0, 1.0) };
                // J = a t³/3 − 0.21 t⁴ + 0.0175 t⁸/a⁴ (`geometry`'s fit).
                let torsion = da * (t.powi(3) / 3.0 - 0.07 * t.powi(8) / a.powi(5))
                    + dt * (a * t * t - 0.84 * t.powi(3) + 0.14 * t.powi(7) / a.powi(4));
                // The long sides' middles: c = 3 J P(r)/(a t²), r = t/a.
                let r = t / a;
                let p =
                    1.0 + 0.6095 * r + 0.8865 * r.powi(2) - 1.8023 * r.powi(3) + 0.91 * r.powi(4);
                let dp = 0.6095 + 1.773 * r - 5.4069 * r.powi(2) + 3.64 * r.powi(3);
                let dr = dt / a - da * t / (a * a);
                let c_rate = torsion / geometry.torsion - da / a - 2.0 * dt / t + dp * dr / p;
                let (by_y, by_z) = if width {
                    (1.0 / b, 0.0)
                } else {
                    (0.0, 1.0 / h)
                };
                Some(Geometry {
                    area: if width { h } else { b },
                    i2: if width {
                        h.powi(3) / 12.0
                    } else {
                        b * h * h / 4.0
                    },
                    i3: if width {
                        h * b * b / 4.0
                    } else {
                        b.powi(3) / 12.0
                    },
                    torsion,
                    shear: [0.0; 2],
                    fibres: scaled(&geometry.fibres, [by_y, by_z, c_rate]),
                })
            }
            _ => None,
        }
    }
}

fn positive(values: &[f64]) -> Option<()> {
    values
        .iter()
        .all(|v| v.is_finite() && *v > 0.0)
        .then_some(())
}

/// A beam's section at full density: what the element reads (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Section {
    /// Area `A` (m²), for volumes.
    pub area: f64,
    /// `diag C_N = (EA, κ₂GA, κ₃GA)` (N).
    pub c_n: [f64; 3],
    /// `diag C_M = (GJ, EI₂, EI₃)` (N m²).
    pub c_m: [f64; 3],
    /// Mass per length `ρA` (kg/m).
    pub rho_a: f64,
    /// Rotary inertia per length `ρ (I₂ + I₃, I₂, I₃)` (kg m).
    pub rho_i: [f64; 3],
    /// Rayleigh damping `C = α M + β K`: `α` (1/s).
    pub alpha: f64,
    /// `β` (s): Kelvin–Voigt damping of the strains.
    pub beta: f64,
    /// The solid material's Young's and shear moduli `E`, `G` (Pa): what its stresses are
    /// read with at any density.
    pub moduli: [f64; 2],
    /// Where its stresses are read.
    pub fibres: Fibres,
    /// The shape it was made of, where a scene gave one: what its size parameters move.
    pub shape: Option<Shape>,
}

impl Section {
    /// The section of `geometry` in a material of Young's modulus `e` (Pa), shear modulus
    /// `g` (Pa) and density `rho` (kg/m³), undamped.
    pub fn new(geometry: &Geometry, e: f64, g: f64, rho: f64) -> Self {
        let Geometry {
            area,
            i2,
            i3,
            torsion,
            shear,
            fibres,
        } = *geometry;
        Self {
            area,
            c_n: [e * area, shear[0] * g * area, shear[1] * g * area],
            c_m: [g * torsion, e * i2, e * i3],
            rho_a: rho * area,
            rho_i: [rho * (i2 + i3), rho * i2, rho * i3],
            alpha: 0.0,
            beta: 0.0,
            moduli: [e, g],
            fibres,
            shape: None,
        }
    }

    /// Its shape's geometry at full density and that geometry's rate to `dimension`
    /// (Poisson's ratio from the moduli); `None` where it has no shape or the shape no such
    /// dimension.
    pub fn geometry_rate(&self, dimension: Dimension) -> Option<(Geometry, Geometry)> {
        let shape = self.shape?;
        let nu = self.moduli[0] / (2.0 * self.moduli[1]) - 1.0;
        Some((shape.geometry(nu)?, shape.rate(nu, dimension)?))
    }

    /// How far the section reaches from the beam's axis, for drawing it (m): a circle's or
    /// a tube's outer radius, half a rectangle's larger side; without a shape, the radius
    /// of the circle of its area.
    pub fn outer_radius(&self) -> f64 {
        match self.shape {
            Some(Shape::SolidCircle { d }) => 0.5 * d,
            Some(Shape::HollowCircle { outer, .. }) => 0.5 * outer,
            Some(Shape::Rectangle { b, h }) => 0.5 * b.max(h),
            None => (self.area / std::f64::consts::PI).sqrt(),
        }
    }

    /// The section made of `shape` (its size parameters move it).
    pub fn with_shape(self, shape: Shape) -> Self {
        Self {
            shape: Some(shape),
            ..self
        }
    }

    /// The section damped by `C = α M + β K` (`α` in 1/s, `β` in s).
    pub fn with_rayleigh(self, alpha: f64, beta: f64) -> Self {
        Self {
            alpha,
            beta,
            ..self
        }
    }

    /// What no beam has: a stiffness or inertia that is not positive and finite, damping
    /// that is negative or not finite; named for the message.
    pub fn implausible(&self) -> Option<&'static str> {
        let positive = |v: &[f64]| v.iter().all(|x| x.is_finite() && *x > 0.0);
        if !positive(&[self.area]) {
            Some("area")
        } else if !positive(&self.c_n) {
            Some("axial and shear stiffnesses (EA, κGA)")
        } else if !positive(&self.c_m) {
            Some("torsion and bending stiffnesses (GJ, EI)")
        } else if !positive(&[self.rho_a]) || !positive(&self.rho_i) {
            Some("mass and rotary inertia (ρA, ρI)")
        } else if !(self.alpha.is_finite() && self.alpha >= 0.0) {
            Some("Rayleigh α")
        } else if !(self.beta.is_finite() && self.beta >= 0.0) {
            Some("Rayleigh β")
        } else {
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A thin tube's properties tend to the thin-walled ones (`A = π d t`, `I = π d³ t/8`,
    /// `J = 2I`, Cowper's `κ = 2(1+ν)/(4+3ν)`), a square's torsion constant is `0.1406 a⁴` (Saint-Venant), a
    /// solid circle's shear coefficient `6(1+ν)/(7+6ν)`.
    #[test]
    fn shapes_have_their_textbook_properties() {
        let (d, t) = (0.1, 1e-5);
        let tube = Shape::HollowCircle {
            outer: d + t,
            inner: d - t,
        }
        .geometry(0.3)
        .unwrap();
        let thin_area = PI * d * t;
        assert!((tube.area / thin_area - 1.0).abs() < 1e-9);
        assert!((tube.i2 / (PI * d.powi(3) * t / 8.0) - 1.0).abs() < 1e-8);
        assert_eq!(tube.torsion, 2.0 * tube.i3);
        assert!(
            (tube.shear[0] - 2.6 / 4.9).abs() < 1e-6,
            "{}",
            tube.shear[0]
        );
        let square = Shape::Rectangle { b: 2.0, h: 2.0 }.geometry(0.3).unwrap();
        assert!((square.torsion / (0.1406 * 16.0) - 1.0).abs() < 5e-3);
        assert_eq!(square.i2, square.i3);
        let flat = Shape::Rectangle { b: 4.0, h: 1.0 }.geometry(0.0).unwrap();
        assert_eq!((flat.i2, flat.i3), (4.0 / 12.0, 64.0 / 12.0));
        let circle = Shape::SolidCircle { d: 1.0 }.geometry(0.5).unwrap();
        assert!((circle.shear[1] - 9.0 / 10.0).abs() < 1e-15);
        assert!(Shape::HollowCircle {
            outer: 1.0,
            inner: 1.0
        }
        .geometry(0.3)
        .is_none());
        assert!(Shape::Rectangle {
            b: f64::NAN,
            h: 1.0
        }
        .geometry(0.3)
        .is_none());
    }

    /// Every shape's geometry rate against central differences of its geometry, each
    /// dimension, a rectangle standing and lying; fibres in the same order.
    #[test]
    fn geometry_rates_against_differences() {
        let cases = [
            (Shape::SolidCircle { d: 0.03 }, Dimension::Diameter),
            (
                Shape::HollowCircle {
                    outer: 0.05,
                    inner: 0.04,
                },
                Dimension::Outer,
            ),
            (
                Shape::HollowCircle {
                    outer: 0.05,
                    inner: 0.04,
                },
                Dimension::Inner,
            ),
            (Shape::Rectangle { b: 0.02, h: 0.05 }, Dimension::Width),
            (Shape::Rectangle { b: 0.02, h: 0.05 }, Dimension::Height),
            (Shape::Rectangle { b: 0.06, h: 0.01 }, Dimension::Width),
            (Shape::Rectangle { b: 0.06, h: 0.01 }, Dimension::Height),
        ];
        let moved = |shape: Shape, dimension: Dimension, by: f64| match (shape, dimension) {
            (Shape::SolidCircle { d }, _) => Shape::SolidCircle { d: d + by },
            (Shape::HollowCircle { outer, inner }, Dimension::Outer) => Shape::HollowCircle {
                outer: outer + by,
                inner,
            },
            (Shape::HollowCircle { outer, inner }, _) => Shape::HollowCircle {
                outer,
                inner: inner + by,
            },
            (Shape::Rectangle { b, h }, Dimension::Width) => Shape::Rectangle { b: b + by, h },
            (Shape::Rectangle { b, h }, _) => Shape::Rectangle { b, h: h + by },
        };
        let flat = |g: &Geometry| -> Vec<f64> {
            let mut v = vec![g.area, g.i2, g.i3, g.torsion, g.shear[0], g.shear[1]];
            v.extend(g.fibres.iter().flat_map(|f| [f.y, f.z, f.torsion]));
            v
        };
        for (shape, dimension) in cases {
            let exact = flat(&shape.rate(0.3, dimension).unwrap());
            let step = 1e-6;
            let at = |by: f64| flat(&moved(shape, dimension, by).geometry(0.3).unwrap());
            let (up, down) = (at(step), at(-step));
            let scale = flat(&shape.geometry(0.3).unwrap());
            for (k, e) in exact.iter().enumerate() {
                let fd = (up[k] - down[k]) / (2.0 * step);
                let tolerance = 1e-7 * (fd.abs() + scale[k].abs() / 0.01);
                assert!(
                    (fd - e).abs() <= tolerance,
                    "{shape:?} {dimension:?} [{k}]: {e} against {fd}"
                );
            }
        }
        assert!(Shape::SolidCircle { d: 0.1 }
            .rate(0.3, Dimension::Width)
            .is_none());
    }

    /// The torsion's peak shear `T c/J` against Timoshenko & Goodier's `T/(α h b²)` for
    /// rectangles `h/b` = 1, 2, 10 (α = 0.208, 0.246, 0.312), within 1 %, on the long sides'
    /// middles; a circle's `16T/(πd³)` exactly; the corners' none; the fibres on the edge.
    #[test]
    fn fibres_carry_the_torsions_textbook_peak_shear() {
        for (ratio, alpha) in [(1.0, 0.208), (2.0, 0.246), (10.0, 0.312)] {
            let (b, h) = (0.01, 0.01 * ratio);
            let g = Shape::Rectangle { b, h }.geometry(0.3).unwrap();
            let peak = g.fibres.iter().map(|f| f.torsion).fold(0.0, f64::max) / g.torsion;
            assert!(
                (peak * alpha * h * b * b - 1.0).abs() < 0.01,
                "{ratio}: {peak}"
            );
            for f in g.fibres.iter() {
                let corner = f.y.abs() == 0.5 * b && f.z.abs() == 0.5 * h;
                let edge = f.y.abs() == 0.5 * b || f.z.abs() == 0.5 * h;
                assert!(corner == (f.torsion == 0.0) && edge);
            }
            let square = ratio == 1.0;
            assert_eq!(g.fibres.len(), if square { 8 } else { 6 });
        }
        let d = 0.03;
        let circle = Shape::SolidCircle { d }.geometry(0.3).unwrap();
        for f in circle.fibres.iter() {
            assert!(
                (f.torsion / circle.torsion - 16.0 / (PI * d.powi(3))).abs() < 1e-9 / d.powi(3)
            );
            assert!(((f.y * f.y + f.z * f.z).sqrt() - d / 2.0).abs() < 1e-15);
        }
    }
}
