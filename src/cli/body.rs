//! `garmatnet body`: write the procedural body, optionally posed, as a mesh file.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;
use garmatnet::core::{CapsuleBody, JointLimits, write_obj};

use garmatnet::sim::resolve_pose;

/// Write the capsule body (SMPL's neutral proportions) as an OBJ, in the rest T-pose or posed.
#[derive(Debug, Args)]
pub struct BodyArgs {
    /// Output OBJ file (the only format: the name must end in .obj).
    #[arg(long)]
    pub out: PathBuf,
    /// A frame of the built-in walk, `everyday` (with `--frame N`) or `everyday:NAME` (a pose
    /// of the everyday suite, e.g. `everyday:arms-at-sides`), or a pose file (.json list of
    /// 72-vectors, AMASS-style .npz, or .npy). Default: the rest T-pose.
    #[arg(long)]
    pub pose: Option<String>,
    /// Which pose of a pose file (default 0).
    #[arg(long)]
    pub frame: Option<usize>,
}

/// Runs the command.
pub fn run(args: &BodyArgs) -> Result<()> {
    super::template::require_obj_extension(&args.out, "body")?;
    let pose = resolve_pose(args.pose.as_deref(), args.frame)?;
    // The limits training poses are drawn within, as `drape` checks them.
    if let Err(e) = JointLimits::everyday().validate(&pose, 1e-6) {
        warnln!(
            "note: {e} (the body is posed anyway; training poses are drawn within \
             JointLimits::everyday)"
        );
    }
    let mesh = CapsuleBody::smpl_neutral().pose(&pose).mesh();
    write_obj(&args.out, &mesh).with_context(|| format!("writing {}", args.out.display()))?;
    outln!(
        "wrote {} ({} vertices, {} triangles)",
        args.out.display(),
        mesh.vertex_count(),
        mesh.face_count()
    )?;
    Ok(())
}
