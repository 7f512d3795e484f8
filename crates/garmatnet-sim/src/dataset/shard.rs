//! Splitting dataset generation across processes and merging the results.

use std::path::{Path, PathBuf};

use garmatnet_core::{Error, Result};

use crate::dataset::manifest::{DatasetSpec, Manifest};
use crate::dataset::sample_arrays::read_simulated;
use crate::dataset::sample_deriver::SampleDeriver;
use crate::dataset::writer::{DatasetWriter, ensure_same_spec, samples_dir, scan_samples};

/// A subset of a dataset's work: shard `index` of `count` takes the materials whose index
/// `% count == index`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// This shard, `0..count`.
    pub index: usize,
    /// Number of shards (≥ 1).
    pub count: usize,
}

impl Shard {
    /// The whole dataset as one shard.
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    /// Shard `index` of `count`.
    ///
    /// # Errors
    /// [`crate::Error::InvalidShard`] unless `index < count`.
    pub fn new(index: usize, count: usize) -> crate::Result<Self> {
        if index >= count {
            return Err(crate::Error::InvalidShard {
                text: format!("{index}/{count}"),
                count: Some(count),
            });
        }
        Ok(Self { index, count })
    }

    /// Parses `"i/k"`, as given on the command line.
    ///
    /// # Errors
    /// [`crate::Error::InvalidShard`] for anything but two integers with `i < k`.
    pub fn parse(text: &str) -> crate::Result<Self> {
        let bad = |count| crate::Error::InvalidShard {
            text: text.to_owned(),
            count,
        };
        let (i, k) = text.split_once('/').ok_or_else(|| bad(None))?;
        let count: usize = k.trim().parse().map_err(|_| bad(None))?;
        let index = i.trim().parse().map_err(|_| bad(Some(count)))?;
        Self::new(index, count).map_err(|_| bad(Some(count)))
    }

    /// Whether this shard computes the samples of `material`.
    #[must_use]
    pub fn contains_material(&self, material: usize) -> bool {
        material % self.count == self.index
    }
}

/// What [`merge_shards`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct MergeReport {
    /// Samples copied with all their arrays.
    pub copied: usize,
    /// Slim samples (only `simulated.npy` and `stats.json`) whose smoothed garment and body
    /// points were recomputed ([`SampleDeriver`]) before they were written.
    pub derived: usize,
}

/// The arrays a slim sample leaves out: [`SampleDeriver`] recomputes them from
/// `simulated.npy` and the spec.
const DERIVED_FILES: [&str; 2] = ["smoothed.npy", "body.npy"];

/// Merges shard outputs into `dest`: copies every finished sample directory of each source
/// (all written with `spec`) into `dest`, then opens `dest` so its manifest lists them all.
///
/// A source sample may be *slim*: only `simulated.npy` and its `stats.json` marker, a third of
/// the bytes, which is how shards computed elsewhere are best carried home. Its smoothed
/// garment and body points are then recomputed from the spec exactly as the generator
/// computed them (byte for byte: tested) and the sample is written through
/// [`DatasetWriter::write_sample`], marker last.
///
/// # Errors
/// [`crate::Error::MergeIntoSource`] if a source is `dest` itself; as
/// [`DatasetWriter::open`] for `dest` and each source's manifest (a source with a
/// different spec is refused before anything is copied); [`Error::Io`] if copying fails;
/// for slim samples, [`SampleDeriver::for_spec`]'s errors and [`Error::Parse`] for a
/// malformed `simulated.npy`.
pub fn merge_shards(
    dest: impl AsRef<Path>,
    sources: &[PathBuf],
    spec: DatasetSpec,
) -> crate::Result<MergeReport> {
    let dest = dest.as_ref();
    // Merging a dataset into itself would delete each sample's marker before copying it.
    if let Ok(dest_path) = std::fs::canonicalize(dest)
        && let Some(src) = sources
            .iter()
            .find(|src| std::fs::canonicalize(src).is_ok_and(|s| s == dest_path))
    {
        return Err(crate::Error::MergeIntoSource { path: src.clone() });
    }
    // Every source is read before `dest` is created, so a missing source leaves nothing.
    let manifests = sources
        .iter()
        .map(|src| Manifest::read(src))
        .collect::<Result<Vec<_>>>()?;
    let writer = DatasetWriter::open(dest, spec)?;
    let mut plans = Vec::new();
    for (src, manifest) in sources.iter().zip(manifests) {
        ensure_same_spec(writer.spec(), &manifest.spec)?;
        plans.push((src, scan_samples(src, &manifest.spec)?));
    }
    let mut report = MergeReport::default();
    let mut deriver: Option<SampleDeriver> = None;
    for (src, records) in plans {
        for record in records {
            let from = samples_dir(src).join(&record.stem);
            if !DERIVED_FILES.iter().all(|name| from.join(name).exists()) {
                let deriver = match &mut deriver {
                    Some(deriver) => deriver,
                    empty => empty.insert(SampleDeriver::for_spec(writer.spec())?),
                };
                let x = read_simulated(&from, &record.stem)?;
                let arrays = deriver.arrays(&x, &writer.spec().poses[record.pose])?;
                writer.write_sample(record.material, record.pose, &arrays, record.stats)?;
                report.derived += 1;
                continue;
            }
            let to = samples_dir(dest).join(&record.stem);
            std::fs::create_dir_all(&to).map_err(|e| Error::io(&to, e))?;
            match std::fs::remove_file(to.join("stats.json")) {
                Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                    return Err(Error::io(&to, e).into());
                }
                _ => {}
            }
            // Marker last, through a rename, as the writer does.
            for name in ["simulated.npy", "smoothed.npy", "body.npy", "stats.json"] {
                let bytes =
                    std::fs::read(from.join(name)).map_err(|e| Error::io(from.join(name), e))?;
                garmatnet_core::write_bytes_atomic(to.join(name), &bytes)?;
            }
            report.copied += 1;
        }
    }
    drop(writer);
    // Reopen to rebuild the manifest from every marker now present.
    let spec = Manifest::read(dest)?.spec;
    DatasetWriter::open(dest, spec)?.flush()?;
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dataset::writer::tests::{arrays, stats, tiny_spec};

    #[test]
    fn shards_partition_materials_and_merge_by_copy() {
        let root = tempfile::tempdir().unwrap();
        let spec = tiny_spec();
        let shards: Vec<PathBuf> = (0..2)
            .map(|i| root.path().join(format!("shard{i}")))
            .collect();
        for (i, dir) in shards.iter().enumerate() {
            let shard = Shard::new(i, 2).unwrap();
            let w = DatasetWriter::open(dir, spec.clone()).unwrap();
            for m in (0..3).filter(|&m| shard.contains_material(m)) {
                for p in 0..4 {
                    w.write_sample(m, p, &arrays(m, p), stats(1e-6)).unwrap();
                }
            }
        }
        let merged = root.path().join("merged");
        assert_eq!(
            merge_shards(&merged, &shards, spec.clone()).unwrap(),
            MergeReport {
                copied: 12,
                derived: 0
            }
        );
        let manifest = Manifest::read(&merged).unwrap();
        assert_eq!(manifest.samples.len(), 12);
        // Plain directory copies (no merge_shards) are also picked up on open.
        let copied = root.path().join("copied");
        drop(DatasetWriter::open(&copied, spec.clone()).unwrap());
        for entry in std::fs::read_dir(samples_dir(&shards[1])).unwrap() {
            let entry = entry.unwrap();
            let to = samples_dir(&copied).join(entry.file_name());
            std::fs::create_dir_all(&to).unwrap();
            for f in std::fs::read_dir(entry.path()).unwrap() {
                let f = f.unwrap();
                std::fs::copy(f.path(), to.join(f.file_name())).unwrap();
            }
        }
        let w = DatasetWriter::open(&copied, spec.clone()).unwrap();
        assert_eq!(w.done_count(), 4);
        assert!(w.is_done(1, 3) && !w.is_done(0, 0));
        drop(w);
        // Into itself (also spelled another way): refused, every sample left in place.
        let itself = merged.join("..").join("merged");
        let err = merge_shards(&merged, &[shards[0].clone(), itself.clone()], spec).unwrap_err();
        assert!(
            matches!(&err, crate::Error::MergeIntoSource { path } if *path == itself),
            "{err}"
        );
        let err = err.to_string();
        assert!(err.contains("both a source and the destination"), "{err}");
        assert_eq!(Manifest::read(&merged).unwrap().samples.len(), 12);
        assert_eq!(scan_samples(&merged, &tiny_spec()).unwrap().len(), 12);
    }

    #[test]
    fn shards_of_two_ground_truth_revisions_are_not_merged() {
        let root = tempfile::tempdir().unwrap();
        let mut older = tiny_spec();
        older.ground_truth_revision = None;
        let shards: Vec<PathBuf> = [tiny_spec(), older]
            .into_iter()
            .enumerate()
            .map(|(i, spec)| {
                let dir = root.path().join(format!("shard{i}"));
                let w = DatasetWriter::open(&dir, spec).unwrap();
                w.write_sample(i, 0, &arrays(i, 0), stats(1e-6)).unwrap();
                dir
            })
            .collect();
        let merged = root.path().join("merged");
        let err = merge_shards(&merged, &shards, tiny_spec())
            .unwrap_err()
            .to_string();
        assert!(err.contains("ground-truth revision"), "{err}");
        assert_eq!(
            DatasetWriter::open(&merged, tiny_spec())
                .unwrap()
                .done_count(),
            0,
            "nothing was copied"
        );
    }

    #[test]
    fn shard_parsing() {
        assert_eq!(Shard::parse("1/4").unwrap(), Shard { index: 1, count: 4 });
        for (bad, count) in [
            ("4/4", Some(4)),
            ("1", None),
            ("a/b", None),
            ("0/0", Some(0)),
            ("-1/3", Some(3)),
        ] {
            assert!(
                matches!(
                    Shard::parse(bad),
                    Err(crate::Error::InvalidShard { ref text, count: c }) if text == bad && c == count
                ),
                "{bad}"
            );
        }
        assert!(matches!(
            Shard::new(2, 2),
            Err(crate::Error::InvalidShard { count: Some(2), .. })
        ));
        let err = Shard::parse("4/4").unwrap_err().to_string();
        assert!(err.contains("0/4 .. 3/4"), "{err}");
        let s = Shard::new(2, 3).unwrap();
        assert_eq!(
            (0..9)
                .filter(|&m| s.contains_material(m))
                .collect::<Vec<_>>(),
            vec![2, 5, 8]
        );
    }
}
