//! Building a dataset on an existing one: the samples of the fabrics both have are copied,
//! not draped again.
//!
//! A sample depends only on its material, its pose (by the canonical protocol; in a walk,
//! the end of the walk through the poses in order, on the poses before it too), the
//! template, the body and the solver and smoothing settings — not on which other materials
//! share the dataset. A dataset with more fabrics (denser
//! coverage of ω, the lever for unseen fabrics) can therefore start from the samples of one
//! made with the same poses and settings, and drape only what is new; under the canonical
//! protocol, where a sample depends on its own pose alone, so can a dataset of more or other
//! poses (each sample goes to the pose equal to its own).

use std::collections::HashMap;
use std::path::Path;

use garmatnet_core::Error;

use crate::dataset::manifest::DatasetSpec;
use crate::dataset::reader::DatasetReader;
use crate::dataset::shard::Shard;
use crate::dataset::writer::{DatasetWriter, SpecScope, compare_specs};
use crate::solver::canonical::DrapeProtocol;

/// What [`import_samples`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ImportReport {
    /// Materials both datasets have (same name and ω) that the shard takes.
    pub shared_materials: usize,
    /// Samples copied into the destination.
    pub imported: usize,
    /// Samples of shared materials the destination had already (left as they are).
    pub already_done: usize,
}

/// Copies into the dataset `writer` writes every finished sample of the dataset in `source`
/// whose material the destination also lists (same name and ω) and `shard` takes, at that
/// material's index in the destination and (canonical protocol) at the destination's pose
/// equal to its own, bit for bit, unless the destination has it already or its
/// [`crate::SamplePlan`] does not hold it. Samples are
/// read and checked (shapes, finiteness) and written through
/// [`DatasetWriter::write_sample`]: arrays first, completion marker last, so a killed import
/// resumes like a killed run.
///
/// # Errors
/// - as [`DatasetReader::open`] and [`DatasetReader::read_sample`] for `source`;
/// - [`crate::Error::SpecMismatch`] if `source` differs from the destination in anything
///   but its material list, its plan and (canonical protocol) its poses: revision, protocol,
///   template, body, a walk's poses or frames, solver settings, smoothing (its samples would
///   be drapes another dataset does not make); [`Error::Mismatch`] if it lists
///   a material under the destination's name with another ω;
/// - [`crate::Error::NothingToReuse`] if the two share no material at all (a shard that takes
///   none of the shared ones imports nothing, so one command serves every shard);
/// - as [`DatasetWriter::write_sample`] for the destination.
pub fn import_samples(
    writer: &DatasetWriter,
    source: &Path,
    shard: Shard,
) -> crate::Result<ImportReport> {
    let reader = DatasetReader::open(source)?;
    let dest = writer.spec();
    compare_specs(dest, reader.spec(), SpecScope::Reuse, &|what| {
        format!(
            "{what} of the dataset to reuse, {} (reuse only a dataset made with the same \
             template and settings, and for a walk the same poses)",
            source.display()
        )
    })?;
    let poses = pose_map(dest, reader.spec());
    // Source material index -> destination index (this shard's), and whether any is shared.
    let mut map = vec![None; reader.spec().materials.len()];
    let mut shared = false;
    for (to, entry) in dest.materials.iter().enumerate() {
        let Some(from) = reader
            .spec()
            .materials
            .iter()
            .position(|m| m.name == entry.name)
        else {
            continue;
        };
        let theirs = &reader.spec().materials[from];
        if theirs.omega != entry.omega {
            return Err(Error::Mismatch {
                what: format!(
                    "ω of material `{}` in the dataset to reuse, {} (a material of that \
                     name with other parameters is another fabric: rename one)",
                    entry.name,
                    source.display()
                ),
                expected: format!("{:?}", entry.omega),
                got: format!("{:?}", theirs.omega),
            }
            .into());
        }
        shared = true;
        if shard.contains_material(to) {
            map[from] = Some(to);
        }
    }
    if !shared {
        return Err(crate::Error::NothingToReuse {
            dataset: source.to_owned(),
        });
    }
    let mut report = ImportReport {
        shared_materials: map.iter().flatten().count(),
        ..ImportReport::default()
    };
    for record in reader.samples() {
        let Some(to) = map[record.material] else {
            continue;
        };
        // Every place the destination lists this pose and its plan holds this fabric.
        let (done, todo): (Vec<usize>, Vec<usize>) = poses[record.pose]
            .iter()
            .copied()
            .filter(|&pose| dest.plan.includes(to, pose))
            .partition(|&pose| writer.is_done(to, pose));
        report.already_done += done.len();
        if todo.is_empty() {
            continue;
        }
        let arrays = reader.read_sample(record)?;
        for pose in todo {
            writer.write_sample(to, pose, &arrays, record.stats.clone())?;
            report.imported += 1;
        }
    }
    writer.flush()?;
    Ok(report)
}

/// For each pose of `source`, the indices of the same pose in `dest`, bit for bit (none if
/// `dest` lacks it). The specs' protocols are equal ([`compare_specs`]); a walk's poses are
/// the same list, so each maps to its own index, and a canonical sample, which depends on its
/// own pose alone, goes wherever `dest` lists that pose.
fn pose_map(dest: &DatasetSpec, source: &DatasetSpec) -> Vec<Vec<usize>> {
    let key =
        |p: &garmatnet_core::Pose| p.to_vec().iter().map(|v| v.to_bits()).collect::<Vec<u64>>();
    let mut index: HashMap<Vec<u64>, Vec<usize>> = HashMap::new();
    for (i, pose) in dest.poses.iter().enumerate() {
        index.entry(key(pose)).or_default().push(i);
    }
    source
        .poses
        .iter()
        .enumerate()
        .map(|(i, pose)| match dest.protocol {
            DrapeProtocol::Walk => vec![i],
            DrapeProtocol::Canonical => index.get(&key(pose)).cloned().unwrap_or_default(),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dataset::manifest::{DatasetSpec, Manifest};
    use crate::dataset::writer::tests::{arrays, stats, tiny_spec};
    use std::path::PathBuf;

    /// Sets ω's component `i` to `value`, keeping the entry's normalised ω consistent.
    fn set_omega(m: &mut crate::dataset::manifest::MaterialEntry, i: usize, value: f64) {
        m.omega[i] = value;
        m.omega_normalized = garmatnet_core::Material::from_array(m.omega)
            .unwrap()
            .to_normalized();
    }

    /// `tiny_spec` with materials `fabric1, fabric2` and a new `fabric9`.
    fn extended_spec() -> DatasetSpec {
        let mut spec = tiny_spec();
        let mut new = spec.materials[0].clone();
        new.name = "fabric9".into();
        set_omega(&mut new, 0, 99.0);
        spec.materials = vec![spec.materials[1].clone(), spec.materials[2].clone(), new];
        spec
    }

    fn source(dir: &Path) {
        let w = DatasetWriter::open(dir, tiny_spec()).unwrap();
        for m in 0..3 {
            for p in 0..3 {
                w.write_sample(m, p, &arrays(m, p), stats(1e-6 * (m + 1) as f64))
                    .unwrap();
            }
        }
    }

    /// A finished source (`tiny_spec`, poses 0..3) in `root/src` and a writer of
    /// [`extended_spec`] in `root/dst`.
    fn source_and_destination() -> (tempfile::TempDir, PathBuf, DatasetWriter) {
        let root = tempfile::tempdir().unwrap();
        let src = root.path().join("src");
        source(&src);
        let w = DatasetWriter::open(root.path().join("dst"), extended_spec()).unwrap();
        (root, src, w)
    }

    #[test]
    fn shared_materials_are_copied_to_their_new_index() {
        let (root, src, w) = source_and_destination();
        // One shared sample is done already: it must be left as it is.
        w.write_sample(0, 0, &arrays(7, 7), stats(5.0)).unwrap();
        let report = import_samples(&w, &src, Shard::ALL).unwrap();
        assert_eq!(
            report,
            ImportReport {
                shared_materials: 2,
                imported: 5,
                already_done: 1,
            }
        );
        drop(w);
        let dst = root.path().join("dst");
        let r = DatasetReader::open(&dst).unwrap();
        // Source fabric1 -> destination 0, fabric2 -> 1; fabric9 has nothing yet.
        for (from, to) in [(1, 0), (2, 1)] {
            for p in 0..3 {
                let record = r.sample(to, p).unwrap();
                if (to, p) == (0, 0) {
                    assert_eq!(r.read_sample(record).unwrap(), arrays(7, 7));
                    continue;
                }
                assert_eq!(r.read_sample(record).unwrap(), arrays(from, p));
                assert_eq!(record.stats, stats(1e-6 * (from + 1) as f64));
                assert_eq!(record.stem, format!("m{to:03}_p{p:04}"));
            }
        }
        assert!(r.sample(2, 0).is_none());
        assert_eq!(r.samples().len(), 6);
        assert_eq!(Manifest::read(&dst).unwrap().samples.len(), 6);
    }

    #[test]
    fn a_shard_imports_only_its_shared_materials() {
        let (root, src, w) = source_and_destination();
        let report = import_samples(&w, &src, Shard::new(1, 2).unwrap()).unwrap();
        assert_eq!((report.shared_materials, report.imported), (1, 3));
        // Shard 2/3 takes only the new fabric: nothing to import, and no error.
        let report = import_samples(&w, &src, Shard::new(2, 3).unwrap()).unwrap();
        assert_eq!(report, ImportReport::default());
        drop(w);
        let r = DatasetReader::open(root.path().join("dst")).unwrap();
        assert!(r.samples().iter().all(|s| s.material == 1));
    }

    #[test]
    fn other_walks_or_renamed_fabrics_are_refused_before_anything_is_written() {
        let root = tempfile::tempdir().unwrap();
        let src = root.path().join("src");
        source(&src);
        type Change = fn(&mut DatasetSpec);
        let cases: [(&str, Change); 6] = [
            ("ground-truth revision", |s| {
                s.ground_truth_revision = Some(crate::GROUND_TRUTH_REVISION + 1);
            }),
            ("ground-truth revision", |s| s.ground_truth_revision = None),
            ("poses", |s| s.poses.swap(0, 1)),
            ("solver settings", |s| {
                s.solver = serde_json::json!({ "tolerance": 1e-3 });
            }),
            ("ω of material `fabric1`", |s| {
                set_omega(&mut s.materials[0], 5, 1.0);
            }),
            ("none of this dataset's materials", |s| {
                for m in &mut s.materials {
                    m.name.push('x');
                }
            }),
        ];
        for (i, (expected, change)) in cases.into_iter().enumerate() {
            let dst = root.path().join(format!("dst{i}"));
            let mut spec = extended_spec();
            change(&mut spec);
            let w = DatasetWriter::open(&dst, spec).unwrap();
            let err = import_samples(&w, &src, Shard::ALL).unwrap_err();
            if expected == "none of this dataset's materials" {
                assert!(
                    matches!(&err, crate::Error::NothingToReuse { dataset } if *dataset == src),
                    "{err}"
                );
            }
            let err = err.to_string();
            assert!(err.contains(expected), "{expected}: {err}");
            assert!(err.contains("src"), "names the source: {err}");
            assert_eq!(w.done_count(), 0);
        }
    }

    #[test]
    fn a_missing_source_is_an_io_error() {
        let root = tempfile::tempdir().unwrap();
        let w = DatasetWriter::open(root.path().join("dst"), extended_spec()).unwrap();
        let err = import_samples(&w, &root.path().join("nowhere"), Shard::ALL).unwrap_err();
        assert!(err.to_string().contains("nowhere"), "{err}");
    }
}
