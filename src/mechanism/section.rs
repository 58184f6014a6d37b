//! Beam cross-section: the per-length properties of a planar Timoshenko beam.
//!
//! Units are SI throughout the crate: metres, kilograms, seconds, newtons, pascals,
//! radians. A section at full density (`x = 1`) has axial stiffness `EA`, shear
//! stiffness `κGA`, bending stiffness `EI`, mass per length `ρA` and rotary inertia per
//! length `ρI`, and, when the scene gives it, the outer-fibre distance `c` of bending
//! stresses `M c / I`.

/// Per-length stiffness and inertia of a beam section at full density.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Section {
    /// Area `A` (m²), for volumes.
    pub area: f64,
    /// Axial stiffness `EA` (N).
    pub ea: f64,
    /// Shear stiffness `κGA` (N).
    pub gak: f64,
    /// Bending stiffness `EI` (N m²).
    pub ei: f64,
    /// Mass per length `ρA` (kg/m).
    pub rho_a: f64,
    /// Rotary inertia per length `ρI` (kg m).
    pub rho_i: f64,
    /// Outer-fibre distance `c` from the neutral axis (m), `None` for a section given by
    /// `A`, `I`, `κ` without it: the bending stress `M c / I` needs it.
    pub fibre: Option<f64>,
    /// The largest shear stress over the mean `V/A` (4/3 for a solid circle), `None` when
    /// the scene gives a section by `A`, `I`, `κ` without it.
    pub shear_factor: Option<f64>,
    /// Rayleigh damping's mass-proportional coefficient `α` (1/s).
    pub alpha: f64,
    /// Its stiffness-proportional coefficient `β` (s).
    pub beta: f64,
}

impl Section {
    /// Section from material moduli and geometric properties.
    pub fn new(e: f64, g: f64, area: f64, inertia: f64, kappa: f64, rho: f64) -> Self {
        Self {
            area,
            ea: e * area,
            gak: kappa * g * area,
            ei: e * inertia,
            rho_a: rho * area,
            rho_i: rho * inertia,
            fibre: None,
            shear_factor: None,
            alpha: 0.0,
            beta: 0.0,
        }
    }

    /// The section damped by `C = α M + β K` (Rayleigh; `α` in 1/s, `β` in s).
    pub fn with_rayleigh(self, alpha: f64, beta: f64) -> Self {
        Self {
            alpha,
            beta,
            ..self
        }
    }

    /// The section with peak shear factor `k` (the largest shear stress is `k V/A`).
    pub fn with_shear_factor(self, k: f64) -> Self {
        Self {
            shear_factor: Some(k),
            ..self
        }
    }

    /// The section with outer-fibre distance `c` (m).
    pub fn with_fibre(self, c: f64) -> Self {
        Self {
            fibre: Some(c),
            ..self
        }
    }

    /// `c/I = c E/EI` (1/m³), the outer-fibre stress per unit bending moment; `None`
    /// without an outer-fibre distance.
    pub fn fibre_per_moment(&self) -> Option<f64> {
        self.fibre.map(|c| c * (self.ea / self.area) / self.ei)
    }

    /// The section's rates `∂(A, EA, κGA, EI, ρA, ρI, c)/∂p` of `property` (in the fields of
    /// a section), given what it is made of: with `E` (and `κGA` with it: through `G` when
    /// `ν` is given, through a circle's `κ(ν)` with `ν = E/2G − 1` when `G` is), with `ρ`,
    /// or with a solid circle's diameter `d` (`A ∝ d²`, `I ∝ d⁴`); Rayleigh's `α` and `β`
    /// change only themselves.
    pub fn rate(&self, made: &Made, property: SectionProperty) -> Section {
        let zero = Self::new(0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        match property {
            SectionProperty::E => Self {
                ea: self.ea / made.e,
                ei: self.ei / made.e,
                gak: match (made.shear_follows_e, made.diameter) {
                    (true, _) => self.gak / made.e,
                    // κ = 6(1 + ν)/(7 + 6ν): dκ/dν = 6/(7 + 6ν)², dν/dE = 1/2G.
                    (false, Some(_)) => 3.0 * self.area / (7.0 + 6.0 * made.nu).powi(2),
                    (false, None) => 0.0,
                },
                ..zero
            },
            SectionProperty::Rho => Self {
                rho_a: self.rho_a / made.rho,
                rho_i: self.rho_i / made.rho,
                ..zero
            },
            SectionProperty::Diameter => {
                let d = made.diameter.unwrap_or(f64::NAN);
                Self {
                    area: 2.0 * self.area / d,
                    ea: 2.0 * self.ea / d,
                    gak: 2.0 * self.gak / d,
                    ei: 4.0 * self.ei / d,
                    rho_a: 2.0 * self.rho_a / d,
                    rho_i: 4.0 * self.rho_i / d,
                    // The outer fibre of a solid circle is at d/2.
                    fibre: Some(0.5),
                    ..zero
                }
            }
            SectionProperty::Alpha => zero.with_rayleigh(1.0, 0.0),
            SectionProperty::Beta => zero.with_rayleigh(0.0, 1.0),
        }
    }

    /// Geometry of a solid circle of diameter `d`: area `πd²/4`, second moment `πd⁴/64`
    /// and Cowper's shear coefficient `κ = 6(1+ν)/(7+6ν)`.
    pub fn solid_circle(d: f64, nu: f64) -> (f64, f64, f64) {
        let area = std::f64::consts::PI * d * d / 4.0;
        let inertia = std::f64::consts::PI * d.powi(4) / 64.0;
        let kappa = 6.0 * (1.0 + nu) / (7.0 + 6.0 * nu);
        (area, inertia, kappa)
    }
}

/// What a scene's section is made of: the scalars its properties follow.
#[derive(Debug, Clone, PartialEq)]
pub struct Made {
    /// Young's modulus `E` (Pa).
    pub e: f64,
    /// Density `ρ` (kg/m³).
    pub rho: f64,
    /// Poisson's ratio `ν`, given or from `E = 2G(1 + ν)`.
    pub nu: f64,
    /// Whether `G` follows `E` (the scene gives `ν`) rather than being given.
    pub shear_follows_e: bool,
    /// A solid circle's diameter (m); `None` for a section given by `A`, `I`, `κ`.
    pub diameter: Option<f64>,
}

/// A section of the scene by name: its properties and what they are made of.
#[derive(Debug, Clone, PartialEq)]
pub struct NamedSection {
    /// Name in the scene's `[sections]`.
    pub name: String,
    /// Its properties.
    pub section: Section,
    /// What they are made of.
    pub made: Made,
    /// Whether a ground structure declared rigid is made of it: that body's mass and
    /// inertia then follow it too.
    pub rigid: bool,
}

/// A scalar a section's properties follow, for gradients.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SectionProperty {
    /// Young's modulus `E`.
    E,
    /// Density `ρ`.
    Rho,
    /// A solid circle's diameter.
    Diameter,
    /// Rayleigh damping's `α`.
    Alpha,
    /// Rayleigh damping's `β`.
    Beta,
}
