//! `garmatnet ensemble`: several trained models averaged into one model file.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::Args;
use garmatnet::model::{GarMatNetModel, select_device};
use garmatnet::train::{Split, split_path};

/// The most members an ensemble takes. Its merged layer is block-diagonal over the members,
/// so the model file and each prediction grow with the square of the member count, while
/// the error stops falling after a handful of members (book/src/experiments/ensembles.md).
pub const MAX_MEMBERS: usize = 16;

/// Average models trained with different seeds into one model (the mean of their
/// predictions; one wider net of the same architecture and file format).
#[derive(Debug, Args)]
pub struct EnsembleArgs {
    /// The member models (2 to 16 different `.safetensors` files from `garmatnet train` with
    /// the same data and options except `--seed`).
    #[arg(required = true, num_args = 2..)]
    pub models: Vec<PathBuf>,
    /// The model file to write (not one of the members); the members' common split file is
    /// written next to it.
    #[arg(long)]
    pub out: PathBuf,
}

/// What makes two paths one file: the canonical path (symbolic links and `..` resolved) and,
/// on Unix, the device and inode, which hard links share.
#[derive(Debug)]
struct FileIdentity {
    canonical: PathBuf,
    #[cfg(unix)]
    inode: (u64, u64),
}

impl FileIdentity {
    /// The identity of the existing file at `path`.
    fn of(path: &Path) -> std::io::Result<Self> {
        let canonical = std::fs::canonicalize(path)?;
        #[cfg(unix)]
        let inode = {
            use std::os::unix::fs::MetadataExt;
            let meta = std::fs::metadata(&canonical)?;
            (meta.dev(), meta.ino())
        };
        Ok(Self {
            canonical,
            #[cfg(unix)]
            inode,
        })
    }

    fn same_file(&self, other: &Self) -> bool {
        #[cfg(unix)]
        if self.inode == other.inode {
            return true;
        }
        self.canonical == other.canonical
    }
}

/// Whether the files at `a` and `b` hold the same bytes (copies of one model). Members are
/// loaded whole right after, so reading them whole here costs no more memory.
fn same_bytes(a: &Path, b: &Path) -> Result<bool> {
    let read = |p: &Path| std::fs::read(p).with_context(|| format!("reading {}", p.display()));
    let length = |p: &Path| {
        std::fs::metadata(p)
            .map(|m| m.len())
            .with_context(|| format!("reading {}", p.display()))
    };
    Ok(length(a)? == length(b)? && read(a)? == read(b)?)
}

/// Refuses, before anything is loaded or written, more than [`MAX_MEMBERS`] members, a
/// member given twice (the same file, or a copy with the same bytes: averaging a model with
/// itself costs as much as another member and adds nothing), and an `out` that is one of
/// the members or their split files (writing it would destroy a member).
fn check_members(models: &[PathBuf], out: &Path) -> Result<()> {
    if models.len() > MAX_MEMBERS {
        bail!(
            "an ensemble takes at most {MAX_MEMBERS} members, got {}: its merged layer, and \
             with it the model's size and prediction time, grows with the square of the \
             member count; average at most {MAX_MEMBERS} models",
            models.len()
        );
    }
    let identities = models
        .iter()
        .map(|p| {
            FileIdentity::of(p).with_context(|| format!("opening member model {}", p.display()))
        })
        .collect::<Result<Vec<_>>>()?;
    for (i, identity) in identities.iter().enumerate() {
        for (j, earlier) in identities[..i].iter().enumerate() {
            if identity.same_file(earlier) {
                bail!(
                    "{} and {} are the same file, given twice: averaging a model with itself \
                     costs another member's size and time and improves nothing; give each \
                     member once (models trained with different `--seed`)",
                    models[j].display(),
                    models[i].display()
                );
            }
            if same_bytes(&models[j], &models[i])? {
                bail!(
                    "{} and {} are copies of one model (the same bytes): averaging a model \
                     with itself costs another member's size and time and improves nothing; \
                     give models trained with different `--seed`",
                    models[j].display(),
                    models[i].display()
                );
            }
        }
    }
    if out.exists() {
        let target = FileIdentity::of(out).with_context(|| format!("opening {}", out.display()))?;
        for (path, identity) in models.iter().zip(&identities) {
            if target.same_file(identity) {
                bail!(
                    "--out {} is the member {}: writing the ensemble there would replace the \
                     member; choose another output file",
                    out.display(),
                    path.display()
                );
            }
            let split = split_path(path);
            if let Ok(split_identity) = FileIdentity::of(&split)
                && target.same_file(&split_identity)
            {
                bail!(
                    "--out {} is the split file of the member {}: writing the ensemble there \
                     would replace it; choose another output file (`*.safetensors`)",
                    out.display(),
                    path.display()
                );
            }
        }
    }
    Ok(())
}

/// Runs the command.
pub fn run(args: &EnsembleArgs) -> Result<()> {
    check_members(&args.models, &args.out)?;
    let device = select_device("cpu")?;
    let members = args
        .models
        .iter()
        .map(|p| {
            GarMatNetModel::load(p, &device).with_context(|| format!("loading {}", p.display()))
        })
        .collect::<Result<Vec<_>>>()?;
    // Evaluation reads the split next to the model to keep its test samples out of training:
    // the members must share one, or the ensemble's development or test set could hold
    // samples one member trained on.
    let dataset_hash = &members[0].meta.provenance.dataset_hash;
    let splits = args
        .models
        .iter()
        .zip(&members)
        .map(|(path, member)| -> Result<Option<Split>> {
            let file = split_path(path);
            if !file.exists() {
                return Ok(None);
            }
            let split = Split::read(&file, dataset_hash)?;
            // A member records the split it trained with; a file next to it that is another
            // run's would hand the ensemble the wrong held-out samples.
            split.check_model(&file, path, &member.meta.provenance)?;
            Ok(Some(split))
        })
        .collect::<Result<Vec<_>>>()?;
    if let Some(i) = splits.iter().position(|s| *s != splits[0]) {
        bail!(
            "{} and {} were trained on different splits (or only one has a split file), so \
             the ensemble's held-out samples could include some a member trained on; train \
             the members with the same split options (`--seed` changes only the weights and \
             shuffles)",
            args.models[0].display(),
            args.models[i].display()
        );
    }
    let split = splits.into_iter().next().flatten();
    let mut model = GarMatNetModel::average(&members, &device)?;
    model.meta.provenance.command = std::env::args().collect::<Vec<_>>().join(" ");
    if let (Some(split), Some(extra)) = (&split, model.meta.provenance.extra.as_object_mut()) {
        // The ensemble is evaluated with its members' split, written next to it below.
        extra.insert(
            garmatnet::model::TrainingProvenance::SPLIT_FINGERPRINT_KEY.into(),
            split.fingerprint().into(),
        );
    }
    model.save(&args.out)?;
    let out_split = split_path(&args.out);
    let split_note = match split {
        Some(split) => {
            split.write(&out_split)?;
            format!(" and {}", out_split.display())
        }
        None => {
            // A split file left by the model this one replaces would describe other nets.
            if out_split.exists() {
                std::fs::remove_file(&out_split)
                    .with_context(|| format!("removing the stale {}", out_split.display()))?;
            }
            " (the members have no split file, so neither has the ensemble)".to_owned()
        }
    };
    let size = std::fs::metadata(&args.out).map(|m| m.len()).unwrap_or(0);
    outln!(
        "wrote {} ({} members, {:.1} MB){split_note}",
        args.out.display(),
        members.len(),
        size as f64 / 1e6,
    )?;
    Ok(())
}
