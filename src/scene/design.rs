//! The design: one density per free bar or per group of beams, bounded below by `x_min`,
//! with the stiffness interpolated by SIMP or RAMP (paper Eq. 1, 33, 34).
//!
//! Each bar of a ground structure has a variable of its own unless the structure is
//! `fixed`; a beam has its own variable, shares that of its `group`, or has none when
//! `fixed` (full density). Variables are numbered in the order the bars claim them.

use std::collections::HashMap;

use super::spec::{AnalysisSpec, BeamSpec, DesignSpec, InterpolationSpec, MassSpec};
use super::validate::{non_negative, Result};
use crate::error::{short, SceneError};
use crate::mechanism::interpolation::{Interpolation, MassLaw, MASS_FLOOR};

/// Design variables under construction.
#[derive(Default)]
pub(super) struct Variables {
    /// Name of each variable: that of its bar, or of its group.
    pub(super) names: Vec<String>,
    /// Variable of each group.
    groups: HashMap<String, usize>,
}

impl Variables {
    /// A new variable called `name`.
    pub(super) fn add(&mut self, name: &str) -> usize {
        self.names.push(name.to_string());
        self.names.len() - 1
    }

    /// The variable of the beam `b` at `path`, called `name` when it has one of its own.
    pub(super) fn of_beam(
        &mut self,
        path: &str,
        name: &str,
        b: &BeamSpec,
    ) -> Result<Option<usize>> {
        self.of(path, name, b.group.as_deref(), b.fixed)
    }

    /// The variable of a beam at `path` in design `group`, or `fixed` at full density, called
    /// `name` when it has one of its own.
    pub(super) fn of(
        &mut self,
        path: &str,
        name: &str,
        group: Option<&str>,
        fixed: bool,
    ) -> Result<Option<usize>> {
        match (group, fixed) {
            (Some(_), true) => Err(SceneError::new(
                path,
                "a fixed beam cannot belong to a design group",
            )),
            (_, true) => Ok(None),
            (Some(g), false) => Ok(Some(self.group(g))),
            (None, false) => Ok(Some(self.add(name))),
        }
    }

    /// The variable shared by the beams of group `g`, added by its first beam.
    fn group(&mut self, g: &str) -> usize {
        match self.groups.get(g) {
            Some(&v) => v,
            None => {
                let v = self.add(g);
                self.groups.insert(g.to_string(), v);
                v
            }
        }
    }
}

/// The inertia law: Du–Olhoff by default for dynamic scenes, where thin bars vibrate;
/// linear (the paper's) by default for static ones, where mass is only weight.
pub(super) fn mass_law(d: &DesignSpec, analysis: AnalysisSpec) -> Result<MassLaw> {
    let default = match analysis {
        AnalysisSpec::Dynamic => MassSpec::DuOlhoff,
        AnalysisSpec::Static => MassSpec::Linear,
    };
    match (d.mass.unwrap_or(default), d.mass_threshold, d.mass_floor) {
        (MassSpec::Linear, None, None) => Ok(MassLaw::Linear),
        (MassSpec::Linear, t, _) => Err(SceneError::new(
            if t.is_some() {
                "design.mass_threshold"
            } else {
                "design.mass_floor"
            },
            "applies to mass = \"du_olhoff\" only",
        )),
        (MassSpec::DuOlhoff, t, c) => {
            let threshold = t.unwrap_or(0.1);
            if !(threshold > 0.0 && threshold <= 1.0) {
                return Err(SceneError::new(
                    "design.mass_threshold",
                    format!("must lie in (0, 1], got {}", short(threshold)),
                ));
            }
            let floor = c.unwrap_or(MASS_FLOOR);
            if !(floor > 0.0 && floor <= 1.0) {
                return Err(SceneError::new(
                    "design.mass_floor",
                    format!("must lie in (0, 1], got {}", short(floor)),
                ));
            }
            Ok(MassLaw::DuOlhoff { threshold, floor })
        }
    }
}

/// The interpolation law and the lower bound `x_min ∈ (0, 1)` of the densities.
pub(super) fn law(d: &DesignSpec) -> Result<(Interpolation, f64)> {
    let x_min = d.x_min;
    if !(x_min > 0.0 && x_min < 1.0) {
        return Err(SceneError::new(
            "design.x_min",
            format!("must lie in (0, 1), got {}", short(x_min)),
        ));
    }
    Ok((interpolation(d)?, x_min))
}

/// SIMP with exponent `p ≥ 1` (default 3) and void stiffness `0 ≤ e_min < 1` (default 0),
/// or RAMP with parameter `q ≥ 0` (default 8); each law takes only its own parameters.
fn interpolation(d: &DesignSpec) -> Result<Interpolation> {
    if d.e_min.is_some() && d.interpolation == InterpolationSpec::Ramp {
        return Err(SceneError::new(
            "design.e_min",
            "`e_min` is SIMP's stiffness of void; RAMP takes `q`",
        ));
    }
    match (d.interpolation, d.p, d.q) {
        (InterpolationSpec::Simp, p, None) => {
            let p = p.unwrap_or(3.0);
            if !(p.is_finite() && p >= 1.0) {
                return Err(SceneError::new(
                    "design.p",
                    format!("SIMP exponent must be finite and >= 1, got {}", short(p)),
                ));
            }
            let e_min = d.e_min.unwrap_or(0.0);
            if !(0.0..1.0).contains(&e_min) {
                return Err(SceneError::new(
                    "design.e_min",
                    format!(
                        "the stiffness of void E_min/E must lie in [0, 1), got {}",
                        short(e_min)
                    ),
                ));
            }
            Ok(Interpolation::Simp { p, e_min })
        }
        (InterpolationSpec::Ramp, None, q) => Ok(Interpolation::Ramp {
            q: non_negative("design.q", q.unwrap_or(8.0))?,
        }),
        (InterpolationSpec::Simp, _, Some(_)) => Err(SceneError::new(
            "design.q",
            "`q` is the RAMP parameter; SIMP takes `p`",
        )),
        (InterpolationSpec::Ramp, Some(_), _) => Err(SceneError::new(
            "design.p",
            "`p` is the SIMP exponent; RAMP takes `q`",
        )),
    }
}
