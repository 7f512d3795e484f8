//! `garmatnet drape`: one prediction from a script, written by file extension.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use clap::Args;
use garmatnet::model::{
    Detail, FAR_FROM_TRAINING, Predictor, PushOut, default_model_path, select_device,
};
use garmatnet::sim::SequenceSettings;
use garmatnet::train::{
    DrapeView, OutputFormat, comparison_image, resolve_material, resolve_pose, simulate_drape,
    vertex_errors_mm,
};
use garmatnet::{CapsuleBody, Garment, TriMesh};

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
    /// A frame of the built-in motion sequence, or a pose file (.json, .npz, .npy).
    /// Default: the rest T-pose.
    #[arg(long)]
    pub pose: Option<String>,
    /// Which pose of a pose file (default 0).
    #[arg(long)]
    pub frame: Option<usize>,
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
    #[arg(long)]
    pub compare: bool,
    /// Keep vertices the network put inside the body where they are.
    #[arg(long)]
    pub no_push_out: bool,
}

/// Runs the command.
pub fn run(args: &DrapeArgs) -> Result<()> {
    // Refuse unknown formats before any work, so no output is half-done.
    for out in &args.out {
        OutputFormat::from_path(out)?;
    }
    let material = resolve_material(
        args.material.as_deref(),
        args.omega.as_deref(),
        "Cotton Poplin",
    )?;
    let pose = resolve_pose(args.pose.as_deref(), args.frame)?;
    let device = select_device(&args.device)?;
    let model_path = args.model.clone().unwrap_or_else(default_model_path);
    let mut predictor = Predictor::from_file(&model_path, &device)?;
    if args.no_push_out {
        predictor = predictor.with_push_out(PushOut {
            enabled: false,
            ..PushOut::default()
        });
    }
    if let Some(range) = predictor.material_range() {
        let outside = range.outside(&material.to_normalized());
        if !outside.is_empty() {
            let parts: Vec<String> = outside.iter().map(ToString::to_string).collect();
            eprintln!(
                "warning: the material lies outside the fabrics {} was trained on ({}): the \
                 prediction is an extrapolation, expect larger errors",
                model_path.display(),
                parts.join("; ")
            );
        }
    }
    if let Some((fabric, distance)) = predictor.nearest_training_fabric(&material) {
        println!(
            "nearest training fabric: {} ({distance:.3} away in normalised ω)",
            fabric.name
        );
        if distance >= FAR_FROM_TRAINING {
            eprintln!(
                "warning: the material is {distance:.3} from the nearest fabric {} was trained \
                 on ({}); at {FAR_FROM_TRAINING} and beyond, fabrics the model never saw \
                 erred about twice as much as nearer ones (README, \"The typed API\"): \
                 expect a larger error",
                model_path.display(),
                fabric.name
            );
        }
    }
    // The first call warms the backend up; time the second.
    predictor.predict(&pose, &material, args.detail)?;
    let started = Instant::now();
    let mesh = predictor.predict(&pose, &material, args.detail)?;
    let predict_ms = started.elapsed().as_secs_f64() * 1e3;
    println!(
        "predicted {} vertices ({} detail) in {predict_ms:.2} ms with {}",
        mesh.vertices.len(),
        args.detail,
        model_path.display()
    );
    let garment = TriMesh::new(mesh.vertices, mesh.faces)?;
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
        println!("wrote {}", out.display());
    }
    if args.compare {
        let body_model = CapsuleBody::smpl_neutral();
        let template = Garment::tshirt(predictor.model().meta.template.resolution, &body_model)?;
        let sim = simulate_drape(
            &template,
            &body_model,
            &pose,
            &material,
            &SequenceSettings::default(),
        )?;
        let errors = vertex_errors_mm(&garment.vertices, &sim.vertices)?;
        let mean = errors.iter().sum::<f64>() / errors.len() as f64;
        let max = errors.iter().copied().fold(0.0, f64::max);
        println!(
            "simulator: {:.0} ms{}; prediction error mean {mean:.2} mm, max {max:.2} mm; \
             speed-up {:.0}x",
            sim.wall_ms,
            if sim.converged {
                ""
            } else {
                " (not converged)"
            },
            sim.wall_ms / predict_ms
        );
        let truth = TriMesh::new(sim.vertices, garment.faces.clone())?;
        for out in args
            .out
            .iter()
            .filter(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")))
        {
            let stem = out.file_stem().and_then(|s| s.to_str()).unwrap_or("drape");
            let path = out.with_file_name(format!("{stem}_compare.png"));
            let image = comparison_image(&body, &garment, &truth, &errors, 20.0)?;
            garmatnet::core::render::save_png(&path, &image)?;
            println!(
                "wrote {} (prediction | simulation | error, red = 20 mm)",
                path.display()
            );
        }
    }
    Ok(())
}
