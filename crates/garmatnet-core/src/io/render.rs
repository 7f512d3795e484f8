//! A small deterministic software rasteriser: z-buffered triangles, Lambert shading,
//! optional per-vertex colours (error heat maps), PNG output.
//!
//! It exists so that examples, reports and tests can show a garment on a body without a GPU,
//! a window or any system library, and so that the same input always gives the same pixels.

use std::path::Path;

use image::{Rgb, RgbImage};

use crate::error::{Error, Result};
use crate::math::{Real, Vec3};
use crate::mesh::TriMesh;

/// An sRGB colour.
pub type Color = [u8; 3];

/// A perspective pinhole camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Eye position (metres).
    pub eye: Vec3,
    /// The point looked at (metres).
    pub target: Vec3,
    /// The world direction that appears up in the image.
    pub up: Vec3,
    /// Vertical field of view (radians).
    pub fov_y: Real,
}

impl Camera {
    /// A camera in front of the body (on +z, the direction SMPL bodies face) framing the
    /// axis-aligned box `[min, max]` with a small margin, seen from `yaw` radians around +y.
    #[must_use]
    pub fn framing(min: Vec3, max: Vec3, yaw: Real) -> Self {
        let centre = (min + max) * 0.5;
        let radius = ((max - min).norm() * 0.5).max(1e-3);
        let fov_y: Real = 0.5;
        let distance = radius * 1.08 / (fov_y * 0.5).tan();
        let dir = Vec3::new(yaw.sin(), 0.0, yaw.cos());
        Self {
            eye: centre + dir * distance,
            target: centre,
            up: Vec3::y(),
            fov_y,
        }
    }
}

/// How one mesh is coloured.
#[derive(Debug, Clone, Copy)]
pub enum Shading<'a> {
    /// One colour for the whole mesh.
    Uniform(Color),
    /// One colour per vertex, interpolated across faces (e.g. a per-vertex error heat map).
    PerVertex(&'a [Color]),
}

/// A mesh and its colouring, to be drawn.
#[derive(Debug, Clone, Copy)]
pub struct RenderItem<'a> {
    /// The mesh.
    pub mesh: &'a TriMesh,
    /// Its colours.
    pub shading: Shading<'a>,
}

/// Image size and lighting.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderSettings {
    /// Output width in pixels.
    pub width: u32,
    /// Output height in pixels.
    pub height: u32,
    /// Background colour.
    pub background: Color,
    /// Direction *towards* the key light in camera coordinates (x right, y up, z towards the
    /// viewer), so every view is lit alike; normalised internally.
    pub light: Vec3,
    /// Ambient fraction of the lighting in [0, 1].
    pub ambient: Real,
    /// Supersampling factor per axis (1 = none, 2 = 4 samples per pixel).
    pub supersample: u32,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            width: 480,
            height: 640,
            background: [245, 245, 245],
            light: Vec3::new(0.4, 0.7, 1.0),
            ambient: 0.3,
            supersample: 2,
        }
    }
}

/// The neutral colour bodies are drawn in.
pub const BODY_COLOR: Color = [196, 186, 178];
/// The default garment colour.
pub const GARMENT_COLOR: Color = [70, 110, 170];

/// How far (metres, along the view) behind an earlier item a later item still shows: a
/// garment listed after the body it lies on is drawn where the two are in contact, instead of
/// the body flickering through it where rounding puts the skin a hair in front. Past it the
/// nearer surface wins, so cloth truly inside the body still shows the body.
pub const LAYER_TOLERANCE_M: Real = 0.002;

/// Renders `items` seen by `camera`: the nearest surface at each pixel, except that a later
/// item within [`LAYER_TOLERANCE_M`] behind an earlier one shows (list the body first). The
/// pixel then keeps the later item's depth, so with three or more items the allowance can
/// add up along the list.
///
/// # Errors
/// [`Error::RenderSize`] for a zero-sized image or supersampling factor, and
/// [`Error::Mismatch`] when a per-vertex colour list does not match its mesh.
pub fn render(
    items: &[RenderItem<'_>],
    camera: &Camera,
    settings: &RenderSettings,
) -> Result<RgbImage> {
    let ss = settings.supersample;
    if settings.width == 0 || settings.height == 0 || ss == 0 || ss > 8 {
        return Err(Error::RenderSize {
            width: settings.width,
            height: settings.height,
            supersample: ss,
        });
    }
    for item in items {
        if let Shading::PerVertex(c) = item.shading
            && c.len() != item.mesh.vertex_count()
        {
            return Err(Error::Mismatch {
                what: "per-vertex colours".into(),
                expected: format!("{} (one per mesh vertex)", item.mesh.vertex_count()),
                got: c.len().to_string(),
            });
        }
    }
    let (w, h) = (settings.width * ss, settings.height * ss);
    let forward = (camera.target - camera.eye).normalize();
    let right = forward.cross(&camera.up).normalize();
    let up = right.cross(&forward);
    let focal = (h as Real * 0.5) / (camera.fov_y * 0.5).tan();
    let light =
        (right * settings.light.x + up * settings.light.y - forward * settings.light.z).normalize();
    let project = |p: &Vec3| -> (Real, Real, Real) {
        let r = p - camera.eye;
        let z = r.dot(&forward);
        let x = w as Real * 0.5 + focal * r.dot(&right) / z;
        let y = h as Real * 0.5 - focal * r.dot(&up) / z;
        (x, y, z)
    };
    let mut depth = vec![Real::INFINITY; (w * h) as usize];
    // Which item each pixel shows (usize::MAX: none yet).
    let mut owner = vec![usize::MAX; (w * h) as usize];
    let mut color = vec![[0.0 as Real; 3]; (w * h) as usize];
    let bg = settings.background.map(|c| c as Real);
    color.iter_mut().for_each(|c| *c = bg);

    for (item_index, item) in items.iter().enumerate() {
        let mesh = item.mesh;
        let normals = vertex_normals(mesh);
        let projected: Vec<_> = mesh.vertices.iter().map(project).collect();
        for face in &mesh.faces {
            let [a, b, c] = face.map(|i| i as usize);
            let (pa, pb, pc) = (projected[a], projected[b], projected[c]);
            if pa.2 <= 1e-4 || pb.2 <= 1e-4 || pc.2 <= 1e-4 {
                continue; // behind or at the camera: skip rather than wrap around
            }
            let area = (pb.0 - pa.0) * (pc.1 - pa.1) - (pb.1 - pa.1) * (pc.0 - pa.0);
            if area.abs() < 1e-12 {
                continue;
            }
            let min_x = pa.0.min(pb.0).min(pc.0).floor().max(0.0) as u32;
            let max_x = (pa.0.max(pb.0).max(pc.0).ceil() as i64).clamp(0, w as i64 - 1) as u32;
            let min_y = pa.1.min(pb.1).min(pc.1).floor().max(0.0) as u32;
            let max_y = (pa.1.max(pb.1).max(pc.1).ceil() as i64).clamp(0, h as i64 - 1) as u32;
            let shade = |i: usize| -> [Real; 3] {
                let base = match item.shading {
                    Shading::Uniform(c) => c,
                    Shading::PerVertex(cs) => cs[i],
                };
                let mut n = normals[i];
                // Two-sided lighting: light the side that faces the camera.
                if n.dot(&(mesh.vertices[i] - camera.eye)) > 0.0 {
                    n = -n;
                }
                let lambert = n.dot(&light).max(0.0);
                let k = settings.ambient + (1.0 - settings.ambient) * lambert;
                base.map(|c| c as Real * k)
            };
            let (ca, cb, cc) = (shade(a), shade(b), shade(c));
            for py in min_y..=max_y {
                for px in min_x..=max_x {
                    let (x, y) = (px as Real + 0.5, py as Real + 0.5);
                    let wa = ((pb.0 - x) * (pc.1 - y) - (pb.1 - y) * (pc.0 - x)) / area;
                    let wb = ((pc.0 - x) * (pa.1 - y) - (pc.1 - y) * (pa.0 - x)) / area;
                    let wc = 1.0 - wa - wb;
                    if wa < 0.0 || wb < 0.0 || wc < 0.0 {
                        continue;
                    }
                    // Perspective-correct depth: interpolate 1/z in screen space.
                    let inv_z = wa / pa.2 + wb / pb.2 + wc / pc.2;
                    let z = 1.0 / inv_z;
                    let idx = (py * w + px) as usize;
                    let tolerance = if owner[idx] < item_index {
                        LAYER_TOLERANCE_M
                    } else {
                        0.0
                    };
                    if z < depth[idx] + tolerance {
                        depth[idx] = z;
                        owner[idx] = item_index;
                        color[idx] = std::array::from_fn(|k| wa * ca[k] + wb * cb[k] + wc * cc[k]);
                    }
                }
            }
        }
    }

    let mut out = RgbImage::new(settings.width, settings.height);
    let n = (ss * ss) as Real;
    for (x, y, pixel) in out.enumerate_pixels_mut() {
        let mut sum = [0.0; 3];
        for sy in 0..ss {
            for sx in 0..ss {
                let c = color[((y * ss + sy) * w + x * ss + sx) as usize];
                (0..3).for_each(|k| sum[k] += c[k]);
            }
        }
        *pixel = Rgb(sum.map(|s| (s / n).round().clamp(0.0, 255.0) as u8));
    }
    Ok(out)
}

fn vertex_normals(mesh: &TriMesh) -> Vec<Vec3> {
    let mut normals = vec![Vec3::zeros(); mesh.vertex_count()];
    for f in &mesh.faces {
        let [a, b, c] = f.map(|i| i as usize);
        let n = (mesh.vertices[b] - mesh.vertices[a]).cross(&(mesh.vertices[c] - mesh.vertices[a]));
        for i in [a, b, c] {
            normals[i] += n;
        }
    }
    normals
        .iter()
        .map(|n| n.try_normalize(1e-20).unwrap_or_else(Vec3::z))
        .collect()
}

/// A perceptually ordered blue → cyan → yellow → red colour for `t` in [0, 1] (clamped;
/// NaN maps to magenta so it cannot pass unnoticed).
#[must_use]
pub fn heat_color(t: Real) -> Color {
    if t.is_nan() {
        return [255, 0, 255];
    }
    const STOPS: [(Real, [Real; 3]); 5] = [
        (0.0, [48.0, 18.0, 160.0]),
        (0.25, [40.0, 120.0, 230.0]),
        (0.5, [60.0, 200.0, 150.0]),
        (0.75, [245.0, 200.0, 40.0]),
        (1.0, [200.0, 30.0, 30.0]),
    ];
    let t = t.clamp(0.0, 1.0);
    let i = STOPS
        .iter()
        .rposition(|(s, _)| *s <= t)
        .unwrap_or(0)
        .min(STOPS.len() - 2);
    let (s0, c0) = STOPS[i];
    let (s1, c1) = STOPS[i + 1];
    let u = (t - s0) / (s1 - s0);
    std::array::from_fn(|k| (c0[k] + (c1[k] - c0[k]) * u).round() as u8)
}

/// Heat-map colours for per-vertex values, scaled so `max_value` is red.
#[must_use]
pub fn heat_colors(values: &[Real], max_value: Real) -> Vec<Color> {
    let max_value = if max_value > 0.0 { max_value } else { 1.0 };
    values.iter().map(|v| heat_color(v / max_value)).collect()
}

/// Places images side by side (top-aligned) on `background`.
#[must_use]
pub fn side_by_side(images: &[RgbImage], background: Color) -> RgbImage {
    let width = images.iter().map(RgbImage::width).sum::<u32>().max(1);
    let height = images.iter().map(RgbImage::height).max().unwrap_or(1);
    let mut out = RgbImage::from_pixel(width, height, Rgb(background));
    let mut x0 = 0;
    for img in images {
        for (x, y, p) in img.enumerate_pixels() {
            out.put_pixel(x0 + x, y, *p);
        }
        x0 += img.width();
    }
    out
}

/// Saves `image` as a PNG atomically (a temporary file in the same directory, then renamed).
///
/// # Errors
/// [`Error::Io`] if the directory is missing or not writable.
pub fn save_png(path: &Path, image: &RgbImage) -> Result<()> {
    let mut png = std::io::Cursor::new(Vec::new());
    image
        .write_to(&mut png, image::ImageFormat::Png)
        .map_err(|e| Error::io(path, std::io::Error::other(e)))?;
    crate::io::files::write_bytes_atomic(path, png.get_ref())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad(z: Real, size: Real) -> TriMesh {
        let v = vec![
            Vec3::new(-size, -size, z),
            Vec3::new(size, -size, z),
            Vec3::new(size, size, z),
            Vec3::new(-size, size, z),
        ];
        TriMesh::new(v, vec![[0, 1, 2], [0, 2, 3]]).unwrap()
    }

    fn settings() -> RenderSettings {
        RenderSettings {
            width: 64,
            height: 64,
            supersample: 1,
            ..RenderSettings::default()
        }
    }

    #[test]
    fn a_later_item_in_contact_shows_and_one_behind_does_not() {
        let cam = Camera {
            eye: Vec3::new(0.0, 0.0, 3.0),
            target: Vec3::zeros(),
            up: Vec3::y(),
            fov_y: 1.0,
        };
        let body = quad(0.0, 1.0);
        let centre = |cloth_z: Real| {
            let cloth = quad(cloth_z, 0.3);
            let items = [
                RenderItem {
                    mesh: &body,
                    shading: Shading::Uniform([0, 0, 255]),
                },
                RenderItem {
                    mesh: &cloth,
                    shading: Shading::Uniform([255, 0, 0]),
                },
            ];
            *render(&items, &cam, &settings()).unwrap().get_pixel(32, 32)
        };
        // The cloth 1 mm behind the body's surface (contact): the cloth shows.
        let contact = centre(-0.001);
        assert!(contact[0] > 0 && contact[2] == 0, "{contact:?}");
        // 5 mm behind (inside the body): the body shows.
        let inside = centre(-0.005);
        assert!(inside[2] > 0 && inside[0] == 0, "{inside:?}");
    }

    #[test]
    fn nearer_surface_wins_the_depth_test() {
        let far = quad(0.0, 1.0);
        let near = quad(0.5, 0.3);
        let cam = Camera {
            eye: Vec3::new(0.0, 0.0, 3.0),
            target: Vec3::zeros(),
            up: Vec3::y(),
            fov_y: 1.0,
        };
        let red = RenderItem {
            mesh: &near,
            shading: Shading::Uniform([255, 0, 0]),
        };
        let blue = RenderItem {
            mesh: &far,
            shading: Shading::Uniform([0, 0, 255]),
        };
        // Draw order must not matter.
        for items in [[red, blue], [blue, red]] {
            let img = render(&items, &cam, &settings()).unwrap();
            let centre = img.get_pixel(32, 32);
            assert!(
                centre[0] > 0 && centre[2] == 0,
                "centre should be the near red quad: {centre:?}"
            );
            let edge = img.get_pixel(16, 32);
            assert!(
                edge[2] > 0 && edge[0] == 0,
                "edge should be the far blue quad: {edge:?}"
            );
            let corner = img.get_pixel(0, 0);
            assert_eq!(
                corner.0,
                settings().background,
                "outside both quads is background"
            );
        }
    }

    #[test]
    fn rendering_is_deterministic_and_colour_lists_are_checked() {
        let q = quad(0.0, 1.0);
        let cam = Camera::framing(Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, 1.0, 0.0), 0.3);
        let colors = heat_colors(&[0.0, 0.3, 0.6, 1.0], 1.0);
        let item = RenderItem {
            mesh: &q,
            shading: Shading::PerVertex(&colors),
        };
        let a = render(&[item], &cam, &RenderSettings::default()).unwrap();
        let b = render(&[item], &cam, &RenderSettings::default()).unwrap();
        assert_eq!(a, b);
        let bad = RenderItem {
            mesh: &q,
            shading: Shading::PerVertex(&colors[..2]),
        };
        assert!(matches!(
            render(&[bad], &cam, &settings()),
            Err(Error::Mismatch { .. })
        ));
        let zero = RenderSettings {
            width: 0,
            ..settings()
        };
        assert!(matches!(
            render(&[item], &cam, &zero),
            Err(Error::RenderSize { .. })
        ));
    }

    #[test]
    fn heat_colors_are_ordered_and_nan_is_loud() {
        assert_eq!(heat_color(f64::NAN), [255, 0, 255]);
        let lo = heat_color(0.0);
        let hi = heat_color(1.0);
        assert!(lo[2] > lo[0] && hi[0] > hi[2], "low is blue, high is red");
        assert_eq!(heat_color(-3.0), lo);
        assert_eq!(heat_color(7.0), hi);
    }

    #[test]
    fn png_is_written_atomically() {
        let dir = tempfile::tempdir().unwrap();
        let img = RgbImage::from_pixel(4, 3, Rgb([1, 2, 3]));
        let path = dir.path().join("x.png");
        save_png(&path, &img).unwrap();
        let back = image::open(&path).unwrap().to_rgb8();
        assert_eq!(back, img);
        let missing = dir.path().join("no/such/dir/x.png");
        assert!(matches!(save_png(&missing, &img), Err(Error::Io { .. })));
        assert_eq!(
            std::fs::read_dir(dir.path()).unwrap().count(),
            1,
            "no temp files left behind"
        );
    }
}
