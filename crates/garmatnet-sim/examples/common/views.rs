//! Front and side views of a drape on its body, shared by the examples that render drapes
//! (included with `#[path]`; not an example itself).

use std::path::Path;

use garmatnet_core::render::{
    BODY_COLOR, Camera, RenderItem, RenderSettings, Shading, render, save_png,
};
use garmatnet_core::{TriMesh, Vec3};

/// Writes `{prefix}_front.png` and `{prefix}_side.png`: `garment` shaded by `shading` on
/// `body`, framed on the garment's bounds widened by `margin` metres on every side.
pub fn save_front_and_side(
    prefix: &Path,
    body: &TriMesh,
    garment: &TriMesh,
    shading: Shading<'_>,
    margin: f64,
) -> anyhow::Result<()> {
    let bounds = garment
        .bounds()
        .ok_or_else(|| anyhow::anyhow!("empty mesh"))?;
    let widen = Vec3::new(margin, margin, margin);
    for (view, yaw) in [("front", 0.0), ("side", std::f64::consts::FRAC_PI_2)] {
        let items = [
            RenderItem {
                mesh: body,
                shading: Shading::Uniform(BODY_COLOR),
            },
            RenderItem {
                mesh: garment,
                shading,
            },
        ];
        let camera = Camera::framing(bounds.min - widen, bounds.max + widen, yaw);
        let image = render(&items, &camera, &RenderSettings::default())?;
        let mut name = prefix.as_os_str().to_owned();
        name.push(format!("_{view}.png"));
        save_png(Path::new(&name), &image)?;
    }
    Ok(())
}
