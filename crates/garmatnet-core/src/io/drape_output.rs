//! Drapes written out: the output format an extension names (OBJ, glTF binary, PLY, PNG
//! render), one garment on its posed body ([`DrapeView`]) or a sequence of them
//! ([`DrapeSequence`]), and the comparison of a prediction with the ground truth.

use std::path::{Path, PathBuf};

use image::RgbImage;

use crate::body::capsule_body::CapsuleBody;
use crate::body::pose::Pose;
use crate::body::sdf::SkinnedBody;
use crate::error::{Error, Result};
use crate::io::files::{write_obj, write_ply};
use crate::io::gltf::{GlbAnimatedMesh, GlbMesh, GlbSkinnedMesh, write_glb, write_glb_animation};
use crate::io::render::{
    BODY_COLOR, Camera, Color, GARMENT_COLOR, RenderItem, RenderSettings, Shading, heat_colors,
    render, save_png, side_by_side,
};
use crate::math::{Real, Vec3};
use crate::mesh::TriMesh;

/// `path` with a frame number before its extension, `drape.obj` → `drape.0007.obj`, wide
/// enough for `last`, so a sequence's files sort in frame order.
#[must_use]
pub fn numbered_path(path: &Path, frame: usize, last: usize) -> PathBuf {
    let width = last.max(1).to_string().len().max(4);
    let stem = file_stem(path);
    let name = match path.extension() {
        Some(ext) => format!("{stem}.{frame:0width$}.{}", ext.to_string_lossy()),
        None => format!("{stem}.{frame:0width$}"),
    };
    path.with_file_name(name)
}

/// Where the comparison image of the PNG `path` goes: `drape.png` → `drape_compare.png`.
#[must_use]
pub fn compare_path(path: &Path) -> PathBuf {
    let stem = file_stem(path);
    path.with_file_name(format!("{stem}_compare.png"))
}

/// `path`'s file name without its extension, `drape` when it has none.
fn file_stem(path: &Path) -> String {
    path.file_stem()
        .map_or_else(|| "drape".to_owned(), |s| s.to_string_lossy().into_owned())
}

/// A file-name-safe lowercase form of a name (e.g. a fabric's): ASCII letters and digits
/// kept, everything else `_`.
///
/// ```
/// assert_eq!(garmatnet_core::slug("Sherpa Fleece 160"), "sherpa_fleece_160");
/// ```
#[must_use]
pub fn slug(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() {
                c.to_ascii_lowercase()
            } else {
                '_'
            }
        })
        .collect()
}

/// The kinds of file a drape can be written as, chosen by extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutputFormat {
    /// `.obj`: the garment mesh.
    Obj,
    /// `.glb`: garment and posed body as one glTF binary (Blender, browser viewers).
    Glb,
    /// `.ply`: the garment mesh (with per-vertex colours when there are some).
    Ply,
    /// `.png`: a render of the garment on the posed body.
    Png,
}

impl OutputFormat {
    /// The format `path`'s extension names (case-insensitive).
    ///
    /// # Errors
    /// [`Error::UnknownOutputFormat`] for another or a missing extension.
    pub fn from_path(path: &Path) -> Result<Self> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("obj") => Ok(Self::Obj),
            Some("glb") => Ok(Self::Glb),
            Some("ply") => Ok(Self::Ply),
            Some("png") => Ok(Self::Png),
            _ => Err(Error::UnknownOutputFormat {
                path: path.to_owned(),
            }),
        }
    }
}

/// A garment on its posed body, ready to render or export.
#[derive(Debug, Clone, Copy)]
pub struct DrapeView<'a> {
    /// The posed body mesh (metres).
    pub body: &'a TriMesh,
    /// The garment mesh (metres).
    pub garment: &'a TriMesh,
    /// Optional per-vertex garment colours (a heat map); the garment colour otherwise.
    pub garment_colors: Option<&'a [Color]>,
}

impl DrapeView<'_> {
    /// Renders the view from the front, framed on the body (every view of one body is framed
    /// alike, so side-by-side images line up).
    ///
    /// # Errors
    /// [`Error::Mismatch`] when the colour list does not match the garment.
    pub fn render(&self, settings: &RenderSettings) -> Result<RgbImage> {
        let bounds = self
            .body
            .bounds()
            .ok_or_else(|| Error::InvalidMesh("the body mesh is empty".into()))?;
        let camera = Camera::framing(bounds.min, bounds.max, 0.35);
        let garment_shading = match self.garment_colors {
            Some(colors) => Shading::PerVertex(colors),
            None => Shading::Uniform(GARMENT_COLOR),
        };
        render(
            &[
                RenderItem {
                    mesh: self.body,
                    shading: Shading::Uniform(BODY_COLOR),
                },
                RenderItem {
                    mesh: self.garment,
                    shading: garment_shading,
                },
            ],
            &camera,
            settings,
        )
    }

    /// Writes the view to `path` in the format its extension names ([`OutputFormat`]),
    /// atomically: OBJ and PLY hold the garment, GLB garment and body, PNG a render.
    ///
    /// # Errors
    /// [`Error::UnknownOutputFormat`] for an unknown extension; [`Error::Io`] when the
    /// file cannot be written (nothing is left behind then).
    pub fn write(&self, path: &Path) -> Result<()> {
        match OutputFormat::from_path(path)? {
            OutputFormat::Obj => write_obj(path, self.garment)?,
            OutputFormat::Ply => write_ply(path, self.garment, self.garment_colors)?,
            OutputFormat::Glb => write_glb(
                path,
                &[
                    GlbMesh {
                        name: "garment",
                        mesh: self.garment,
                        color: GARMENT_COLOR,
                        vertex_colors: self.garment_colors,
                    },
                    GlbMesh {
                        name: "body",
                        mesh: self.body,
                        color: BODY_COLOR,
                        vertex_colors: None,
                    },
                ],
            )?,
            OutputFormat::Png => save_png(path, &self.render(&RenderSettings::default())?)?,
        }
        Ok(())
    }
}

/// A garment on its posed body at a sequence of frames, ready to export as an animation.
#[derive(Debug, Clone, Copy)]
pub struct DrapeSequence<'a> {
    /// The frame numbers (e.g. of the pose file), one per mesh, in playing order.
    pub frames: &'a [usize],
    /// The body the garment is worn by.
    pub body: &'a CapsuleBody,
    /// The pose at each frame.
    pub poses: &'a [Pose],
    /// The garment mesh at each frame (metres).
    pub garments: &'a [TriMesh],
    /// The simulator's garment at each frame, to show beside the prediction (e.g. from
    /// `garmatnet_sim::simulate_sequence`), if any.
    pub simulated: Option<&'a [TriMesh]>,
    /// Frames per second of the animation.
    pub fps: f64,
}

/// The colour of a simulated garment shown beside a predicted one.
pub const SIMULATED_COLOR: Color = [200, 120, 60];

impl DrapeSequence<'_> {
    /// Writes the sequence to `path` by its extension ([`OutputFormat`]), atomically: GLB
    /// as one animated file ([`write_glb_animation`]: the garment's frames as morph
    /// targets, the simulated garment's too when there is one (`garment_simulated`, in
    /// [`SIMULATED_COLOR`], on the same body), the body once, skinned to its skeleton and
    /// posed by the animation), OBJ, PLY and PNG as one file a frame, numbered
    /// ([`numbered_path`]); with a simulated garment, each PNG frame also gets a comparison
    /// image (`<stem>_compare.NNNN.png`: prediction | simulation | error, red = 20 mm).
    /// Returns the paths written.
    ///
    /// # Errors
    /// [`Error::UnknownOutputFormat`] for an unknown extension; [`Error::Empty`] for no
    /// frames; [`Error::Mismatch`] when the lists differ in length; the writers' errors
    /// otherwise (files already written for earlier frames stay, each complete).
    pub fn write(&self, path: &Path) -> Result<Vec<PathBuf>> {
        let format = OutputFormat::from_path(path)?;
        let n = self.frames.len();
        if n == 0 {
            return Err(Error::Empty {
                what: "a drape sequence".into(),
                item: "frame",
            });
        }
        for (what, len) in [
            ("poses", self.poses.len()),
            ("garments", self.garments.len()),
            (
                "simulated garments",
                self.simulated.map_or(n, <[TriMesh]>::len),
            ),
        ] {
            if len != n {
                return Err(Error::Mismatch {
                    what: format!("{what} of the drape sequence"),
                    expected: format!("{n} (one per frame)"),
                    got: len.to_string(),
                });
            }
        }
        if format == OutputFormat::Glb {
            write_glb_animation(
                path,
                &[
                    Some(GlbAnimatedMesh {
                        name: "garment",
                        frames: self.garments,
                        color: GARMENT_COLOR,
                    }),
                    self.simulated.map(|frames| GlbAnimatedMesh {
                        name: "garment_simulated",
                        frames,
                        color: SIMULATED_COLOR,
                    }),
                ]
                .into_iter()
                .flatten()
                .collect::<Vec<_>>(),
                &[GlbSkinnedMesh {
                    name: "body",
                    rest: self.body.rest_mesh(),
                    weights: self.body.rest_mesh_weights(),
                    skeleton: self.body.skeleton(),
                    poses: self.poses,
                    color: BODY_COLOR,
                }],
                self.fps,
            )?;
            return Ok(vec![path.to_owned()]);
        }
        let last = self.frames.iter().copied().max().unwrap_or(0);
        let mut written = Vec::with_capacity(n);
        for (k, ((&frame, pose), garment)) in self
            .frames
            .iter()
            .zip(self.poses)
            .zip(self.garments)
            .enumerate()
        {
            let out = numbered_path(path, frame, last);
            let body = self.body.pose(pose).mesh();
            DrapeView {
                body: &body,
                garment,
                garment_colors: None,
            }
            .write(&out)?;
            written.push(out);
            if let (Some(simulated), OutputFormat::Png) = (self.simulated, format) {
                let truth = &simulated[k];
                let errors = vertex_errors_mm(&garment.vertices, &truth.vertices)?;
                let compare = numbered_path(&compare_path(path), frame, last);
                save_png(
                    &compare,
                    &comparison_image(&body, garment, truth, &errors, 20.0)?,
                )?;
                written.push(compare);
            }
        }
        Ok(written)
    }
}

/// Per-vertex Euclidean distance between two garments of one template (millimetres).
///
/// # Errors
/// [`Error::Mismatch`] when the vertex counts differ.
pub fn vertex_errors_mm(predicted: &[Vec3], truth: &[Vec3]) -> Result<Vec<Real>> {
    if predicted.len() != truth.len() {
        return Err(Error::Mismatch {
            what: "garment vertex counts".into(),
            expected: truth.len().to_string(),
            got: predicted.len().to_string(),
        });
    }
    Ok(predicted
        .iter()
        .zip(truth)
        .map(|(p, t)| (p - t).norm() * 1e3)
        .collect())
}

/// Three renders side by side: the prediction, the ground truth, and the prediction coloured
/// by its per-vertex error (blue 0 to red `max_mm`).
///
/// # Errors
/// [`Error::Mismatch`] when the meshes or the error list disagree in size.
pub fn comparison_image(
    body: &TriMesh,
    predicted: &TriMesh,
    truth: &TriMesh,
    errors_mm: &[Real],
    max_mm: Real,
) -> Result<RgbImage> {
    let settings = RenderSettings::default();
    let colors = heat_colors(errors_mm, max_mm);
    let view = |garment: &TriMesh, garment_colors: Option<&[Color]>| {
        DrapeView {
            body,
            garment,
            garment_colors,
        }
        .render(&settings)
    };
    Ok(side_by_side(
        &[
            view(predicted, None)?,
            view(truth, None)?,
            view(predicted, Some(&colors))?,
        ],
        settings.background,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::garment::resolution::Resolution;
    use crate::garment::template::Garment;
    #[test]
    fn numbered_paths_sort_in_frame_order() {
        let p = Path::new("out/drape.obj");
        assert_eq!(numbered_path(p, 7, 239), Path::new("out/drape.0007.obj"));
        assert_eq!(
            numbered_path(p, 7, 12_000),
            Path::new("out/drape.00007.obj")
        );
        assert_eq!(numbered_path(Path::new("x"), 3, 9), Path::new("x.0003"));
    }

    #[test]
    fn a_sequence_writes_one_animation_or_one_file_a_frame() -> anyhow::Result<()> {
        let body = CapsuleBody::smpl_neutral();
        let shirt = Garment::tshirt(Resolution::Coarse, &body)?;
        let frames = [3, 4];
        let poses = [Pose::zero(), Pose::a_pose()];
        let garments = vec![shirt.rest.clone(), shirt.rest.clone()];
        let sequence = DrapeSequence {
            frames: &frames,
            body: &body,
            poses: &poses,
            garments: &garments,
            simulated: None,
            fps: 30.0,
        };
        let dir = tempfile::tempdir()?;
        let glb = dir.path().join("a.glb");
        assert_eq!(sequence.write(&glb)?, vec![glb.clone()]);
        let bytes = std::fs::read(&glb)?;
        let json_len = u32::from_le_bytes(bytes[12..16].try_into()?) as usize;
        let doc: serde_json::Value = serde_json::from_slice(&bytes[20..20 + json_len])?;
        // The garment's morph weights and the body's 24 joint rotations.
        assert_eq!(
            doc["animations"][0]["channels"].as_array().map(Vec::len),
            Some(1 + crate::body::joints::JOINT_COUNT)
        );
        assert_eq!(doc["skins"].as_array().map(Vec::len), Some(1));
        let objs = sequence.write(&dir.path().join("a.obj"))?;
        assert_eq!(
            objs,
            vec![dir.path().join("a.0003.obj"), dir.path().join("a.0004.obj")]
        );
        assert!(objs.iter().all(|p| p.exists()));
        let short = DrapeSequence {
            garments: &garments[..1],
            ..sequence
        };
        let err = short
            .write(&dir.path().join("b.glb"))
            .expect_err("one garment, two frames");
        assert!(err.to_string().contains("garments"), "{err}");
        assert!(!dir.path().join("b.glb").exists());
        Ok(())
    }

    #[test]
    fn formats_come_from_extensions() {
        assert_eq!(
            OutputFormat::from_path(Path::new("a/b.GLB")).ok(),
            Some(OutputFormat::Glb)
        );
        assert_eq!(
            OutputFormat::from_path(Path::new("b.png")).ok(),
            Some(OutputFormat::Png)
        );
        let err = OutputFormat::from_path(Path::new("b.stl")).expect_err("stl");
        assert!(
            matches!(&err, Error::UnknownOutputFormat { path } if path == Path::new("b.stl")),
            "{err}"
        );
        assert!(OutputFormat::from_path(Path::new("noext")).is_err());
    }

    #[test]
    fn every_format_writes_a_readable_file_and_bad_paths_leave_nothing() -> anyhow::Result<()> {
        let body = CapsuleBody::smpl_neutral();
        let garment = Garment::tshirt(Resolution::Coarse, &body)?;
        let body_mesh = body.pose(&Pose::zero()).mesh();
        let view = DrapeView {
            body: &body_mesh,
            garment: &garment.rest,
            garment_colors: None,
        };
        let dir = tempfile::tempdir()?;
        for name in ["g.obj", "g.glb", "g.ply", "g.png"] {
            let path = dir.path().join(name);
            view.write(&path)?;
            assert!(std::fs::metadata(&path)?.len() > 100, "{name} is empty");
        }
        let back = crate::io::files::read_obj(dir.path().join("g.obj"))?;
        assert_eq!(back.vertices.len(), garment.vertex_count());
        let png = image::open(dir.path().join("g.png"))?.to_rgb8();
        let garment_pixels = png
            .pixels()
            .filter(|p| p.0[2] > p.0[0] + 40) // the blue garment
            .count();
        assert!(
            garment_pixels > 1000,
            "garment barely visible: {garment_pixels} px"
        );
        assert!(view.write(&dir.path().join("missing/g.obj")).is_err());
        assert!(!dir.path().join("missing").exists());
        Ok(())
    }

    #[test]
    fn vertex_errors_are_distances_in_millimetres() {
        let a = [Vec3::zeros(), Vec3::new(0.0, 0.003, 0.004)];
        let b = [Vec3::new(0.001, 0.0, 0.0), Vec3::zeros()];
        let e = vertex_errors_mm(&a, &b).expect("same length");
        assert!(
            (e[0] - 1.0).abs() < 1e-9 && (e[1] - 5.0).abs() < 1e-9,
            "{e:?}"
        );
        assert!(vertex_errors_mm(&a, &b[..1]).is_err());
    }
}
