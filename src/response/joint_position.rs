//! A joint's own coordinate at the final time ([`crate::joint::planar::Joint::coordinate`]): a
//! pin's rotation or a hinge's relative rotation from the reference (rad), a slider's
//! travel (m).

use super::arguments::joint_index;
use super::{Context, Family, Kind, Known, Partials, Sample, Weighting};
use crate::joint::planar::ConstraintRow;
use crate::mechanism::model::Model;

pub(super) const KIND: Kind = Kind {
    name: "joint_position",
    syntax: "joint_position:JOINT",
    doc: "a joint's own coordinate at the end: a pin's or hinge's rotation from the \
          reference (rad), a slider's travel (m)",
    peak: false,
    unit: "rad (m on a slider)",
    spatial: None,
    linear: false,
    parse: Some(parse),
};

fn parse(model: &Model, rest: Option<&str>) -> Result<Box<dyn Family>, String> {
    let name = rest.ok_or("name the joint: joint_position:JOINT")?;
    let j = joint_index(model, name)?;
    let row = model.joints[j].coordinate(j).ok_or_else(|| {
        format!(
            "joint '{name}' is a {}: it holds every coordinate, so it has no position",
            model.joints[j].kind.name()
        )
    })?;
    Ok(Box::new(JointPosition { row }))
}

/// The coordinate as a constraint row's law, read at the final state.
#[derive(Debug)]
struct JointPosition {
    row: ConstraintRow,
}

impl Family for JointPosition {
    fn weighting(&self) -> Weighting {
        Weighting::Final
    }

    fn integrand(&self, _: &Context, at: Sample, _: Known) -> f64 {
        self.row.evaluate(at.q).0
    }

    fn add_partials(&self, _: &Context, at: Sample, _: Known, scale: f64, g: Partials) {
        for (d, dg) in self.row.dofs().iter().zip(self.row.evaluate(at.q).1) {
            if let Some(d) = d {
                g.q[*d] += scale * dg;
            }
        }
    }
}
