//! `garmatnet materials`: list the fabric presets.

use std::path::PathBuf;

use anyhow::{Result, bail};
use clap::Args;
use garmatnet::core::presets;
use garmatnet::model::material_range::nearest;
use garmatnet::model::{FAR_FROM_TRAINING, GarMatNetModel, default_model_path, select_device};

/// List the fabric presets.
#[derive(Debug, Args)]
pub struct MaterialsArgs {
    /// Also name, for each preset, the nearest fabric a model trained on and its distance in
    /// normalised ω (`--model` alone: the shipped model, or $GARMATNET_MODEL). The farther,
    /// the larger the error to expect; `*` marks FAR_FROM_TRAINING (0.3) and beyond.
    #[arg(long, num_args = 0..=1, value_name = "MODEL")]
    pub model: Option<Option<PathBuf>>,
}

/// Prints every preset with its physical ω and its normalised coordinates, and with
/// `--model`, the model's nearest training fabric.
pub fn run(args: &MaterialsArgs) -> Result<()> {
    let fabrics = match &args.model {
        None => None,
        Some(path) => {
            let path = path.clone().unwrap_or_else(default_model_path);
            let model = GarMatNetModel::load(&path, &select_device("cpu")?)?;
            let fabrics = model.meta.provenance.training_fabrics;
            if fabrics.is_empty() {
                bail!(
                    "{} does not record the fabrics it was trained on (trained before models \
                     recorded them); re-train it to list its nearest fabrics",
                    path.display()
                );
            }
            Some(fabrics)
        }
    };
    let nearest_column = if fabrics.is_some() {
        "   nearest training fabric (distance)"
    } else {
        ""
    };
    outln!(
        "{:<24} {:>9} {:>9} {:>9} {:>9} {:>9} {:>8}   {:<32}{nearest_column}",
        "name",
        "struct V",
        "struct H",
        "flex V",
        "flex H",
        "shear",
        "density",
        "normalised ω"
    )?;
    outln!(
        "{:<24} {:>9} {:>9} {:>9} {:>9} {:>9} {:>8}",
        "",
        "N/m",
        "N/m",
        "N/m",
        "N/m",
        "N/m",
        "kg/m²"
    )?;
    for p in presets() {
        let m = p.material;
        let n = m.to_normalized();
        let omega = format!(
            "[{}]",
            n.iter()
                .map(|x| format!("{x:.2}"))
                .collect::<Vec<_>>()
                .join(", ")
        );
        let near = match fabrics
            .as_deref()
            .and_then(|f| nearest(&n, f.iter().map(|f| (f, f.omega))))
        {
            None => String::new(),
            Some((_, 0.0)) => "   trained on".to_owned(),
            Some((f, d)) => {
                let far = if d >= FAR_FROM_TRAINING { " *" } else { "" };
                format!("   {} ({d:.3}){far}", f.name)
            }
        };
        outln!(
            "{:<24} {:>9.1} {:>9.1} {:>9.2} {:>9.2} {:>9.1} {:>8.3}   {omega:<32}{near}",
            p.name,
            m.structural_vertical,
            m.structural_horizontal,
            m.flexion_vertical,
            m.flexion_horizontal,
            m.shear,
            m.density,
        )?;
    }
    Ok(())
}
