//! The arguments responses take after their name: components, nodes, directions, driven
//! joints and `key=value` options, each read against the model with an error in the user's
//! words.

use crate::mechanism::model::{Analysis, Model};

/// A component by name, `None` for all.
pub(super) fn component(model: &Model, arg: Option<&str>) -> Result<Option<usize>, String> {
    let Some(c) = arg else { return Ok(None) };
    model
        .components
        .iter()
        .position(|x| x == c)
        .map(Some)
        .ok_or_else(|| {
            format!(
                "unknown component '{c}' (components: {})",
                model.components.join(", ")
            )
        })
}

/// The elements of a component, or all of them.
pub(super) fn elements_of(m: &Model, component: Option<usize>) -> impl Iterator<Item = usize> + '_ {
    (0..m.elements.len())
        .filter(move |&e| component.is_none_or(|c| m.bars[m.elements[e].bar].component == c))
}

/// The cells of a component's continuum members, or all of them.
pub(super) fn cells_of(m: &Model, component: Option<usize>) -> impl Iterator<Item = usize> + '_ {
    (0..m.cells.len())
        .filter(move |&k| component.is_none_or(|c| m.members[m.cells[k].member].component == c))
}

/// A node by name.
pub(super) fn node(model: &Model, name: &str) -> Result<usize, String> {
    model
        .node_index(name)
        .ok_or_else(|| format!("unknown node '{name}'"))
}

/// `NODE:DX,DY`: a node and a direction, normalized.
pub(super) fn node_and_direction(
    model: &Model,
    arg: Option<&str>,
) -> Result<(usize, [f64; 2]), String> {
    let (n, d) = arg
        .and_then(|a| a.rsplit_once(':'))
        .ok_or("needs NODE:DX,DY")?;
    let v: Vec<f64> = d
        .split(',')
        .map(|s| s.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("direction: {e}"))?;
    let norm = v.iter().map(|c| c * c).sum::<f64>().sqrt();
    if v.len() != 2 || !(norm.is_finite() && norm > 0.0) {
        return Err("direction must be two finite numbers, not both zero".into());
    }
    Ok((node(model, n)?, [v[0] / norm, v[1] / norm]))
}

/// The index of the joint called `name`.
pub(super) fn joint_index(model: &Model, name: &str) -> Result<usize, String> {
    model
        .joints
        .iter()
        .position(|j| j.name == name)
        .ok_or_else(|| {
            let names: Vec<&str> = model.joints.iter().map(|j| j.name.as_str()).collect();
            format!("unknown joint '{name}' (joints: {})", names.join(", "))
        })
}

/// The driven constraint row of the joint called `name`.
pub(super) fn drive_row(model: &Model, name: &str) -> Result<usize, String> {
    if model.analysis == Analysis::Static {
        return Err(
            "a static scene has no motion to drive; torques are responses of a dynamic one".into(),
        );
    }
    let index = joint_index(model, name)?;
    model
        .rows
        .iter()
        .position(|r| r.joint == index && r.driven)
        .ok_or(format!(
            "joint '{name}' has no drive: a drive's torque (−λ of its row) is a response, a \
             motor's is its input"
        ))
}

/// The prescribed rate `ġ(t)` of driven row `row`.
pub(super) fn drive_rate(model: &Model, row: usize, t: f64) -> f64 {
    let r = &model.rows[row];
    model.joints[r.joint].prescribed(r, t)[1]
}

/// `key=value` options of a response, in the order given.
pub(crate) type Options = Vec<(String, f64)>;

/// The value of option `key`, if given.
pub(crate) fn option(options: &Options, key: &str) -> Option<f64> {
    options.iter().find(|(k, _)| k == key).map(|&(_, v)| v)
}

/// An error for the first option not in `allowed`.
pub(crate) fn only(options: &Options, allowed: &[&str]) -> Result<(), String> {
    match options.iter().find(|(k, _)| !allowed.contains(&k.as_str())) {
        None => Ok(()),
        Some((k, _)) if allowed.is_empty() => Err(format!("unknown option '{k}' (options: none)")),
        Some((k, _)) => Err(format!(
            "unknown option '{k}' (options: {})",
            allowed.join(", ")
        )),
    }
}

/// `COMPONENT` and `key=value,...` options of a response argument `[COMPONENT][:OPTIONS]`
/// (the part with `=` is the options).
pub(crate) fn component_and_options(rest: Option<&str>) -> Result<(Option<&str>, Options), String> {
    let mut component = None;
    let mut options = Vec::new();
    for part in rest.into_iter().flat_map(|r| r.split(':')) {
        if !part.contains('=') {
            if component.replace(part).is_some() {
                return Err("give at most one component".into());
            }
            continue;
        }
        for option in part.split(',') {
            let (k, v) = option
                .split_once('=')
                .ok_or(format!("option '{option}' needs KEY=VALUE"))?;
            let value = v
                .trim()
                .parse::<f64>()
                .map_err(|e| format!("option '{option}': {e}"))?;
            if options
                .iter()
                .any(|(key, _): &(String, f64)| key == k.trim())
            {
                return Err(format!("option '{}' given twice", k.trim()));
            }
            options.push((k.trim().to_string(), value));
        }
    }
    Ok((component, options))
}

/// An error unless the response takes no argument.
pub(super) fn none(rest: Option<&str>) -> Result<(), String> {
    match rest {
        None => Ok(()),
        Some(a) => Err(format!("takes no argument, got '{a}'")),
    }
}
