//! Sections: the material and cross-section of a beam, named in the scene's `[sections]`.

use std::collections::BTreeMap;

use super::spec::SectionSpec;
use super::validate::{positive, unknown, Result};
use crate::error::{short, SceneError};
use crate::section::Section;

/// The scene's sections by name.
pub(super) type Sections = BTreeMap<String, Section>;

/// Every section of the scene, checked in name order.
pub(super) fn sections(specs: &BTreeMap<String, SectionSpec>) -> Result<Sections> {
    specs
        .iter()
        .map(|(k, s)| Ok((k.clone(), section(&format!("sections.{k}"), s)?)))
        .collect()
}

/// The section called `name` by the `section` key of the entry at `path`.
pub(super) fn find<'a>(sections: &'a Sections, path: &str, name: &str) -> Result<&'a Section> {
    sections
        .get(name)
        .ok_or_else(|| unknown(format!("{path}.section"), "section", name))
}

/// The section at `path`: Young's modulus `E` and density `ρ` positive, the shear modulus
/// from [`elasticity`], the area and inertia from [`geometry`].
fn section(path: &str, s: &SectionSpec) -> Result<Section> {
    let e = positive(&format!("{path}.E"), s.E)?;
    let rho = positive(&format!("{path}.rho"), s.rho)?;
    let (g, nu) = elasticity(path, s, e)?;
    let (area, inertia, kappa) = geometry(path, s, nu)?;
    let mut section = Section::new(e, g, area, inertia, kappa, rho);
    if let Some(d) = s.diameter {
        if s.c.is_some() || s.shear_factor.is_some() {
            return Err(SceneError::new(
                path,
                "a solid circle's outer fibre is at diameter/2 and its peak shear 4/3 V/A; drop `c` and `shear_factor`",
            ));
        }
        return Ok(section.with_fibre(d / 2.0).with_shear_factor(4.0 / 3.0));
    }
    if let Some(c) = s.c {
        section = section.with_fibre(positive(&format!("{path}.c"), c)?);
    }
    if let Some(k) = s.shear_factor {
        section = section.with_shear_factor(positive(&format!("{path}.shear_factor"), k)?);
    }
    Ok(section)
}

/// Shear modulus `G` and Poisson's ratio `ν`: exactly one is given, the other follows from
/// `E = 2G(1 + ν)`, and `ν ∈ (−1, 0.5]`.
fn elasticity(path: &str, s: &SectionSpec, e: f64) -> Result<(f64, f64)> {
    let (g, nu) = match (s.G, s.nu) {
        (Some(g), None) => {
            let g = positive(&format!("{path}.G"), g)?;
            (g, e / (2.0 * g) - 1.0)
        }
        (None, Some(nu)) => (e / (2.0 * (1.0 + nu)), nu),
        _ => return Err(SceneError::new(path, "give exactly one of G and nu")),
    };
    if !(nu > -1.0 && nu <= 0.5) {
        return Err(SceneError::new(
            path,
            format!("Poisson's ratio must lie in (-1, 0.5], got {}", short(nu)),
        ));
    }
    Ok((g, nu))
}

/// Area `A`, second moment of area `I` and shear coefficient `κ`: those of a solid circle
/// of the given `diameter`, or all three given.
fn geometry(path: &str, s: &SectionSpec, nu: f64) -> Result<(f64, f64, f64)> {
    match (s.diameter, s.A, s.I, s.kappa) {
        (Some(d), None, None, None) => Ok(Section::solid_circle(
            positive(&format!("{path}.diameter"), d)?,
            nu,
        )),
        (None, Some(a), Some(i), Some(k)) => Ok((
            positive(&format!("{path}.A"), a)?,
            positive(&format!("{path}.I"), i)?,
            positive(&format!("{path}.kappa"), k)?,
        )),
        _ => Err(SceneError::new(
            path,
            "give either `diameter` (solid circle) or all of `A`, `I`, `kappa`",
        )),
    }
}
