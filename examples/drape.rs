//! Run: `cargo run --release --example drape [-- --material NAME --pose FRAME --compare]`
//!
//! Drapes the T-shirt with the shipped GarMatNet model (or `--model FILE`, or
//! `$GARMATNET_MODEL`) for a few poses of the built-in motion and three contrasting fabrics,
//! prints the prediction time of every frame, and writes for each an OBJ, a glTF binary
//! (`.glb`, garment + body: open it in Blender or any browser glTF viewer) and a PNG render,
//! plus one PNG per pose with the fabrics side by side, and the first fabric over the first
//! `--motion-frames` frames of the motion as one animated `.glb`. `--compare` also runs the simulator
//! on the same input and prints the error (mm) and the speed-up, with a render of
//! prediction | simulation | per-vertex error.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use clap::Parser;
use garmatnet::core::render::{RenderSettings, save_png, side_by_side};
use garmatnet::core::{
    DrapeSequence, DrapeView, comparison_image, resolve_material, slug, vertex_errors_mm,
};
use garmatnet::model::{Detail, FAR_FROM_TRAINING, Predictor, default_model_path, select_device};
use garmatnet::sim::{canonical_settings, resolve_frames, resolve_pose, simulate_drape};
use garmatnet::{CapsuleBody, Garment, GarmentMesh, Material, Pose, TriMesh};

/// The fabrics shown when none is named: light and fluid, a heavy twill, a stiff interlining.
const DEFAULT_FABRICS: [&str; 3] = ["Silk Chiffon", "Denim Heavy", "Trim Fusible Rigid"];
/// Frames of the built-in motion shown when no pose is named.
const DEFAULT_FRAMES: [&str; 3] = ["20", "95", "170"];

/// Command-line arguments.
#[derive(Debug, Parser)]
struct Args {
    /// Fabric preset(s), repeatable (see `garmatnet materials`); or six physical values.
    #[arg(long)]
    material: Vec<String>,
    /// A material as normalised ω: six numbers in [0, 1], comma-separated (replaces
    /// --material).
    #[arg(long)]
    omega: Option<String>,
    /// Pose(s), repeatable: a frame of the built-in motion, or a pose file (.json/.npz/.npy;
    /// its first pose).
    #[arg(long)]
    pose: Vec<String>,
    /// `full` (both nets) or `smooth` (the generally-fitting net only).
    #[arg(long, default_value = "full")]
    detail: Detail,
    /// Compute device: cpu, gpu (build with `--features wgpu`) or auto.
    #[arg(long, default_value = "cpu")]
    device: String,
    /// Model file (default: the shipped model).
    #[arg(long)]
    model: Option<PathBuf>,
    /// Output folder (created if missing).
    #[arg(long, default_value = "out/drape")]
    out: PathBuf,
    /// Also run the simulator for every input (by the canonical protocol, as a dataset
    /// drapes it): error (mm), speed-up, side-by-side render.
    #[arg(long)]
    compare: bool,
    /// Frames of the built-in motion to predict for the first fabric and write as one
    /// animated glTF (`motion_<fabric>.glb`, 24 frames a second); 0 for none.
    #[arg(long, default_value_t = 48)]
    motion_frames: usize,
}

fn main() -> Result<()> {
    let args = Args::parse();
    let fabrics: Vec<(String, Material)> = match &args.omega {
        Some(omega) => vec![("omega".into(), resolve_material(None, Some(omega), "")?)],
        None if args.material.is_empty() => DEFAULT_FABRICS
            .iter()
            .map(|n| Ok(((*n).to_string(), Material::preset(n)?)))
            .collect::<Result<_>>()?,
        None => args
            .material
            .iter()
            .map(|m| Ok((m.clone(), resolve_material(Some(m), None, "")?)))
            .collect::<Result<_>>()?,
    };
    let pose_specs: Vec<String> = if args.pose.is_empty() {
        DEFAULT_FRAMES.iter().map(|s| (*s).to_string()).collect()
    } else {
        args.pose.clone()
    };
    let poses: Vec<(String, Pose)> = pose_specs
        .iter()
        .map(|spec| Ok((spec.clone(), resolve_pose(Some(spec), None)?)))
        .collect::<Result<_>>()?;

    let device = select_device(&args.device)?;
    let model_path = args.model.clone().unwrap_or_else(default_model_path);
    let predictor = Predictor::from_file(&model_path, &device)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    println!(
        "model {} ({} vertices), {} detail on {}",
        model_path.display(),
        predictor.vertex_count(),
        args.detail,
        args.device
    );
    // How far each fabric lies from what the model learned: the farther from its nearest
    // training fabric, the larger the error to expect (book/src/api.md).
    for (name, material) in &fabrics {
        if let Some((nearest, distance)) = predictor.nearest_training_fabric(material) {
            if distance == 0.0 {
                println!("{name}: one of the model's training fabrics");
                continue;
            }
            let far = if distance >= FAR_FROM_TRAINING {
                ": far from every training fabric, expect a larger error"
            } else {
                ""
            };
            println!(
                "{name}: nearest training fabric {} ({distance:.3} away in normalised ω){far}",
                nearest.name
            );
        }
    }
    // One untimed prediction warms the backend up.
    predictor.predict(&poses[0].1, &fabrics[0].1, args.detail)?;

    let body_model = CapsuleBody::smpl_neutral();
    let info = &predictor.model().meta.template;
    let template = Garment::for_template(info.resolution, &info.hash, &body_model)?;
    let settings = RenderSettings::default();
    for (spec, pose) in &poses {
        let pose_name = match spec.parse::<usize>() {
            Ok(frame) => format!("frame{frame:03}"),
            Err(_) => slug(spec),
        };
        let body = body_model.pose(pose).mesh();
        let mut panels = Vec::new();
        for (name, material) in &fabrics {
            let started = Instant::now();
            let mesh = predictor.predict(pose, material, args.detail)?;
            let ms = started.elapsed().as_secs_f64() * 1e3;
            let garment = mesh.into_tri_mesh()?;
            let view = DrapeView {
                body: &body,
                garment: &garment,
                garment_colors: None,
            };
            let stem = format!("{pose_name}_{}", slug(name));
            for ext in ["obj", "glb"] {
                view.write(&args.out.join(format!("{stem}.{ext}")))?;
            }
            let image = view.render(&settings)?;
            save_png(&args.out.join(format!("{stem}.png")), &image)?;
            panels.push(image);
            print!("{pose_name} {name:<20} predicted in {ms:6.2} ms");
            if args.compare {
                let sim = simulate_drape(
                    &template,
                    &body_model,
                    pose,
                    material,
                    &canonical_settings(),
                )?;
                let errors = vertex_errors_mm(&garment.vertices, &sim.vertices)?;
                let mean = errors.iter().sum::<f64>() / errors.len() as f64;
                let truth = TriMesh::new(sim.vertices, garment.faces.to_vec())?;
                save_png(
                    &args.out.join(format!("{stem}_compare.png")),
                    &comparison_image(&body, &garment, &truth, &errors, 20.0)?,
                )?;
                print!(
                    " | simulated in {:.0} ms{}: error {mean:.2} mm, {:.0}x faster",
                    sim.wall_ms,
                    if sim.converged {
                        ""
                    } else {
                        " (not converged)"
                    },
                    sim.wall_ms / ms
                );
            }
            println!();
        }
        save_png(
            &args.out.join(format!("{pose_name}_fabrics.png")),
            &side_by_side(&panels, settings.background),
        )?;
    }
    if args.motion_frames > 0 {
        // A whole motion at once: batched through the nets, one animated glTF.
        let (name, material) = &fabrics[0];
        let sequence = resolve_frames(None, &format!("0..{}", args.motion_frames))?;
        let (frames, motion): (Vec<usize>, Vec<Pose>) = sequence.into_iter().unzip();
        let started = Instant::now();
        let predicted = predictor.predict_sequence(&motion, material, args.detail)?;
        let ms = started.elapsed().as_secs_f64() * 1e3;
        let garments = predicted
            .into_iter()
            .map(GarmentMesh::into_tri_mesh)
            .collect::<Result<Vec<_>, _>>()?;
        let path = args.out.join(format!("motion_{}.glb", slug(name)));
        DrapeSequence {
            frames: &frames,
            body: &body_model,
            poses: &motion,
            garments: &garments,
            simulated: None,
            fps: 24.0,
        }
        .write(&path)?;
        // Six evenly spaced frames side by side, for a glance without a glTF viewer.
        let shown: Vec<usize> = (0..6).map(|k| k * (frames.len() - 1) / 5).collect();
        let mut strip = Vec::with_capacity(shown.len());
        for &k in &shown {
            let body = body_model.pose(&motion[k]).mesh();
            let view = DrapeView {
                body: &body,
                garment: &garments[k],
                garment_colors: None,
            };
            strip.push(view.render(&settings)?);
        }
        let strip_path = args.out.join(format!("motion_{}.png", slug(name)));
        save_png(&strip_path, &side_by_side(&strip, settings.background))?;
        println!(
            "{name}: frames 0..{} of the motion predicted in {ms:.1} ms ({:.2} ms a frame), \
             animated in {} (frames {:?} side by side in {})",
            args.motion_frames,
            ms / frames.len() as f64,
            path.display(),
            shown.iter().map(|&k| frames[k]).collect::<Vec<_>>(),
            strip_path.display()
        );
    }
    println!(
        "wrote OBJ, GLB and PNG files to {} (<pose>_fabrics.png: the fabrics side by side)",
        args.out.display()
    );
    Ok(())
}
