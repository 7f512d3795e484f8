//! `garmatnet materials`: list the fabric presets.

use anyhow::Result;
use garmatnet::core::presets;

/// Prints every preset with its physical ω and its normalised coordinates.
pub fn run() -> Result<()> {
    println!(
        "{:<24} {:>9} {:>9} {:>9} {:>9} {:>9} {:>8}   normalised ω",
        "name", "struct V", "struct H", "flex V", "flex H", "shear", "density"
    );
    println!(
        "{:<24} {:>9} {:>9} {:>9} {:>9} {:>9} {:>8}",
        "", "N/m", "N/m", "N/m", "N/m", "N/m", "kg/m²"
    );
    for p in presets() {
        let m = p.material;
        let n = m.to_normalized();
        println!(
            "{:<24} {:>9.1} {:>9.1} {:>9.2} {:>9.2} {:>9.1} {:>8.3}   [{}]",
            p.name,
            m.structural_vertical,
            m.structural_horizontal,
            m.flexion_vertical,
            m.flexion_horizontal,
            m.shear,
            m.density,
            n.iter()
                .map(|x| format!("{x:.2}"))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    Ok(())
}
