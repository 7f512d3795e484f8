//! The drapes of this [`GROUND_TRUTH_REVISION`], pinned by a fixture.
//!
//! A dataset's manifest records the revision of the solver that made it, and a dataset is
//! only resumed, extended or merged with drapes of its own revision. That guard is only as
//! good as the revision number, so this test fails when the drapes move without it: the
//! coarse T-shirt in Felt walked through three of the motion's most extreme poses (arms
//! against the torso, where the final projection out of the body works in the capsules'
//! blend regions), compared vertex by vertex with the fixture of this revision, once with
//! the default settings and once as a manifest written before the penalty hardened inside
//! the body reads them (`contact_hardening` 0), so datasets made that way still resume as
//! they were made.
//!
//! When a change moves the drapes on purpose, bump [`GROUND_TRUTH_REVISION`], say in its
//! doc what changed, and write the new fixture with
//! `GARMATNET_BLESS=1 cargo test --release -p garmatnet-sim --test ground_truth_revision`.

use std::path::{Path, PathBuf};

use garmatnet_core::{CapsuleBody, Garment, Material, Resolution};
use garmatnet_sim::sample_arrays::{read_points_npy, write_points_npy};
use garmatnet_sim::{
    GROUND_TRUTH_REVISION, MotionGenerator, SequenceSettings, drape_poses, extreme_poses,
};

/// How far (metres) a vertex may lie from the fixture: far above the fixture's f32 rounding
/// (3e-8 m at these coordinates), far below what a change of the solver moves (the change
/// that made revision 2 moved this walk's first drape by 0.73 mm).
const TOLERANCE: f64 = 1e-6;

fn fixture(settings: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(format!(
            "ground_truth_r{GROUND_TRUTH_REVISION}_{settings}.npy"
        ))
}

/// The walk with `settings`: every drape's vertices, frame after frame, in f32 as datasets
/// store them.
fn walk(settings: &SequenceSettings) -> Vec<[f32; 3]> {
    let body = CapsuleBody::smpl_neutral();
    // Revision 2's drapes were made on the boxy shirt (its datasets and the shipped model).
    let garment = Garment::boxy_tshirt(Resolution::Coarse, &body).unwrap();
    let motion = MotionGenerator::new(0, 200).generate();
    let poses: Vec<_> = extreme_poses(&motion, 20)[..3]
        .iter()
        .map(|&i| motion[i].clone())
        .collect();
    let material = Material::preset("Felt").unwrap();
    drape_poses(&garment, &body, &material, &poses, settings)
        .unwrap()
        .iter()
        .flatten()
        .map(|v| [v.x as f32, v.y as f32, v.z as f32])
        .collect()
}

#[test]
fn the_drapes_are_this_revisions() {
    let defaults = SequenceSettings::default();
    let mut unhardened = defaults.clone();
    unhardened.drape.contact_hardening = 0.0;
    for (name, settings) in [("defaults", defaults), ("no_hardening", unhardened)] {
        check(&fixture(name), &walk(&settings));
    }
}

fn check(path: &Path, drapes: &[[f32; 3]]) {
    if std::env::var_os("GARMATNET_BLESS").is_some() {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        write_points_npy(path, drapes).unwrap();
        eprintln!("wrote {}", path.display());
        return;
    }
    let pinned = read_points_npy(path, "fixture").unwrap_or_else(|e| {
        panic!(
            "no fixture for ground-truth revision {GROUND_TRUTH_REVISION} ({e}); write it \
             with GARMATNET_BLESS=1 once the revision's doc says what changed"
        )
    });
    assert_eq!(pinned.len(), drapes.len(), "the fixture's vertex count");
    let (worst, at) = drapes
        .iter()
        .zip(&pinned)
        .enumerate()
        .map(|(i, (a, b))| {
            let d = (0..3)
                .map(|k| (f64::from(a[k]) - f64::from(b[k])).powi(2))
                .sum::<f64>()
                .sqrt();
            (d, i)
        })
        .fold((0.0, 0), |best, x| if x.0 > best.0 { x } else { best });
    let per_frame = drapes.len() / 3;
    assert!(
        worst <= TOLERANCE,
        "the solver's drapes moved (by {:.3} mm at vertex {} of drape {}) from ground-truth \
         revision {GROUND_TRUTH_REVISION}'s ({}): datasets of this revision could no longer be \
         resumed or extended consistently. If the change is meant, bump GROUND_TRUTH_REVISION \
         (crates/garmatnet-sim/src/manifest.rs), say there what changed, and write the new \
         fixture with GARMATNET_BLESS=1",
        worst * 1e3,
        at % per_frame,
        at / per_frame,
        path.display()
    );
}
