//! A spatial scene's positions at the end of the run: a body's centre of mass or a node's
//! origin along one axis (`scene/spatial/names.rs` parses them, `spatial/sensitivity.rs`
//! differentiates them). A planar scene's displacement along a direction is
//! `displacement.rs`'s.

use super::Kind;

/// The position along `axis` at the end of the run, a spatial scene's only.
const fn along(name: &'static str, spatial: &'static str, doc: &'static str) -> Kind {
    Kind {
        name,
        syntax: spatial,
        doc,
        peak: false,
        unit: "m",
        spatial: Some(spatial),
        linear: false,
        parse: None,
    }
}

pub(super) const X: Kind = along(
    "x",
    "x:NAME",
    "a body's centre of mass or a node's origin along x at the end of the run (m); spatial \
     scenes",
);

pub(super) const Y: Kind = along("y", "y:NAME", "the same along y (m); spatial scenes");

pub(super) const Z: Kind = along("z", "z:NAME", "the same along z (m); spatial scenes");
