//! `garmatnet drape`: one prediction from a script, written by file extension.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use garmatnet::core::{
    DrapeSequence, DrapeView, OutputFormat, compare_path, comparison_image, resolve_material,
    vertex_errors_mm,
};
use garmatnet::core::{JointLimits, MATERIAL_DIM, Real, parse_omega, read_pose_frame_rate};
use garmatnet::model::{
    Detail, FAR_FROM_TRAINING, FabricCalibration, Predictor, PushOut, SEQUENCE_BATCH,
    default_model_path, select_device,
};
use garmatnet::sim::SequenceSettings;
use garmatnet::sim::{
    canonical_settings, resolve_frames, resolve_pose, simulate_drape, simulate_sequence,
};
use garmatnet::{CapsuleBody, Garment, GarmentMesh, Material, Pose, TriMesh};

/// Predict the T-shirt for one pose and fabric and write it.
#[derive(Debug, Args)]
pub struct DrapeArgs {
    /// Model file (default: the shipped model, or $GARMATNET_MODEL).
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// A fabric preset name (see `garmatnet materials`) or six physical values
    /// (N/m ×5, kg/m²) separated by commas. Default: Cotton Poplin.
    #[arg(long)]
    pub material: Option<String>,
    /// The material as normalised ω: six numbers in [0, 1] separated by commas (overrides
    /// --material).
    #[arg(long)]
    pub omega: Option<String>,
    /// A calibrated fabric from `garmatnet calibrate` (JSON) instead of --material or
    /// --omega: the model's training fabrics blended to match the fabric's simulated drape.
    #[arg(long, conflicts_with_all = ["material", "omega"])]
    pub calibration: Option<PathBuf>,
    /// A frame of the built-in motion sequence, a pose file (.json, .npz, .npy), `everyday`
    /// (the suite of named everyday poses: `--frame N` picks one, `--frames all` takes them
    /// all; `garmatnet simulate --poses everyday` lists their names) or `everyday:NAME` (one
    /// of them, e.g. `everyday:hands-on-hips`). Default: the T-pose (SMPL's zero pose).
    #[arg(long)]
    pub pose: Option<String>,
    /// Which pose of a pose file or of `--pose everyday` (default 0).
    #[arg(long, conflicts_with = "frames")]
    pub frame: Option<usize>,
    /// Predict a sequence instead of one pose: `START..END` (END excluded), `START..=END`,
    /// `START..` or `all` of the pose file's poses (`--pose FILE` or `--pose everyday`), or
    /// of the built-in motion without `--pose`. A .glb output becomes one animation (garment
    /// and body); .obj, .ply and .png outputs one file a frame, numbered (`drape.0012.obj`).
    /// With `--compare`, the simulator drapes the same frames (seconds a frame) and its
    /// garment joins the animation.
    #[arg(long)]
    pub frames: Option<String>,
    /// Frames per second of a `--frames` animation. Default: the pose file's own (an AMASS
    /// `.npz`'s `mocap_framerate`), else 30.
    #[arg(long, requires = "frames")]
    pub fps: Option<f64>,
    /// `full` (both nets) or `smooth` (the generally-fitting net only).
    #[arg(long, default_value = "full")]
    pub detail: Detail,
    /// Compute device: cpu, gpu or auto.
    #[arg(long, default_value = "cpu")]
    pub device: String,
    /// Output file(s): .obj (garment), .glb (garment + body), .ply (garment), .png (render).
    /// Repeat for several.
    #[arg(long, required = true)]
    pub out: Vec<PathBuf>,
    /// Also drape with the simulator, print the error (mm) and speed-up, and write
    /// `<out>_compare.png` next to each PNG output (prediction | simulation | error map).
    /// One pose is draped by the canonical protocol, as a dataset drapes it;
    /// `--frames` are walked in order, as an animation moves.
    #[arg(long)]
    pub compare: bool,
    /// Keep vertices the network put inside the body where they are.
    #[arg(long)]
    pub no_push_out: bool,
    /// Push the triangles out of the body between their vertices too, as the ground truth's
    /// drapes are (`garmatnet_core::push_mesh_outside`; off by default).
    #[arg(long, conflicts_with = "no_push_out")]
    pub push_faces: bool,
    /// Predict without mirror averaging: the nets' garment at the pose alone, not averaged
    /// with the mirror image of their garment at the mirrored pose (half the nets' time; a
    /// symmetric pose may then get a lopsided garment). A `--calibration` was fitted to
    /// mirror-averaged predictions, and its reference errors describe those.
    #[arg(long)]
    pub no_mirror_averaging: bool,
}

/// Runs the command.
pub fn run(args: &DrapeArgs) -> Result<()> {
    // Refuse unknown formats before any work, so no output is half-done.
    for out in &args.out {
        OutputFormat::from_path(out)?;
    }
    // The material in physical units (for the simulator) and its normalised ω (for the
    // nets), each as given: ω given goes to the predictor as written, a preset or physical
    // values to the simulator unchanged.
    let (material, omega, fabric) = match &args.calibration {
        Some(path) => {
            let calibration = FabricCalibration::load(path)?;
            let omega = calibration.omega;
            let material = Material::from_normalized(omega)?;
            (material, omega, Fabric::Calibrated(Box::new(calibration)))
        }
        None => {
            let (material, omega) = match args.omega.as_deref() {
                Some(text) => {
                    let omega = parse_omega(text)?;
                    (Material::from_normalized(omega)?, omega)
                }
                None => {
                    let material =
                        resolve_material(args.material.as_deref(), None, "Cotton Poplin")?;
                    (material, material.to_normalized())
                }
            };
            (material, omega, Fabric::Omega(omega))
        }
    };
    if let Some(fps) = args.fps
        && !(fps.is_finite() && fps > 0.0)
    {
        bail!("--fps must be a positive number of frames a second, got {fps:?}");
    }
    let sequence = match &args.frames {
        Some(frames) => {
            if args
                .pose
                .as_deref()
                .is_some_and(|p| p.trim().parse::<usize>().is_ok())
            {
                bail!(
                    "--pose names one frame of the built-in motion; with --frames, leave --pose \
                     out (frames of the built-in motion) or give a pose file"
                );
            }
            Some(resolve_frames(args.pose.as_deref(), frames)?)
        }
        None => None,
    };
    // A sequence brings its own poses; only a single prediction reads `--pose`/`--frame`.
    let pose = match sequence {
        Some(_) => Pose::zero(),
        None => resolve_pose(args.pose.as_deref(), args.frame)?,
    };
    let device = select_device(&args.device)?;
    let model_path = args.model.clone().unwrap_or_else(default_model_path);
    let mut predictor = Predictor::from_file(&model_path, &device)?;
    if args.no_push_out || args.push_faces {
        predictor = predictor.with_push_out(PushOut {
            enabled: !args.no_push_out,
            faces: args.push_faces,
            ..PushOut::default()
        })?;
    }
    if args.no_mirror_averaging {
        predictor = predictor.with_mirror_averaging(false)?;
    }
    if let Fabric::Calibrated(calibration) = &fabric {
        calibration.check_for(&predictor).with_context(|| {
            format!(
                "{} with {}",
                args.calibration
                    .as_ref()
                    .map_or_else(String::new, |p| p.display().to_string()),
                model_path.display()
            )
        })?;
        outln!(
            "calibrated fabric {}: at its reference pose the nets erred {:.2} mm, the blend \
             {:.2} mm",
            calibration.name,
            calibration.reference_error_mm,
            calibration.calibrated_reference_error_mm
        )?;
    }
    if let Some(range) = predictor.material_range() {
        let outside = range.outside(&omega);
        if !outside.is_empty() {
            let parts: Vec<String> = outside.iter().map(ToString::to_string).collect();
            warnln!(
                "warning: the material lies outside the fabrics {} was trained on ({}): the \
                 prediction is an extrapolation, expect larger errors",
                model_path.display(),
                parts.join("; ")
            );
        }
    }
    if let Some((nearest, distance)) = predictor.nearest_training_fabric(&material) {
        outln!(
            "nearest training fabric: {} ({distance:.3} away in normalised ω)",
            nearest.name
        )?;
        if distance >= FAR_FROM_TRAINING {
            warnln!(
                "warning: the material is {distance:.3} from the nearest fabric {} was trained \
                 on ({}); at {FAR_FROM_TRAINING} and beyond, fabrics models never saw \
                 erred about twice as much as nearer ones on revision 2's data \
                 (book/src/api.md): expect a larger error",
                model_path.display(),
                nearest.name
            );
        }
    }
    // Training poses are drawn within the everyday limits (the pose sampler's; the built-in
    // walk keeps to the narrower defaults inside them): a pose beyond them is an
    // extrapolation for every model.
    let limits = JointLimits::everyday();
    let single = [(0, pose.clone())];
    let frames = sequence.as_deref().unwrap_or(&single);
    let mut beyond = frames
        .iter()
        .filter_map(|(i, p)| limits.validate(p, 1e-6).err().map(|e| (*i, e)));
    if let Some((frame, first)) = beyond.next() {
        let which = match &sequence {
            Some(_) => format!(
                "{} of the frames, first frame {frame}: ",
                1 + beyond.count()
            ),
            None => String::new(),
        };
        warnln!(
            "warning: the pose lies outside the joint limits training poses are drawn within \
             (JointLimits::everyday; {which}{first}): the prediction is an extrapolation, expect \
             larger errors"
        );
    }
    if let Some(sequence) = sequence {
        return write_sequence(args, &predictor, &model_path, &material, &fabric, &sequence);
    }
    let poses = std::slice::from_ref(&pose);
    // The first call warms the backend up; time the second.
    fabric.predict(&predictor, poses, args.detail)?;
    let started = Instant::now();
    let mesh = fabric
        .predict(&predictor, poses, args.detail)?
        .pop()
        .context("the predictor returned no garment")?;
    let predict_ms = started.elapsed().as_secs_f64() * 1e3;
    outln!(
        "predicted {} vertices ({} detail) in {predict_ms:.2} ms with {}",
        mesh.vertices.len(),
        args.detail,
        model_path.display()
    )?;
    let garment = mesh.into_tri_mesh()?;
    let body = predictor
        .body()
        .context("the predictor has no body")?
        .pose(&pose)
        .mesh();
    let view = DrapeView {
        body: &body,
        garment: &garment,
        garment_colors: None,
    };
    for out in &args.out {
        view.write(out)
            .with_context(|| format!("writing {}", out.display()))?;
        outln!("wrote {}", out.display())?;
    }
    if args.compare {
        let body_model = CapsuleBody::smpl_neutral();
        let info = &predictor.model().meta.template;
        let template = Garment::for_template(info.resolution, &info.hash, &body_model)?;
        let sim = simulate_drape(
            &template,
            &body_model,
            &pose,
            &material,
            &canonical_settings(),
        )?;
        let errors = vertex_errors_mm(&garment.vertices, &sim.vertices)?;
        let mean = errors.iter().sum::<f64>() / errors.len() as f64;
        let max = errors.iter().copied().fold(0.0, f64::max);
        outln!(
            "simulator: {:.0} ms{}; prediction error mean {mean:.2} mm, max {max:.2} mm; \
             speed-up {:.0}x",
            sim.wall_ms,
            if sim.converged {
                ""
            } else {
                " (not converged)"
            },
            sim.wall_ms / predict_ms
        )?;
        let truth = TriMesh::new(sim.vertices, garment.faces.to_vec())?;
        for out in args
            .out
            .iter()
            .filter(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")))
        {
            let path = compare_path(out);
            let image = comparison_image(&body, &garment, &truth, &errors, 20.0)?;
            garmatnet::core::render::save_png(&path, &image)?;
            outln!(
                "wrote {} (prediction | simulation | error, red = 20 mm)",
                path.display()
            )?;
        }
    }
    Ok(())
}

/// The frame rate of a `--frames` animation when neither `--fps` nor the pose file gives one.
const DEFAULT_FPS: f64 = 30.0;

/// What the nets drape: a fabric by its ω, or a calibrated fabric (`--calibration`).
enum Fabric {
    /// Normalised ω.
    Omega([Real; MATERIAL_DIM]),
    Calibrated(Box<FabricCalibration>),
}

impl Fabric {
    /// The garments at `poses`, each pushed out of its posed body as `Predictor::predict`
    /// pushes one.
    fn predict(
        &self,
        predictor: &Predictor,
        poses: &[Pose],
        detail: Detail,
    ) -> Result<Vec<GarmentMesh>> {
        Ok(match self {
            Fabric::Omega(omega) => predictor.predict_sequence_normalized(poses, omega, detail)?,
            Fabric::Calibrated(calibration) => {
                predictor.predict_calibrated_sequence(poses, calibration, detail)?
            }
        })
    }
}

/// Predicts `sequence` (frame number, pose) in batches, pushed out of the body as a single
/// prediction is, and writes every output.
fn write_sequence(
    args: &DrapeArgs,
    predictor: &Predictor,
    model_path: &std::path::Path,
    material: &Material,
    fabric: &Fabric,
    sequence: &[(usize, Pose)],
) -> Result<()> {
    // Read before any work, so a malformed rate in the file stops the run at once.
    let fps = match (args.fps, args.pose.as_deref()) {
        (Some(fps), _) => fps,
        (None, Some(file)) => read_pose_frame_rate(file)?.unwrap_or(DEFAULT_FPS),
        (None, None) => DEFAULT_FPS,
    };
    let poses: Vec<Pose> = sequence.iter().map(|(_, p)| p.clone()).collect();
    // A first batch warms the backend up, so the timing is the steady state's.
    fabric.predict(
        predictor,
        &poses[..poses.len().min(SEQUENCE_BATCH)],
        args.detail,
    )?;
    let started = Instant::now();
    let predicted = fabric.predict(predictor, &poses, args.detail)?;
    let total_ms = started.elapsed().as_secs_f64() * 1e3;
    let garments = predicted
        .into_iter()
        .map(GarmentMesh::into_tri_mesh)
        .collect::<Result<Vec<_>, _>>()?;
    let (first, last) = (sequence[0].0, sequence[sequence.len() - 1].0);
    outln!(
        "predicted frames {first}..={last} ({} frames, {} detail) in {total_ms:.1} ms, \
         {:.2} ms a frame, with {}",
        sequence.len(),
        args.detail,
        total_ms / sequence.len() as f64,
        model_path.display()
    )?;
    let body = predictor.body().context("the predictor has no body")?;
    let frames: Vec<usize> = sequence.iter().map(|(f, _)| *f).collect();
    let simulated = if args.compare {
        Some(compare_sequence(
            predictor, body, &frames, &poses, material, &garments, total_ms,
        )?)
    } else {
        None
    };
    let view = DrapeSequence {
        frames: &frames,
        body,
        poses: &poses,
        garments: &garments,
        simulated: simulated.as_deref(),
        fps,
    };
    super::write_sequence_outputs(&view, &args.out, &format!("{} frames", frames.len()))?;
    Ok(())
}

/// Drapes `poses` with the simulator, walked in order as an animation moves (as revision 2's
/// datasets and `simulate --protocol walk` drape them), prints how far the predicted
/// `garments` lie from its drapes and how much faster they came (`predict_ms` for all of
/// them), and returns the simulated garments.
fn compare_sequence(
    predictor: &Predictor,
    body: &CapsuleBody,
    frames: &[usize],
    poses: &[Pose],
    material: &Material,
    garments: &[TriMesh],
    predict_ms: f64,
) -> Result<Vec<TriMesh>> {
    let info = &predictor.model().meta.template;
    let template = Garment::for_template(info.resolution, &info.hash, body)?;
    // From the rest drape to the first frame, then frame to frame, as an animation moves:
    // the drapes depend on that path (book/src/solver.md, "The ground truth's noise floor"),
    // so a frame's drape here need not be the canonical sample of its pose.
    outln!(
        "simulating {} frames (rest pose, then each frame in turn; seconds a frame) ...",
        frames.len()
    )?;
    let drapes = simulate_sequence(
        &template,
        body,
        poses,
        material,
        &SequenceSettings::default(),
    )?;
    let mut simulated = Vec::with_capacity(drapes.len());
    let (mut sum, mut worst, mut sim_ms, mut unsettled) = (0.0, (0.0, 0), 0.0, 0);
    for ((drape, garment), &frame) in drapes.into_iter().zip(garments).zip(frames) {
        let errors = vertex_errors_mm(&garment.vertices, &drape.vertices)?;
        let mean = errors.iter().sum::<f64>() / errors.len() as f64;
        outln!(
            "  frame {frame}: simulated in {:.0} ms{}, prediction error mean {mean:.2} mm",
            drape.wall_ms,
            if drape.converged {
                ""
            } else {
                " (not converged)"
            }
        )?;
        sum += mean;
        if mean > worst.0 {
            worst = (mean, frame);
        }
        sim_ms += drape.wall_ms;
        unsettled += usize::from(!drape.converged);
        simulated.push(TriMesh::new(drape.vertices, garment.faces.to_vec())?);
    }
    let n = frames.len() as f64;
    outln!(
        "simulator: {:.0} ms a frame{}; prediction error mean {:.2} mm over the frames \
         (worst frame {}: {:.2} mm); speed-up {:.0}x",
        sim_ms / n,
        if unsettled > 0 {
            format!(" ({unsettled} not converged)")
        } else {
            String::new()
        },
        sum / n,
        worst.1,
        worst.0,
        sim_ms / predict_ms
    )?;
    Ok(simulated)
}
