//! Sections: the material and cross-section of a beam, named in the scene's `[sections]`.

use std::collections::BTreeMap;

use super::spec::SectionSpec;
use super::validate::{non_negative, positive, unknown, Result};
use crate::error::{short, SceneError};
use crate::mechanism::section::{Made, NamedSection, Section};

/// The scene's sections, in name order.
pub(super) type Sections = Vec<NamedSection>;

/// Every section of the scene, checked in name order; `rigid` names the sections of
/// ground structures declared rigid.
pub(super) fn sections(specs: &BTreeMap<String, SectionSpec>, rigid: &[&str]) -> Result<Sections> {
    specs
        .iter()
        .map(|(k, s)| {
            let path = format!("sections.{k}");
            let section = section(&path, s)?;
            Ok(NamedSection {
                name: k.clone(),
                section,
                made: Made {
                    e: s.E,
                    rho: s.rho,
                    nu: elasticity(&path, s, s.E)?.1,
                    shear_follows_e: s.G.is_none(),
                    diameter: s.diameter,
                },
                rigid: rigid.contains(&k.as_str()),
            })
        })
        .collect()
}

/// The section called `name` by the `section` key of the entry at `path`: its index and
/// properties.
pub(super) fn find<'a>(
    sections: &'a Sections,
    path: &str,
    name: &str,
) -> Result<(usize, &'a Section)> {
    sections
        .iter()
        .position(|s| s.name == name)
        .map(|k| (k, &sections[k].section))
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
    if let Some([alpha, beta]) = s.rayleigh {
        let alpha = non_negative(&format!("{path}.rayleigh[0]"), alpha)?;
        section = section.with_rayleigh(alpha, non_negative(&format!("{path}.rayleigh[1]"), beta)?);
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::section::SectionProperty;

    /// Every field of `Section::rate` against central differences of sections the scene
    /// builds, for circles and given `A, I, κ`, with `ν` or with `G` given.
    #[test]
    fn section_rates_equal_central_differences() {
        let circle = |g: Option<f64>, nu: Option<f64>| SectionSpec {
            E: 70e9,
            rho: 2700.0,
            G: g,
            nu,
            diameter: Some(0.02),
            ..SectionSpec::default()
        };
        let given = |g: Option<f64>, nu: Option<f64>| SectionSpec {
            diameter: None,
            A: Some(3e-4),
            I: Some(2e-8),
            kappa: Some(0.85),
            ..circle(g, nu)
        };
        let specs = [
            circle(None, Some(0.32)),
            circle(Some(26e9), None),
            given(None, Some(0.32)),
            given(Some(26e9), None),
        ];
        let fields = |s: &Section| [s.area, s.ea, s.gak, s.ei, s.rho_a, s.rho_i];
        for spec in specs {
            let named = &sections(&[("s".to_string(), spec.clone())].into(), &[]).unwrap()[0];
            for property in [
                SectionProperty::E,
                SectionProperty::Rho,
                SectionProperty::Diameter,
            ] {
                if property == SectionProperty::Diameter && spec.diameter.is_none() {
                    continue;
                }
                let built = |step: f64| {
                    let mut s = spec.clone();
                    match property {
                        SectionProperty::E => s.E *= 1.0 + step,
                        SectionProperty::Rho => s.rho *= 1.0 + step,
                        SectionProperty::Diameter => {
                            s.diameter = s.diameter.map(|d| d * (1.0 + step))
                        }
                        SectionProperty::Alpha | SectionProperty::Beta => unreachable!(),
                    }
                    fields(&section("s", &s).unwrap())
                };
                let value = match property {
                    SectionProperty::E => spec.E,
                    SectionProperty::Rho => spec.rho,
                    SectionProperty::Diameter => spec.diameter.unwrap(),
                    SectionProperty::Alpha | SectionProperty::Beta => unreachable!(),
                };
                let h = 1e-5;
                let (up, down) = (built(h), built(-h));
                let rate = fields(&named.section.rate(&named.made, property));
                for k in 0..6 {
                    let fd = (up[k] - down[k]) / (2.0 * h * value);
                    let scale = fields(&named.section)[k] / value;
                    assert!(
                        (rate[k] - fd).abs() <= 1e-7 * scale,
                        "{property:?} field {k}: {} against {fd}",
                        rate[k]
                    );
                }
            }
        }
    }
}
