//! `garmatnet simulate`: generate a ground-truth dataset with the mass-spring solver.

use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};

use anyhow::{Context, Result, anyhow, bail};
use clap::Args;
use garmatnet::core::{
    MATERIAL_DIM, Material, Pose, Resolution, SmoothingSettings, SplitMix64, find_preset, presets,
    read_poses,
};
use garmatnet::sim::{
    ArmClearance, DEFAULT_ARM_CLEARANCE, DrapeProtocol, GenerateConfig, GenerateEvent, Manifest,
    MotionGenerator, MotionPace, POSE_NAMES_FILE, PoseSampler, PoseSamplerConfig, SamplePlan,
    SequenceSettings, Shard, canonical_settings, everyday_poses, generate_dataset, manifest_path,
};
use garmatnet::train::Progress;

/// Drape the T-shirt for every (material, pose) pair, or those of a strided plan, and write a
/// dataset directory.
#[derive(Debug, Args)]
pub struct SimulateArgs {
    /// `all` (the presets), or a comma-separated list of preset names, of fabrics of a
    /// `--reuse` dataset (e.g. `random-0-003`, with the ω it was made with) and of `reused`
    /// (every fabric of the `--reuse` datasets), so datasets of different fabrics merge
    /// into one: `--materials all,reused --reuse A --reuse B`; or `none`, to drape only the
    /// `--random-materials`.
    #[arg(long, default_value = "all")]
    pub materials: String,
    /// Also drape this many random materials, uniform in the normalised ω cube (after the
    /// presets; named `random-SEED-INDEX`): denser material coverage for training.
    #[arg(long, default_value_t = 0)]
    pub random_materials: usize,
    /// Seed of the random materials.
    #[arg(long, default_value_t = 0)]
    pub material_seed: u64,
    /// Draw the random materials between these presets instead (`all` or a comma-separated
    /// list, at least two): each lies at a uniform point of the segment between two distinct
    /// presets of the list in normalised ω, plus Gaussian noise of 0.03 per component,
    /// clamped to the cube, and is named `mix-SEED-INDEX`. Near the fabrics people use rather
    /// than in the cube's empty corners.
    #[arg(long, value_name = "PRESETS")]
    pub random_between: Option<String>,
    /// The poses to drape: a number N of poses made by `--motion` (N independent poses by
    /// default), `everyday` (the fixed suite of named everyday poses, for evaluation only;
    /// their names go to `pose_names.json` in `--out`), or a pose file (.json, .npz, .npy).
    #[arg(long)]
    pub poses: String,
    /// How `--poses N` draws its poses.
    #[command(flatten)]
    pub draw: PoseDrawArgs,
    /// How each sample is draped: `canonical` (default; ground-truth revisions 3 and 4: each sample
    /// on its own, from the fabric's rest drape along one path from the rest pose, so a drape
    /// depends on its pose and fabric alone) or `walk` (each pose from the previous one of
    /// the sequence, as in revisions 1 and 2; for animations).
    #[arg(long, default_value = "canonical")]
    pub protocol: DrapeProtocol,
    /// Drape each pose past the first `--full-poses` for every G-th fabric only: pose p for
    /// the fabrics m (in list order, from 0) with m % G == p % G. G times the poses for the
    /// same solver time; poses, not fabrics, limit the nets' accuracy. Canonical protocol
    /// only. Default 1: every fabric at every pose.
    #[arg(long, value_name = "G", default_value_t = 1)]
    pub fabric_stride: usize,
    /// With `--fabric-stride G`: how many of the first poses every fabric drapes (e.g. those
    /// of an existing full dataset given to `--reuse`).
    #[arg(long, value_name = "D", default_value_t = 0)]
    pub full_poses: usize,
    /// Template resolution: coarse, default or paper.
    #[arg(long, default_value = "default")]
    pub resolution: Resolution,
    /// Output dataset directory (resumed when it exists).
    #[arg(long)]
    pub out: PathBuf,
    /// Worker threads (materials run in parallel); default: all cores.
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// This machine's share, `i/k`: materials whose index % k == i.
    #[arg(long, default_value = "0/1")]
    pub shard: String,
    /// Solver settings as a JSON file (a `SequenceSettings`; missing fields take defaults).
    /// Without it, an existing dataset in `--out` resumes with the settings its manifest
    /// records (also those of an earlier version), a new one built with `--reuse` takes the
    /// first reused dataset's, and any other new one the defaults.
    #[arg(long)]
    pub solver: Option<PathBuf>,
    /// An existing dataset to build on (repeatable): its finished samples of the materials
    /// listed here too (same name and ω) are copied in first, so only the rest is draped.
    /// It must have been made with the same template and settings; under the canonical
    /// protocol its samples go to the poses of this dataset equal to theirs (so a dataset of
    /// more poses, e.g. `--poses 1400` after `--poses 200`, or poses from a file, builds on
    /// it), a walk's poses must be the same. A new `--out` takes its solver settings unless
    /// `--solver` is given.
    #[arg(long, value_name = "DIR")]
    pub reuse: Vec<PathBuf>,
    /// No progress: neither the bar on a terminal nor, elsewhere, the progress lines (one a
    /// minute; `GARMATNET_PROGRESS_SECS` sets the interval).
    #[arg(long)]
    pub quiet: bool,
}

/// How N poses are drawn (`simulate --poses N`, `poses --count N`): the seed, independent
/// poses or a walk, the arms' bands and a walk's arm clearance.
#[derive(Debug, Args)]
pub struct PoseDrawArgs {
    /// Seed of the drawn poses: pose i of independent poses depends on the seed and i alone
    /// (so 300 poses extend 200); a walk depends on the seed and its length.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// How the poses are made: `independent` (default; each pose drawn on its own
    /// within the everyday joint limits: arms hanging to overhead, in front and behind,
    /// elbows bent, torso bent and twisted, legs apart or mid-stride, weight shifted; no
    /// pose with the body through itself), or a walk for animations: `brisk` (consecutive
    /// frames distinct poses; the datasets made before independent poses were the default)
    /// or `gentle` (datasets made before the brisk pace).
    #[arg(long, default_value = "independent")]
    pub motion: MotionKind,
    /// How independent poses share each arm out between the sampler's three bands:
    /// `H,R`, the fraction hanging at the side (elevation −88° … −60°) and the fraction
    /// raised (45° … 85°); the rest lie in between (−60° … 45°). Default 0.5,0.2, the
    /// revision-3 datasets'; another share draws other poses for the same seed.
    #[arg(long, value_name = "H,R")]
    pub arm_bands: Option<String>,
    /// Fraction of independent poses whose arms are placed alike: the right arm points
    /// within 15° of the left arm's elevation and 25° of its azimuth (mirrored), as in a
    /// T-pose, an A-pose or a walk's swing. Default 0, the revision-3 and -4 datasets'
    /// (arms drawn each on its own); another fraction draws other poses for the same seed.
    #[arg(long, value_name = "P")]
    pub paired_arms: Option<f64>,
    /// Fraction of independent poses with both arms held out to the side near the
    /// horizontal (each arm's elevation −25° … 25°, azimuth −25° … 35° toward the front),
    /// as in a T-pose or arms spread for balance; `--paired-arms` applies to the rest.
    /// Default 0 (the datasets made before it); another fraction draws other poses for the
    /// same seed.
    #[arg(long, value_name = "P")]
    pub side_arms: Option<f64>,
    /// Smallest gap (metres) a walk (`--motion brisk|gentle`) keeps between the arms and the
    /// torso; 0 turns the check off, as datasets made before it existed (resume those with
    /// `--arm-clearance 0`). Independent poses let an arm press up to 3 cm into another body
    /// part instead (the body leaves the cloth a channel where parts press together).
    #[arg(long, default_value_t = DEFAULT_ARM_CLEARANCE)]
    pub arm_clearance: f64,
}

impl PoseDrawArgs {
    /// The first pose-sampler flag given (`--arm-bands H,R`, `--paired-arms P`,
    /// `--side-arms P`), as typed:
    /// settings that only independent poses drawn here can honour.
    #[must_use]
    pub fn sampler_flag(&self) -> Option<String> {
        self.arm_bands
            .as_deref()
            .map(|text| format!("--arm-bands {text}"))
            .or_else(|| self.paired_arms.map(|p| format!("--paired-arms {p}")))
            .or_else(|| self.side_arms.map(|p| format!("--side-arms {p}")))
    }

    /// The `n` poses these settings draw: independent poses of the sampler (with
    /// `--arm-bands H,R`, `--paired-arms P` and `--side-arms P` when given), or a walk
    /// keeping the arms `--arm-clearance` off the torso.
    ///
    /// # Errors
    /// `--arm-bands` that is not two fractions summing to at most 1, `--paired-arms` or
    /// `--side-arms` outside 0 … 1, any of them given with a walk; an arm clearance outside
    /// 0 … 0.1 m for a walk; a pose the sampler cannot draw.
    pub fn poses(&self, n: usize) -> Result<Vec<Pose>> {
        let arm_bands = self.arm_bands.as_deref();
        match self.motion {
            MotionKind::Independent => {
                let mut config = PoseSamplerConfig {
                    seed: self.seed,
                    ..PoseSamplerConfig::default()
                };
                if let Some(text) = arm_bands {
                    [config.hanging_fraction, config.raised_fraction] = arm_band_fractions(text)?;
                }
                if let Some(fraction) = self.paired_arms {
                    config.paired_fraction = fraction;
                }
                if let Some(fraction) = self.side_arms {
                    config.side_fraction = fraction;
                }
                let sampler = PoseSampler::new(config)
                    .context("--arm-bands, --paired-arms or --side-arms")?;
                Ok(sampler.poses(n)?)
            }
            MotionKind::Walk(pace) => {
                if let Some(flag) = self.sampler_flag() {
                    bail!(
                        "{flag} sets how independent poses are drawn, not a walk: leave out \
                         --motion {pace} or {flag}"
                    );
                }
                // Refuses a clearance outside 0 … 0.1 m with a message (the walk generator
                // clamps).
                ArmClearance::new(self.arm_clearance).context("--arm-clearance")?;
                Ok(MotionGenerator {
                    arm_clearance: self.arm_clearance,
                    ..MotionGenerator::with_pace(self.seed, n, pace)
                }
                .generate())
            }
        }
    }
}

/// How `simulate --poses N` makes its N poses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MotionKind {
    /// Independent poses from [`PoseSampler`] (the default).
    Independent,
    /// A walk from [`MotionGenerator`] at this pace.
    Walk(MotionPace),
}

impl std::fmt::Display for MotionKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            MotionKind::Independent => f.write_str("independent"),
            MotionKind::Walk(pace) => pace.fmt(f),
        }
    }
}

impl std::str::FromStr for MotionKind {
    type Err = String;

    fn from_str(s: &str) -> std::result::Result<Self, String> {
        if s.trim().eq_ignore_ascii_case("independent") {
            return Ok(MotionKind::Independent);
        }
        s.parse::<MotionPace>().map(MotionKind::Walk).map_err(|_| {
            format!(
                "unknown motion `{s}`: use `independent` (the default: independent poses), \
                 `brisk` (a walk, the datasets made before independent poses) or `gentle` \
                 (a walk, the datasets made before the brisk pace)"
            )
        })
    }
}

/// Adds fabric `name` to `list` (name, material, named explicitly) unless it is there: a
/// fabric reached again with the same ω is listed once; two of one name with different ω,
/// or one named explicitly twice, is an error.
fn add_fabric(
    list: &mut Vec<(String, Material, bool)>,
    name: &str,
    material: Material,
    explicit: bool,
) -> Result<()> {
    match list.iter().find(|(n, _, _)| n == name) {
        None => list.push((name.to_owned(), material, explicit)),
        Some((_, m, _)) if m.as_array() != material.as_array() => bail!(
            "two fabrics are named `{name}` with different parameters ({:?} and {:?}): \
             a material of that name with other parameters is another fabric; rename \
             one, leave one out of --materials, or draw with another --material-seed",
            m.as_array(),
            material.as_array()
        ),
        Some((_, _, true)) if explicit => bail!("material `{name}` is listed twice"),
        Some(_) => {}
    }
    Ok(())
}

/// The fabrics `--materials` (or `--random-between`) names: `all` (the presets) and preset
/// names, plus fabrics of the datasets in `reuse` by name (with the ω they were made with)
/// and `reused` for all of them, in the order given. A fabric reached twice through `all` or `reused` is listed once; one named
/// twice, or two of one name with different ω, is an error. `none` alone names no fabric
/// (an empty list: the caller decides whether that leaves anything to do).
pub fn resolve_materials(spec: &str, reuse: &[PathBuf]) -> Result<Vec<(String, Material)>> {
    let mut reused: Vec<(String, Material)> = Vec::new();
    for dir in reuse {
        let manifest = Manifest::read(dir)
            .with_context(|| format!("reading the dataset to reuse in {}", dir.display()))?;
        for entry in &manifest.spec.materials {
            let material = Material::from_array(entry.omega)
                .with_context(|| format!("material `{}` of {}", entry.name, dir.display()))?;
            reused.push((entry.name.clone(), material));
        }
    }
    let mut out: Vec<(String, Material, bool)> = Vec::new();
    let mut add = |name: &str, material: Material, explicit: bool| {
        add_fabric(&mut out, name, material, explicit)
    };
    let items: Vec<&str> = spec
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .collect();
    if items.is_empty() {
        bail!(
            "no fabric named: give `all`, preset names (see `garmatnet materials`), fabrics \
             of a --reuse dataset, or `none`"
        );
    }
    if items.iter().any(|i| i.eq_ignore_ascii_case("none")) {
        if items.len() > 1 {
            bail!("`none` names no fabric, so it stands alone: drop it or the other names");
        }
        return Ok(Vec::new());
    }
    for item in items {
        if item.eq_ignore_ascii_case("all") {
            for p in presets() {
                add(p.name, p.material, false)?;
            }
        } else if item.eq_ignore_ascii_case("reused") {
            if reuse.is_empty() {
                bail!("--materials reused takes the fabrics of the --reuse datasets: give one");
            }
            for (name, material) in &reused {
                add(name, *material, false)?;
            }
        } else if let Some((name, material)) = reused.iter().find(|(n, _)| n == item) {
            add(name, *material, true)?;
        } else {
            let preset = find_preset(item).map_err(|e| {
                if reuse.is_empty() {
                    anyhow::Error::from(e)
                } else {
                    anyhow::anyhow!("{e}; nor is it a fabric of the --reuse datasets")
                }
            })?;
            add(preset.name, preset.material, true)?;
        }
    }
    Ok(out.into_iter().map(|(n, m, _)| (n, m)).collect())
}

/// `count` materials uniform in the normalised ω cube from `seed`, named `random-SEED-INDEX`.
pub fn random_materials(count: usize, seed: u64) -> Result<Vec<(String, Material)>> {
    let mut rng = SplitMix64::new(seed);
    (0..count)
        .map(|i| {
            let omega: [f64; MATERIAL_DIM] = std::array::from_fn(|_| rng.next_f64());
            Ok((
                format!("random-{seed}-{i:03}"),
                Material::from_normalized(omega)?,
            ))
        })
        .collect()
}

/// Standard deviation of the noise added to each normalised component of a material drawn
/// between two presets ([`mixed_materials`]).
pub const MIX_NOISE: f64 = 0.03;

/// `count` materials between pairs of `anchors` from `seed`, named `mix-SEED-INDEX`: each at a
/// uniform point of the segment between two distinct anchors in normalised ω, plus Gaussian
/// noise of [`MIX_NOISE`] per component, clamped to the unit cube.
pub fn mixed_materials(
    count: usize,
    seed: u64,
    anchors: &[(String, Material)],
) -> Result<Vec<(String, Material)>> {
    if count > 0 && anchors.len() < 2 {
        bail!(
            "--random-between needs at least two presets to draw between, got {}",
            anchors.len()
        );
    }
    let normalised: Vec<[f64; MATERIAL_DIM]> =
        anchors.iter().map(|(_, m)| m.to_normalized()).collect();
    let mut rng = SplitMix64::new(seed);
    (0..count)
        .map(|i| {
            let a = rng.below(normalised.len());
            let b = (a + 1 + rng.below(normalised.len() - 1)) % normalised.len();
            let t = rng.next_f64();
            let (a, b) = (normalised[a], normalised[b]);
            let omega: [f64; MATERIAL_DIM] = std::array::from_fn(|k| {
                (a[k] + t * (b[k] - a[k]) + MIX_NOISE * rng.normal()).clamp(0.0, 1.0)
            });
            Ok((
                format!("mix-{seed}-{i:03}"),
                Material::from_normalized(omega)?,
            ))
        })
        .collect()
}

/// Whether `e` is the refusal of a dataset whose spec differs in `field`.
fn is_spec_mismatch(e: &garmatnet::sim::Error, field: garmatnet::sim::SpecField) -> bool {
    matches!(e, garmatnet::sim::Error::SpecMismatch { field: f, .. } if *f == field)
}

/// The most frames `--poses N` generates: at about 5 s a drape (default resolution, one
/// core) that is six days per fabric, and the motion is held in memory at once.
pub const MAX_GENERATED_POSES: usize = 100_000;

/// `--arm-bands H,R`: the fractions of arms hanging and raised.
fn arm_band_fractions(text: &str) -> Result<[f64; 2]> {
    let usage = "give two fractions, hanging then raised, e.g. 0.3,0.15";
    let values = text
        .split(',')
        .map(|v| v.trim().parse::<f64>())
        .collect::<std::result::Result<Vec<_>, _>>()
        .map_err(|e| anyhow!("--arm-bands {text}: {e}; {usage}"))?;
    let [hanging, raised] = values[..] else {
        bail!("--arm-bands {text}: {usage}");
    };
    if !(0.0..=1.0).contains(&hanging) || !(0.0..=1.0).contains(&raised) || hanging + raised > 1.0 {
        bail!(
            "--arm-bands {text}: each fraction lies in 0 … 1 and together they make at most 1 \
             (the rest of the arms lie between hanging and raised); {usage}"
        );
    }
    Ok([hanging, raised])
}

/// Runs the command.
pub fn run(args: &SimulateArgs) -> Result<()> {
    let mut listed: Vec<(String, Material, bool)> =
        resolve_materials(&args.materials, &args.reuse)?
            .into_iter()
            .map(|(name, material)| (name, material, true))
            .collect();
    let drawn = match &args.random_between {
        Some(_) if args.random_materials == 0 => {
            bail!("--random-between says where to draw --random-materials N: give N too")
        }
        Some(spec) => mixed_materials(
            args.random_materials,
            args.material_seed,
            &resolve_materials(spec, &[]).context("--random-between")?,
        )?,
        None => random_materials(args.random_materials, args.material_seed)?,
    };
    // A drawn fabric that `reused` already brought in (same name and ω) is listed once.
    for (name, material) in drawn {
        add_fabric(&mut listed, &name, material, false)?;
    }
    let materials: Vec<(String, Material)> = listed
        .into_iter()
        .map(|(name, material, _)| (name, material))
        .collect();
    if materials.is_empty() {
        bail!("--materials none leaves nothing to drape: add --random-materials N");
    }
    // Refuses a clearance outside 0 … 0.1 m with a message (the walk generator clamps).
    ArmClearance::new(args.draw.arm_clearance).context("--arm-clearance")?;
    let mut pose_names = None;
    let count = args.poses.parse::<usize>().ok();
    if let Some(flag) = args.draw.sampler_flag().filter(|_| count.is_none()) {
        bail!("{flag} sets how independent poses are drawn: give --poses N, or leave it out");
    }
    let poses = match count {
        Some(0) => bail!("--poses 0: ask for at least one pose"),
        Some(n) if n > MAX_GENERATED_POSES => bail!(
            "--poses {n}: --motion makes at most {MAX_GENERATED_POSES} frames (about 5 s of \
             solver time each); for more pass a pose file"
        ),
        Some(n) => args.draw.poses(n)?,
        None if args.poses.trim().eq_ignore_ascii_case("everyday") => {
            let suite = everyday_poses();
            pose_names = Some(suite.iter().map(|p| p.name).collect::<Vec<_>>());
            suite.into_iter().map(|p| p.pose).collect()
        }
        None => read_poses(std::path::Path::new(&args.poses))
            .with_context(|| format!("reading poses from {}", args.poses))?,
    };
    let sequence = match &args.solver {
        Some(path) => super::read_settings_file::<SequenceSettings>(path)?,
        None => {
            // Resuming keeps the dataset's own settings; a new dataset built on another
            // takes that one's, so its samples are walks this dataset would make.
            let (made, what) = if manifest_path(&args.out).exists() {
                (Some(&args.out), "resume")
            } else {
                (args.reuse.first(), "reuse")
            };
            match made {
                Some(dir) => {
                    let existing = Manifest::read(dir).with_context(|| {
                        format!("reading the dataset to {what} in {}", dir.display())
                    })?;
                    SequenceSettings::from_manifest(&existing.spec.solver).with_context(|| {
                        format!("the solver settings of the dataset in {}", dir.display())
                    })?
                }
                None => match args.protocol {
                    DrapeProtocol::Canonical => canonical_settings(),
                    DrapeProtocol::Walk => SequenceSettings::default(),
                },
            }
        }
    };
    let plan = match (args.fabric_stride, args.full_poses) {
        (0, _) => bail!("--fabric-stride 0: give 1 (every fabric at every pose) or more"),
        (1, 0) => SamplePlan::Full,
        (1, d) => bail!(
            "--full-poses {d} says how many poses every fabric drapes before --fabric-stride \
             takes over: give --fabric-stride G with G of 2 or more too"
        ),
        (stride, full_poses) => SamplePlan::Strided { stride, full_poses },
    };
    let config = GenerateConfig {
        out: args.out.clone(),
        frames: (0..poses.len()).collect(),
        poses,
        materials,
        resolution: args.resolution,
        sequence,
        smoothing: SmoothingSettings::default(),
        threads: args.threads,
        shard: Shard::parse(&args.shard)?,
        reuse: args.reuse.clone(),
        protocol: args.protocol,
        plan,
    };
    let shard_samples: usize = (0..config.materials.len())
        .filter(|&m| config.shard.contains_material(m))
        .map(|m| config.plan.material_sample_count(m, config.poses.len()))
        .sum();
    let progress = Progress::stderr(
        shard_samples as u64,
        "samples",
        "{bar:40} {pos}/{len} samples  {elapsed} elapsed, ETA {eta}  {msg}",
        args.quiet,
    );
    // Whether `--out` held a dataset before this run (a spec mismatch is then `--out`'s own,
    // not a `--reuse` source's).
    let resuming = manifest_path(&config.out).exists();
    let not_converged = AtomicUsize::new(0);
    let report = generate_dataset(
        &config,
        &|event| match event {
            GenerateEvent::Started {
                shard_samples,
                done,
            } => {
                progress.start_at(shard_samples as u64, done as u64);
            }
            GenerateEvent::Sample(sample) => {
                if !sample.converged {
                    let n = not_converged.fetch_add(1, Ordering::Relaxed) + 1;
                    progress.set_message(&format!(
                        "{n} not converged (last: m{} p{})",
                        sample.material, sample.pose
                    ));
                }
                progress.inc(1);
            }
        },
        // Never asked to stop: a killed run loses at most the samples in flight (one per
        // worker), since every file is written atomically and the run resumes.
        &|| false,
    );
    progress.finish();
    let report = match report {
        Err(e) if resuming && is_spec_mismatch(&e, garmatnet::sim::SpecField::Plan) => {
            return Err(e).context(format!(
                "{} was made with another sample plan: resume it with the --fabric-stride and \
                 --full-poses it was made with (its manifest's `plan`; none: neither flag)",
                args.out.display()
            ));
        }
        Err(e)
            if resuming
                && is_spec_mismatch(&e, garmatnet::sim::SpecField::Poses)
                && count.is_some() =>
        {
            return Err(e).context(format!(
                "{} was made with other poses than `--poses {} --motion {} --seed {} \
                 --arm-clearance {}` (and `--arm-bands`, if given) gives; resume it with the \
                 motion, seed, arm bands and clearance it was made with (walks made before \
                 independent poses were the default: \
                 `--motion brisk`; before the arm clearance existed: also `--arm-clearance 0`; \
                 before the brisk pace: `--motion gentle --arm-clearance 0`)",
                args.out.display(),
                args.poses,
                args.draw.motion,
                args.draw.seed,
                args.draw.arm_clearance
            ));
        }
        other => other?,
    };
    if let Some(names) = &pose_names {
        let text = serde_json::to_string_pretty(names)?;
        garmatnet::core::write_bytes_atomic(args.out.join(POSE_NAMES_FILE), text.as_bytes())
            .context("writing the everyday poses' names")?;
    }
    outln!(
        "{}: wrote {} samples ({} already done, {} of them copied from --reuse; {} in this shard), {} not converged; {:.0} ms per sample per worker, {:.1} s in all",
        args.out.display(),
        report.written,
        report.skipped,
        report.imported,
        report.shard_samples,
        report.not_converged,
        report.mean_sample_ms,
        report.wall_time_s
    )?;
    Ok(())
}
