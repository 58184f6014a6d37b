//! A scene and the same scene with every frame beam's elements split in two, beam by beam:
//! what [`crate::spatial::shares`] reads.

use crate::error::SettingsError;
use crate::spatial::shares::SplitBeam;

use super::SpatialScene;

impl SpatialScene {
    /// Each of its beams (in its order) with its elements here and in `fine`, its own beams
    /// split in two (a truss bar has none split).
    ///
    /// # Errors
    /// A [`SettingsError`] where `fine` has other beams, or a beam of another kind.
    pub fn split_beams(&self, fine: &SpatialScene) -> Result<Vec<SplitBeam>, SettingsError> {
        let other = |what: &str| {
            SettingsError::new(
                "fine scene",
                format!("is not the coarse scene with every frame beam split in two: {what}"),
            )
        };
        if fine.beams.len() != self.beams.len() {
            return Err(other("it has other beams"));
        }
        (self.beams.iter().zip(&fine.beams))
            .map(|((name, coarse), (fine_name, split))| {
                if fine_name != name || split.truss != coarse.truss {
                    return Err(other(&format!("its beam {fine_name} stands for {name}")));
                }
                let elements = |b: &super::BeamElements| match b.truss {
                    true => Vec::new(),
                    false => b.elements.clone(),
                };
                Ok(SplitBeam {
                    name: name.clone(),
                    coarse: elements(coarse),
                    fine: elements(split),
                })
            })
            .collect()
    }
}
