//! `garmatnet template`: write the T-shirt template as a mesh file.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::Args;
use garmatnet::core::{CapsuleBody, Garment, Resolution, write_obj};

/// Write the procedural T-shirt template (rest pose, metres, y up) as an OBJ.
#[derive(Debug, Args)]
pub struct TemplateArgs {
    /// Output OBJ file (the only format: the name must end in .obj).
    #[arg(long)]
    pub out: PathBuf,
    /// Template resolution: coarse (~830 vertices), default (~2,700) or paper (~4,350).
    #[arg(long, default_value = "default")]
    pub resolution: Resolution,
}

/// Refuses an output path whose name does not end in `.obj` (any case), the one format
/// `template` and `body` write, before anything is built or written: an OBJ written as
/// `t.glb` or `b.png` would be misread by whatever opens it.
///
/// # Errors
/// Names the path and the supported extension.
pub(crate) fn require_obj_extension(out: &Path, command: &str) -> Result<()> {
    if out
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("obj"))
    {
        return Ok(());
    }
    bail!(
        "`garmatnet {command}` writes only Wavefront OBJ, and `{}` does not end in .obj; name \
         the output file `*.obj`",
        out.display()
    )
}

/// Runs the command.
pub fn run(args: &TemplateArgs) -> Result<()> {
    require_obj_extension(&args.out, "template")?;
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
