//! Each spatial beam's share of the change of splitting every frame beam in two
//! ([`crate::spatial::shares`]): it adds up to the change measured, and a scene that is not
//! the other split is named.

use crate::error::Error;
use crate::scene::spatial::tests::{built, PENDULUM};
use crate::scene::spatial::SpatialScene;
use crate::settings::RunOptions;
use crate::spatial::shares::{beam_shares, BeamShares};

fn shares_of(
    coarse: &SpatialScene,
    fine: &SpatialScene,
    names: [&[&str]; 2],
) -> Result<BeamShares, Error> {
    let named = |s: &SpatialScene, names: &[&str]| {
        names
            .iter()
            .map(|r| s.response(r).unwrap())
            .collect::<Vec<_>>()
    };
    let settings = RunOptions::default().dynamic(&coarse.options).unwrap();
    let x = Some(&[0.6, 0.3, 0.5][..]);
    let (rs, fs) = (named(coarse, names[0]), named(fine, names[1]));
    let grid = settings.grid();
    let beams = coarse.split_beams(fine)?;
    let models = (coarse.model_at(x)?, fine.model_at(x)?);
    beam_shares((&models.0, &models.1), &beams, &settings, &grid, &rs, &fs)
}

/// The shares of the flexible pendulum's node positions (its end's, an inner node's), its
/// strain energy's mean and its kinetic energy's integral (these with their own reading of
/// the split beams) add up to the change that splitting every beam makes, within 1 %; the
/// truss bar has none.
#[test]
fn shares_add_up_to_the_change_of_splitting() {
    let coarse = built(PENDULUM).unwrap();
    let fine = built(&PENDULUM.replace("split = 2", "split = 4")).unwrap();
    let energies = ["strain_energy", "kinetic_energy"];
    let responses = ["x:c", "z:c", "y:lower[1]", energies[0], energies[1]];
    let out = shares_of(
        &coarse,
        &fine,
        [
            &responses,
            &["x:c", "z:c", "y:lower[2]", energies[0], energies[1]],
        ],
    )
    .unwrap();
    let n_b = coarse.beams.len();
    let truss = coarse.beams.keys().position(|b| b == "brace").unwrap();
    for (k, name) in responses.iter().enumerate() {
        let change = out.fine_values[k] - out.values[k];
        let row = &out.shares[k * n_b..(k + 1) * n_b];
        let sum: f64 = row.iter().sum();
        assert!(
            change.abs() > 1e-9,
            "{name}: no change to measure ({change:e})"
        );
        assert!(
            (sum - change).abs() <= 1e-2 * change.abs(),
            "{name}: shares {sum:e} against the change {change:e}"
        );
        assert_eq!(row[truss], 0.0);
    }
}

/// A fine scene that is not the coarse one split in two is named.
#[test]
fn a_scene_not_split_in_two_is_named() {
    let coarse = built(PENDULUM).unwrap();
    for (fine, words) in [
        (PENDULUM.to_string(), "it has no node upper[2]"),
        (
            PENDULUM.replace("split = 2", "split = 3"),
            "beam lower is not in twice its elements",
        ),
    ] {
        let fine = built(&fine).unwrap();
        let e = shares_of(&coarse, &fine, [&["x:c"], &["x:c"]]).unwrap_err();
        assert!(e.to_string().contains(words), "{e}");
    }
    let e = shares_of(&coarse, &coarse, [&["x:c"], &[]]).unwrap_err();
    assert!(e.to_string().contains("one for one"), "{e}");
}
