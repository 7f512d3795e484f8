//! Dataset generation end to end: a run killed mid-way resumes and finishes with the same
//! arrays as an uninterrupted run, thread counts do not change the bytes, shards split the
//! materials, slim shards (simulated garments only) merge into the same bytes, a dataset
//! with one more fabric built on an existing one equals one made from scratch, and the result
//! passes `check`.

use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};

use garmatnet_core::{Material, Resolution, SmoothingSettings};
use garmatnet_sim::{
    DrapeProtocol, DrapeSettings, Error, GenerateConfig, GenerateEvent, Manifest, MergeReport,
    MotionGenerator, SamplePlan, SequenceSettings, Shard, check, generate_dataset, merge_shards,
};

fn config(out: &Path, threads: usize, shard: Shard) -> GenerateConfig {
    let poses = MotionGenerator::new(2, 3).generate();
    GenerateConfig {
        out: out.to_owned(),
        materials: ["Cotton Poplin", "Silk Chiffon", "Denim Heavy"]
            .iter()
            .map(|n| (n.to_string(), Material::preset(n).unwrap()))
            .collect(),
        frames: (0..poses.len()).collect(),
        poses,
        resolution: Resolution::Coarse,
        sequence: SequenceSettings {
            drape: DrapeSettings {
                max_iterations: 12,
                ..DrapeSettings::default()
            },
            max_step_rad: 0.1,
            intermediate_iterations: 2,
            ..SequenceSettings::default()
        },
        smoothing: SmoothingSettings::default(),
        threads,
        shard,
        reuse: Vec::new(),
        protocol: DrapeProtocol::Walk,
        plan: SamplePlan::Full,
    }
}

fn arrays(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    for entry in walk(&dir.join("samples")) {
        if entry.extension().is_some_and(|e| e == "npy") {
            let name = entry.strip_prefix(dir).unwrap().display().to_string();
            out.push((name, std::fs::read(&entry).unwrap()));
        }
    }
    out.sort();
    out
}

fn walk(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut files = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            files.extend(walk(&p))
        } else {
            files.push(p)
        }
    }
    files
}

#[test]
fn killed_runs_resume_to_the_same_dataset_and_threads_do_not_matter() -> anyhow::Result<()> {
    let tmp = tempfile::tempdir()?;
    let whole = tmp.path().join("whole");
    let report = generate_dataset(&config(&whole, 1, Shard::new(0, 1)?), &|_| {}, &|| false)?;
    assert_eq!(report.written, 9);
    let reference = arrays(&whole);
    assert_eq!(reference.len(), 27);

    // Kill after 4 samples, then resume with 2 threads.
    let killed = tmp.path().join("killed");
    let done = AtomicUsize::new(0);
    let stop = || done.load(Ordering::SeqCst) >= 4;
    let err = generate_dataset(
        &config(&killed, 1, Shard::new(0, 1)?),
        &|event| {
            if matches!(event, GenerateEvent::Sample(_)) {
                done.fetch_add(1, Ordering::SeqCst);
            }
        },
        &stop,
    )
    .unwrap_err();
    assert!(matches!(err, Error::Interrupted), "{err}");
    // Progress starts where the dataset stands: 4 of 9 on disk, then the 5 written.
    let events = std::sync::Mutex::new(Vec::new());
    let resumed = generate_dataset(
        &config(&killed, 2, Shard::new(0, 1)?),
        &|event| events.lock().unwrap().push(event),
        &|| false,
    )?;
    assert_eq!(resumed.skipped, 4);
    assert_eq!(resumed.written, 5);
    let events = events.into_inner().unwrap();
    assert_eq!(
        events.first(),
        Some(&GenerateEvent::Started {
            shard_samples: 9,
            done: 4
        })
    );
    assert_eq!(
        events[1..]
            .iter()
            .filter(|e| matches!(e, GenerateEvent::Sample(_)))
            .count(),
        5
    );
    assert_eq!(
        arrays(&killed),
        reference,
        "resumed arrays must equal the uninterrupted run's"
    );

    let report = check(&killed)?;
    assert!(report.is_ok(), "{report}");

    // A sample lost from the middle of a walk (deleted by hand): the walk is continuous, so
    // it resumes there and drapes the finished sample after it again. That one counts as
    // written, not also as skipped (the summary added up to 10 of 9), and the bytes stay.
    std::fs::remove_dir_all(killed.join("samples/m000_p0001"))?;
    let events = std::sync::Mutex::new(Vec::new());
    let gap = generate_dataset(
        &config(&killed, 1, Shard::new(0, 1)?),
        &|event| events.lock().unwrap().push(event),
        &|| false,
    )?;
    assert_eq!((gap.skipped, gap.written), (7, 2));
    assert_eq!(
        events.into_inner().unwrap().first(),
        Some(&GenerateEvent::Started {
            shard_samples: 9,
            done: 7
        })
    );
    assert_eq!(arrays(&killed), reference);

    // One more fabric, built on `whole`: its three fabrics' samples are copied (to their
    // new indices) and only the new one is draped, to the same bytes as draping all four.
    let more = |out: &Path, reuse: Vec<std::path::PathBuf>| -> anyhow::Result<GenerateConfig> {
        let mut c = config(out, 1, Shard::new(0, 1)?);
        c.materials
            .insert(0, ("Tulle".into(), Material::preset("Tulle")?));
        c.reuse = reuse;
        Ok(c)
    };
    let fresh = tmp.path().join("fresh");
    generate_dataset(&more(&fresh, Vec::new())?, &|_| {}, &|| false)?;
    let built = tmp.path().join("built");
    let report = generate_dataset(&more(&built, vec![whole.clone()])?, &|_| {}, &|| false)?;
    assert_eq!((report.imported, report.skipped, report.written), (9, 9, 3));
    assert_eq!(arrays(&built), arrays(&fresh));
    assert!(check(&built)?.is_ok());

    // Shards split the materials and merge by copying.
    let sharded = tmp.path().join("sharded");
    let a = generate_dataset(&config(&sharded, 1, Shard::new(0, 2)?), &|_| {}, &|| false)?;
    let b = generate_dataset(&config(&sharded, 1, Shard::new(1, 2)?), &|_| {}, &|| false)?;
    assert_eq!((a.written, b.written), (6, 3));
    assert_eq!(arrays(&sharded), reference);

    // Slim samples (simulated.npy + marker only) merge into the same bytes: the smoothed
    // garment and body points are recomputed as the generator computed them.
    let slim = tmp.path().join("slim");
    std::fs::create_dir_all(&slim)?;
    std::fs::copy(whole.join("manifest.json"), slim.join("manifest.json"))?;
    for entry in std::fs::read_dir(whole.join("samples"))? {
        let entry = entry?;
        let to = slim.join("samples").join(entry.file_name());
        std::fs::create_dir_all(&to)?;
        for name in ["simulated.npy", "stats.json"] {
            std::fs::copy(entry.path().join(name), to.join(name))?;
        }
    }
    let spec = Manifest::read(&whole)?.spec;
    let merged = tmp.path().join("merged");
    let report = merge_shards(&merged, std::slice::from_ref(&slim), spec.clone())?;
    assert_eq!(
        report,
        MergeReport {
            copied: 0,
            derived: 9
        }
    );
    assert_eq!(
        arrays(&merged),
        reference,
        "derived arrays must equal the generator's"
    );
    assert!(check(&merged)?.is_ok());

    // A damaged slim sample is refused by name, and nothing of it is marked done.
    let stem = slim.join("samples").join("m001_p0002");
    std::fs::write(stem.join("simulated.npy"), b"not an npy file")?;
    let again = tmp.path().join("again");
    let err = merge_shards(&again, &[slim], spec).unwrap_err();
    assert!(err.to_string().contains("m001_p0002"), "{err}");
    assert!(!again.join("samples/m001_p0002/stats.json").exists());
    Ok(())
}

/// Issue 48: under the canonical protocol a sample's drape depends on its (pose, fabric,
/// settings) alone: the same pose and fabric give bit-identical `simulated` arrays in a
/// dataset of other poses in another order, in one shard of two, and on one thread or two.
#[test]
fn canonical_drapes_do_not_depend_on_dataset_order_shard_or_threads() -> anyhow::Result<()> {
    let tmp = tempfile::tempdir()?;
    let poses = MotionGenerator::new(5, 3).generate();
    let canonical = |out: &Path, order: &[usize], materials: &[&str], threads, shard| {
        let mut c = config(out, threads, shard);
        c.protocol = DrapeProtocol::Canonical;
        c.sequence.max_surface_step = 0.05;
        c.poses = order.iter().map(|&i| poses[i].clone()).collect();
        c.frames = order.to_vec();
        c.materials = materials
            .iter()
            .map(|n| (n.to_string(), Material::preset(n).unwrap()))
            .collect();
        c
    };
    let a = tmp.path().join("a");
    let report = generate_dataset(
        &canonical(
            &a,
            &[0, 1, 2],
            &["Cotton Poplin", "Denim Heavy"],
            1,
            Shard::new(0, 1)?,
        ),
        &|_| {},
        &|| false,
    )?;
    assert_eq!(report.written, 6);
    let b = tmp.path().join("b");
    generate_dataset(
        &canonical(
            &b,
            &[2, 0],
            &["Silk Chiffon", "Denim Heavy"],
            2,
            Shard::new(1, 2)?,
        ),
        &|_| {},
        &|| false,
    )?;
    let simulated = |dir: &Path, m: usize, p: usize| {
        let stem = garmatnet_sim::sample_stem(m, p);
        std::fs::read(dir.join("samples").join(&stem).join("simulated.npy")).unwrap()
    };
    // Denim Heavy is material 1 in both; b's poses are a's 2 and 0.
    assert_eq!(simulated(&a, 1, 2), simulated(&b, 1, 0));
    assert_eq!(simulated(&a, 1, 0), simulated(&b, 1, 1));
    assert_ne!(simulated(&a, 1, 0), simulated(&a, 1, 2));
    let manifest = Manifest::read(&a)?;
    assert_eq!(manifest.spec.protocol, DrapeProtocol::Canonical);
    assert_eq!(manifest.spec.ground_truth_revision, Some(4));
    Ok(())
}

/// A strided plan drapes the samples it holds and no others, a canonical dataset of more
/// poses builds on one of fewer (its samples go to the equal poses), and what it drapes
/// equals the same (pose, fabric) draped in any other dataset.
#[test]
fn a_strided_plan_drapes_its_samples_and_builds_on_fewer_poses() -> anyhow::Result<()> {
    let tmp = tempfile::tempdir()?;
    let poses = MotionGenerator::new(5, 4).generate();
    let canonical = |out: &Path, order: &[usize], materials: &[&str], plan| {
        let mut c = config(out, 2, Shard::ALL);
        c.protocol = DrapeProtocol::Canonical;
        c.sequence.max_surface_step = 0.05;
        c.poses = order.iter().map(|&i| poses[i].clone()).collect();
        c.frames = (0..order.len()).collect();
        c.materials = materials
            .iter()
            .map(|n| (n.to_string(), Material::preset(n).unwrap()))
            .collect();
        c.plan = plan;
        c
    };
    let three = ["Cotton Poplin", "Silk Chiffon", "Denim Heavy"];
    let a = tmp.path().join("a");
    // The source lists its poses in another order, and one the plan holds for one fabric.
    generate_dataset(
        &canonical(&a, &[1, 0, 2], &three, SamplePlan::Full),
        &|_| {},
        &|| false,
    )?;
    let b = tmp.path().join("b");
    let plan = SamplePlan::Strided {
        stride: 3,
        full_poses: 2,
    };
    let mut config_b = canonical(&b, &[0, 1, 2, 3], &three, plan);
    config_b.reuse = vec![a.clone()];
    let report = generate_dataset(&config_b, &|_| {}, &|| false)?;
    // Poses 0 and 1 for all three and pose 2 for material 2 (imported; not pose 2 for the
    // two others, outside the plan); pose 3 for material 0 (draped).
    assert_eq!(
        (report.imported, report.written, report.shard_samples),
        (7, 1, 8)
    );
    let manifest = Manifest::read(&b)?;
    assert_eq!(manifest.spec.plan, plan);
    let done: Vec<(usize, usize)> = manifest
        .samples
        .iter()
        .map(|s| (s.material, s.pose))
        .collect();
    assert_eq!(
        done,
        [
            (0, 0),
            (0, 1),
            (0, 3),
            (1, 0),
            (1, 1),
            (2, 0),
            (2, 1),
            (2, 2)
        ]
    );
    let checked = check(&b)?;
    assert!(checked.is_ok() && checked.missing.is_empty(), "{checked}");
    assert!(checked.to_string().contains("8 samples"), "{checked}");

    let simulated = |dir: &Path, m: usize, p: usize| {
        let stem = garmatnet_sim::sample_stem(m, p);
        std::fs::read(dir.join("samples").join(&stem).join("simulated.npy")).unwrap()
    };
    // Each reused sample sits at its own pose: a's pose 0 is b's pose 1, and a's 1 b's 0.
    assert_eq!(simulated(&a, 1, 0), simulated(&b, 1, 1));
    assert_eq!(simulated(&a, 0, 1), simulated(&b, 0, 0));
    assert_ne!(simulated(&a, 1, 0), simulated(&a, 1, 1));
    // Denim Heavy at pose 2, draped alone in a dataset of that one pose.
    let c = tmp.path().join("c");
    generate_dataset(
        &canonical(&c, &[2], &["Denim Heavy"], SamplePlan::Full),
        &|_| {},
        &|| false,
    )?;
    assert_eq!(simulated(&c, 0, 0), simulated(&b, 2, 2));

    // The writer refuses a sample outside the plan, by name.
    let writer = garmatnet_sim::DatasetWriter::open(&b, manifest.spec.clone())?;
    let reader = garmatnet_sim::DatasetReader::open(&a)?;
    let arrays = reader.read_sample(reader.sample(0, 0).unwrap())?;
    let stats = reader.sample(0, 0).unwrap().stats.clone();
    let err = writer.write_sample(1, 2, &arrays, stats).unwrap_err();
    assert!(
        matches!(
            err,
            Error::SampleOutsidePlan {
                material: 1,
                pose: 2,
                ..
            }
        ),
        "{err}"
    );
    drop(writer);
    // Resuming with another plan is refused, naming it.
    let mut full = manifest.spec.clone();
    full.plan = SamplePlan::Full;
    let err = garmatnet_sim::DatasetWriter::open(&b, full).unwrap_err();
    assert!(
        matches!(
            err,
            Error::SpecMismatch {
                field: garmatnet_sim::SpecField::Plan,
                ..
            }
        ),
        "{err}"
    );

    // A walk visits every pose: a strided plan is refused before anything is written.
    let walk_dir = tmp.path().join("walk");
    let mut walk = canonical(&walk_dir, &[0, 1, 2], &three, plan);
    walk.protocol = DrapeProtocol::Walk;
    let err = generate_dataset(&walk, &|_| {}, &|| false).unwrap_err();
    assert!(
        matches!(
            err,
            Error::InvalidSpec {
                field: garmatnet_sim::SpecField::Plan,
                ..
            }
        ),
        "{err}"
    );
    assert!(!walk_dir.join("manifest.json").exists());
    Ok(())
}
