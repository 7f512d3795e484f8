//! `garmatnet template`: write the T-shirt template as a mesh file.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;
use garmatnet::core::{CapsuleBody, Garment, Resolution, write_obj};

/// Write the procedural T-shirt template (rest pose, metres, y up) as an OBJ.
#[derive(Debug, Args)]
pub struct TemplateArgs {
    /// Output OBJ file.
    #[arg(long)]
    pub out: PathBuf,
    /// Template resolution: coarse (~830 vertices), default (~2,700) or paper (~4,350).
    #[arg(long, default_value = "default")]
    pub resolution: Resolution,
}

/// Runs the command.
pub fn run(args: &TemplateArgs) -> Result<()> {
    let body = CapsuleBody::smpl_neutral();
    let shirt = Garment::tshirt(args.resolution, &body)?;
    write_obj(&args.out, &shirt.rest).with_context(|| format!("writing {}", args.out.display()))?;
    outln!(
        "wrote {} ({} resolution: {} vertices, {} triangles, {} springs, template hash {:016x})",
        args.out.display(),
        args.resolution,
        shirt.vertex_count(),
        shirt.rest.face_count(),
        shirt.springs.len(),
        shirt.template_hash()
    )?;
    Ok(())
}
