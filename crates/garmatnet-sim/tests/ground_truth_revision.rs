//! The drapes of this [`GROUND_TRUTH_REVISION`], pinned by a fixture.
//!
//! A dataset's manifest records the revision of the solver that made it, and a dataset is
//! only resumed, extended or merged with drapes of its own revision. That guard is only as
//! good as the revision number, so this test fails when the drapes move without it: the
//! coarse fitted T-shirt in Felt draped by the canonical protocol at three poses of the
//! everyday suite (arms at the sides, where cloth is pinched between arm and torso; both
//! arms raised; the torso twisted), compared vertex by vertex with the fixture of this
//! revision, once with the canonical settings and once without the penalty's hardening
//! inside the body (`contact_hardening` 0, as manifests written before it read).
//!
//! When a change moves the drapes on purpose, bump [`GROUND_TRUTH_REVISION`], say in its
//! doc what changed, and write the new fixture with
//! `GARMATNET_BLESS=1 cargo test --release -p garmatnet-sim --test ground_truth_revision`.

use std::path::{Path, PathBuf};

use garmatnet_core::{CapsuleBody, Garment, Material, Resolution};
use garmatnet_sim::sample_arrays::{read_points_npy, write_points_npy};
use garmatnet_sim::{
    CanonicalDraper, GROUND_TRUTH_REVISION, SequenceSettings, canonical_settings, everyday_pose,
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

/// Felt's drapes by the canonical protocol with `settings` (this revision's samples) at three
/// poses of the everyday suite, on the default (fitted) shirt: every vertex, pose after pose,
/// in f32 as datasets store them.
fn walk(settings: &SequenceSettings) -> Vec<[f32; 3]> {
    let body = CapsuleBody::smpl_neutral();
    let garment = Garment::tshirt(Resolution::Coarse, &body).unwrap();
    let material = Material::preset("Felt").unwrap();
    let draper = CanonicalDraper::new(&garment, &body, &material, settings).unwrap();
    ["arms-at-sides", "both-arms-raised", "torso-twisted"]
        .iter()
        .flat_map(|name| draper.drape(&everyday_pose(name).unwrap()).unwrap().0)
        .map(|v| [v.x as f32, v.y as f32, v.z as f32])
        .collect()
}

#[test]
fn the_drapes_are_this_revisions() {
    let defaults = canonical_settings();
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
         (crates/garmatnet-sim/src/dataset/manifest.rs), say there what changed, and write the new \
         fixture with GARMATNET_BLESS=1",
        worst * 1e3,
        at % per_frame,
        at / per_frame,
        path.display()
    );
}
