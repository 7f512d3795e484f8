//! What `garmatnet drape` and the `drape` example share: materials given as normalised ω,
//! outputs chosen by file extension (OBJ, glTF binary, PLY, PNG render), and the comparison
//! of a prediction with the simulator's ground truth for the same input.

use std::path::{Path, PathBuf};
use std::time::Instant;

use garmatnet_core::read_poses;
use garmatnet_core::render::{
    BODY_COLOR, Camera, Color, GARMENT_COLOR, RenderItem, RenderSettings, Shading, heat_colors,
    render, save_png, side_by_side,
};
use garmatnet_core::{
    CapsuleBody, Error as CoreError, Garment, MATERIAL_DIM, Material, Pose, Real, SkinnedBody,
    TriMesh, Vec3, write_obj, write_ply,
};
use garmatnet_core::{GlbAnimatedMesh, GlbMesh, GlbSkinnedMesh, write_glb, write_glb_animation};
use garmatnet_sim::{
    MotionGenerator, SequenceSettings, drape_sequence, everyday_pose, everyday_poses,
};
use image::RgbImage;

use crate::dataset_loader::{SampleKey, TrainingDataset};
use crate::error::{Error, Result};

/// The seed of the built-in motion sequence that `--pose FRAME` indexes.
pub const DEFAULT_MOTION_SEED: u64 = 0;
/// The number of frames of the built-in motion sequence that `--pose FRAME` indexes.
pub const DEFAULT_MOTION_FRAMES: usize = 240;

/// The `--pose` value that names the everyday suite ([`garmatnet_sim::everyday_poses`]);
/// `everyday:NAME` names one of its poses.
pub const EVERYDAY_POSES: &str = "everyday";

/// Resolves a `--pose` argument: a frame number of the built-in motion sequence
/// ([`DEFAULT_MOTION_SEED`], [`DEFAULT_MOTION_FRAMES`]), `everyday` (the everyday suite, of
/// which `frame` picks one pose), `everyday:NAME` (its pose called NAME) or a pose file
/// (`.json`, `.npz`, `.npy`), of which `frame` picks one pose (default the first). No
/// argument is the T-pose.
///
/// # Errors
/// [`CoreError::OutOfRange`] for a frame past the sequence or the file;
/// [`CoreError::InvalidArgument`] for a `frame` without a pose file to pick from (no `spec`,
/// or a frame number of the built-in motion) and for an unknown everyday pose name; the
/// pose file reader's errors (missing file, malformed content, NaN) otherwise.
pub fn resolve_pose(spec: Option<&str>, frame: Option<usize>) -> Result<Pose> {
    let no_file = |what: &str| {
        CoreError::InvalidArgument(format!(
            "--frame picks a pose from a pose file, but {what}: give `--pose FILE --frame N`, \
             or `--pose N` alone for frame N of the built-in motion"
        ))
    };
    let Some(spec) = spec else {
        return match frame {
            Some(_) => Err(no_file("no --pose was given").into()),
            None => Ok(Pose::zero()),
        };
    };
    let out_of_range = |what: &str, index: usize, count: usize| CoreError::OutOfRange {
        what: what.into(),
        value: index as Real,
        min: 0.0,
        max: count.saturating_sub(1) as Real,
        hint: String::new(),
    };
    if let Ok(index) = spec.trim().parse::<usize>() {
        if frame.is_some() {
            return Err(
                no_file(&format!("--pose {index} is a frame of the built-in motion")).into(),
            );
        }
        let frames = MotionGenerator::new(DEFAULT_MOTION_SEED, DEFAULT_MOTION_FRAMES).generate();
        return frames.get(index).cloned().ok_or_else(|| {
            out_of_range("frame of the built-in motion (--pose)", index, frames.len()).into()
        });
    }
    if let Some(name) = everyday_name(spec) {
        if frame.is_some() {
            return Err(no_file(&format!("--pose {spec} names one pose")).into());
        }
        return Ok(everyday_pose(name)?);
    }
    let poses = pose_list(spec)?;
    let index = frame.unwrap_or(0);
    poses.get(index).cloned().ok_or_else(|| {
        out_of_range(
            &format!("pose index into `{spec}` (--frame)"),
            index,
            poses.len(),
        )
        .into()
    })
}

/// Resolves a `--frames` argument: which poses of a pose file (`pose_file`, `.json`, `.npz`,
/// `.npy`) or of the everyday suite (`pose_file` = `everyday`), or of the built-in motion
/// sequence ([`DEFAULT_MOTION_SEED`], [`DEFAULT_MOTION_FRAMES`]) when there is none, to
/// predict in order. `frames` is `START..END` (END excluded), `START..=END`, `START..` (to
/// the last pose) or `all`; returns each pose with its index.
///
/// # Errors
/// [`CoreError::InvalidArgument`] for another form or an empty range;
/// [`CoreError::OutOfRange`] for a range past the poses there are; the pose file reader's
/// errors (missing file, malformed content, NaN) otherwise.
pub fn resolve_frames(pose_file: Option<&str>, frames: &str) -> Result<Vec<(usize, Pose)>> {
    let (poses, source) = match pose_file {
        Some(file) => (pose_list(file)?, format!("`{file}`")),
        None => (
            MotionGenerator::new(DEFAULT_MOTION_SEED, DEFAULT_MOTION_FRAMES).generate(),
            "the built-in motion".to_owned(),
        ),
    };
    let range = frame_range(frames, poses.len(), &source)?;
    Ok(range.clone().zip(poses[range].iter().cloned()).collect())
}

/// `NAME` of an `everyday:NAME` pose argument.
fn everyday_name(spec: &str) -> Option<&str> {
    let (head, name) = spec.trim().split_once(':')?;
    head.eq_ignore_ascii_case(EVERYDAY_POSES).then_some(name)
}

/// The poses of a pose file, or the everyday suite for [`EVERYDAY_POSES`].
fn pose_list(spec: &str) -> Result<Vec<Pose>> {
    if spec.trim().eq_ignore_ascii_case(EVERYDAY_POSES) {
        return Ok(everyday_poses().into_iter().map(|p| p.pose).collect());
    }
    Ok(read_poses(Path::new(spec))?)
}

/// The frames of the shipped model's training motion: [`DEFAULT_MOTION_SEED`],
/// [`SHIPPED_TRAINING_FRAMES`] frames at the default pace and arm clearance, the poses of
/// `garmatnet simulate --poses 200 --seed 0 --motion brisk` (the default before independent
/// poses). `frames` as in [`resolve_frames`].
///
/// # Errors
/// As [`resolve_frames`].
pub fn training_motion_frames(frames: &str) -> Result<Vec<(usize, Pose)>> {
    let poses = MotionGenerator::new(DEFAULT_MOTION_SEED, SHIPPED_TRAINING_FRAMES).generate();
    let range = frame_range(frames, poses.len(), "the shipped model's training motion")?;
    Ok(range.clone().zip(poses[range].iter().cloned()).collect())
}

/// The number of frames of the motion the shipped model was trained on
/// ([`training_motion_frames`]).
pub const SHIPPED_TRAINING_FRAMES: usize = 200;

/// The poses `text` (`START..END`, `START..=END`, `START..` or `all`) picks of `count`.
fn frame_range(text: &str, count: usize, source: &str) -> Result<std::ops::Range<usize>> {
    let text = text.trim();
    let malformed = || {
        CoreError::InvalidArgument(format!(
            "cannot read the frames `{text}`: write START..END (END excluded), START..=END, \
             START.. or all, e.g. 0..120"
        ))
    };
    let number = |t: &str| t.trim().parse::<usize>().map_err(|_| malformed());
    let range = if text.eq_ignore_ascii_case("all") {
        0..count
    } else if let Some((start, end)) = text.split_once("..=") {
        number(start)?..number(end)?.checked_add(1).ok_or_else(malformed)?
    } else if let Some((start, end)) = text.split_once("..") {
        let end = if end.trim().is_empty() {
            count
        } else {
            number(end)?
        };
        number(start)?..end
    } else {
        return Err(malformed().into());
    };
    if range.is_empty() {
        return Err(CoreError::InvalidArgument(format!(
            "the frames `{text}` name no pose: END must lie past START"
        ))
        .into());
    }
    if range.end > count {
        return Err(CoreError::OutOfRange {
            what: format!("last frame of `{text}` in {source} (--frames)"),
            value: (range.end - 1) as Real,
            min: 0.0,
            max: count.saturating_sub(1) as Real,
            hint: String::new(),
        }
        .into());
    }
    Ok(range)
}

/// `path` with a frame number before its extension, `drape.obj` → `drape.0007.obj`, wide
/// enough for `last`, so a sequence's files sort in frame order.
#[must_use]
pub fn numbered_path(path: &Path, frame: usize, last: usize) -> PathBuf {
    let width = last.max(1).to_string().len().max(4);
    let stem = path
        .file_stem()
        .map_or_else(|| "drape".to_owned(), |s| s.to_string_lossy().into_owned());
    let name = match path.extension() {
        Some(ext) => format!("{stem}.{frame:0width$}.{}", ext.to_string_lossy()),
        None => format!("{stem}.{frame:0width$}"),
    };
    path.with_file_name(name)
}

/// Where the comparison image of the PNG `path` goes: `drape.png` → `drape_compare.png`.
#[must_use]
pub fn compare_path(path: &Path) -> PathBuf {
    let stem = path
        .file_stem()
        .map_or_else(|| "drape".to_owned(), |s| s.to_string_lossy().into_owned());
    path.with_file_name(format!("{stem}_compare.png"))
}

/// The material of a `--material` / `--omega` pair: `omega` (normalised ω, see
/// [`material_from_omega`]) when given, else `material` (a preset name or six physical
/// values, see [`Material::from_str`](std::str::FromStr)), else the preset named `default`.
///
/// # Errors
/// As [`material_from_omega`] and [`Material::from_str`](std::str::FromStr): unknown
/// names (with the closest presets), wrong counts, values out of range.
pub fn resolve_material(
    material: Option<&str>,
    omega: Option<&str>,
    default: &str,
) -> Result<Material> {
    match (omega, material) {
        (Some(o), _) => material_from_omega(o),
        (None, Some(m)) => Ok(m.parse::<Material>()?),
        (None, None) => Ok(Material::preset(default)?),
    }
}

/// A file-name-safe lowercase form of a name (e.g. a fabric's): ASCII letters and digits
/// kept, everything else `_`.
///
/// ```
/// assert_eq!(garmatnet_train::slug("Sherpa Fleece 160"), "sherpa_fleece_160");
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

/// Parses a normalised material ω: six comma-separated numbers in [0, 1] (structural V/H,
/// flexion V/H, shear, density on the library's log scale; see
/// [`Material::to_normalized`]).
///
/// ```
/// let m = garmatnet_train::material_from_omega("0.5, 0.5, 0.5, 0.5, 0.5, 0.5")?;
/// assert!((m.to_normalized()[0] - 0.5).abs() < 1e-12);
/// # Ok::<(), garmatnet_train::Error>(())
/// ```
///
/// # Errors
/// [`CoreError::InvalidArgument`] when there are not six numbers or one does not parse;
/// [`CoreError::OutOfRange`] / [`CoreError::NonFinite`] (naming the component) for a value
/// outside [0, 1] or NaN.
pub fn material_from_omega(text: &str) -> Result<Material> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    if parts.len() != MATERIAL_DIM {
        return Err(CoreError::InvalidArgument(format!(
            "ω needs {MATERIAL_DIM} comma-separated numbers in [0, 1] (structural V, structural \
             H, flexion V, flexion H, shear, density), got {} in `{text}`",
            parts.len()
        ))
        .into());
    }
    let mut omega = [0.0; MATERIAL_DIM];
    for (k, part) in parts.iter().enumerate() {
        omega[k] = part.parse::<Real>().map_err(|_| {
            CoreError::InvalidArgument(format!("ω component {} is `{part}`, not a number", k + 1))
        })?;
    }
    Ok(Material::from_normalized(omega)?)
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
    /// [`CoreError::InvalidArgument`] for another or a missing extension, listing the ones
    /// understood.
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
            _ => Err(CoreError::InvalidArgument(format!(
                "cannot tell the output format of `{}`: end the file name in .obj, .glb, .ply \
                 or .png",
                path.display()
            ))
            .into()),
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
    /// [`CoreError::Mismatch`] when the colour list does not match the garment.
    pub fn render(&self, settings: &RenderSettings) -> Result<RgbImage> {
        let bounds = self
            .body
            .bounds()
            .ok_or_else(|| CoreError::InvalidMesh("the body mesh is empty".into()))?;
        let camera = Camera::framing(bounds.min, bounds.max, 0.35);
        let garment_shading = match self.garment_colors {
            Some(colors) => Shading::PerVertex(colors),
            None => Shading::Uniform(GARMENT_COLOR),
        };
        Ok(render(
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
        )?)
    }

    /// Writes the view to `path` in the format its extension names ([`OutputFormat`]),
    /// atomically: OBJ and PLY hold the garment, GLB garment and body, PNG a render.
    ///
    /// # Errors
    /// [`CoreError::InvalidArgument`] for an unknown extension; [`CoreError::Io`] when the
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
    /// The simulator's garment at each frame, to show beside the prediction
    /// ([`simulate_sequence`]), if any.
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
    /// [`CoreError::InvalidArgument`] for an unknown extension or no frames;
    /// [`CoreError::Mismatch`] when the lists differ in length; the writers' errors
    /// otherwise (files already written for earlier frames stay, each complete).
    pub fn write(&self, path: &Path) -> Result<Vec<PathBuf>> {
        let format = OutputFormat::from_path(path)?;
        let n = self.frames.len();
        if n == 0 {
            return Err(CoreError::InvalidArgument("a drape sequence needs a frame".into()).into());
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
                return Err(CoreError::Mismatch {
                    what: format!("{what} of the drape sequence"),
                    expected: format!("{n} (one per frame)"),
                    got: len.to_string(),
                }
                .into());
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

/// One fabric's stored drapes over a run of a dataset's frames: the ground truth as a
/// sequence ([`stored_sequence`]), for a [`DrapeSequence`].
#[derive(Debug, Clone, PartialEq)]
pub struct StoredSequence {
    /// The fabric's name, as the dataset spells it.
    pub material: String,
    /// The dataset's pose indices, in order.
    pub frames: Vec<usize>,
    /// The pose of each frame.
    pub poses: Vec<Pose>,
    /// The simulated garment of each frame, as stored (metres).
    pub garments: Vec<TriMesh>,
}

/// The stored drapes of the fabric named `material` (case-insensitive) in `data`, at the
/// frames `frames` names (`START..END`, `START..=END`, `START..` or `all`, as
/// [`resolve_frames`] reads them, of the dataset's poses).
///
/// # Errors
/// [`Error::Dataset`] for a name the dataset does not hold (listing what it holds) or a
/// frame not draped yet (named); the frame parser's errors; unreadable arrays.
pub fn stored_sequence(
    data: &TrainingDataset,
    material: &str,
    frames: &str,
) -> Result<StoredSequence> {
    let spec = data.spec();
    let index = spec
        .materials
        .iter()
        .position(|m| m.name.eq_ignore_ascii_case(material.trim()))
        .ok_or_else(|| {
            let names: Vec<&str> = spec.materials.iter().map(|m| m.name.as_str()).collect();
            Error::Dataset {
                dir: data.dir().to_owned(),
                message: format!(
                    "it holds no fabric named `{material}`; it holds: {}",
                    names.join(", ")
                ),
            }
        })?;
    let range = frame_range(frames, spec.poses.len(), "the dataset's poses")?;
    let mut sequence = StoredSequence {
        material: spec.materials[index].name.clone(),
        frames: range.clone().collect(),
        poses: spec.poses[range.clone()].to_vec(),
        garments: Vec::with_capacity(range.len()),
    };
    for pose in range {
        let truth = data.truth(SampleKey {
            material: index,
            pose,
        })?;
        sequence.garments.push(TriMesh::new(
            truth.simulated,
            data.garment().rest.faces.clone(),
        )?);
    }
    Ok(sequence)
}

/// The simulator's drape of one (pose, material): the ground truth a prediction is compared
/// with.
#[derive(Debug, Clone, PartialEq)]
pub struct SimulatedDrape {
    /// The settled garment (metres).
    pub vertices: Vec<Vec3>,
    /// Wall-clock time of the whole drape: rest drape, walk to the pose, converge (ms).
    pub wall_ms: Real,
    /// Whether the final converge met the residual tolerances.
    pub converged: bool,
}

/// Drapes `garment` of `material` on `body` at `pose` with the dataset generator's solver and
/// settings (from the rest garment, through intermediate poses), on this thread.
///
/// # Errors
/// The solver's errors ([`garmatnet_sim::Error`]), e.g. a material outside the physical range.
pub fn simulate_drape(
    garment: &Garment,
    body: &CapsuleBody,
    pose: &Pose,
    material: &Material,
    settings: &SequenceSettings,
) -> Result<SimulatedDrape> {
    // One pose: its drape's time runs from the start, rest drape and walk included.
    simulate_sequence(
        garment,
        body,
        std::slice::from_ref(pose),
        material,
        settings,
    )?
    .pop()
    .ok_or_else(|| CoreError::InvalidArgument("the simulator returned no drape".into()).into())
}

/// The simulator's drapes along `poses`, in order, as a dataset walks them
/// ([`drape_sequence`]: the rest drape, then each pose reached through intermediate poses and
/// converged): the ground truth to hold a predicted sequence against. Each drape's `wall_ms`
/// is the time since the previous one (the first includes the rest drape).
///
/// # Errors
/// The simulator's errors ([`Error::Sim`]).
pub fn simulate_sequence(
    garment: &Garment,
    body: &CapsuleBody,
    poses: &[Pose],
    material: &Material,
    settings: &SequenceSettings,
) -> Result<Vec<SimulatedDrape>> {
    let mut drapes = Vec::with_capacity(poses.len());
    let mut last = Instant::now();
    let stats = drape_sequence(garment, body, material, poses, settings, None, |_, x, _| {
        let now = Instant::now();
        drapes.push(SimulatedDrape {
            vertices: x.to_vec(),
            wall_ms: (now - last).as_secs_f64() * 1e3,
            converged: false,
        });
        last = now;
        Ok(())
    })
    .map_err(Error::Sim)?;
    // `stats` holds the rest drape first, then one per pose.
    for (drape, stat) in drapes.iter_mut().zip(stats.iter().skip(1)) {
        drape.converged = stat.converged;
    }
    Ok(drapes)
}

/// Per-vertex Euclidean distance between two garments of one template (millimetres).
///
/// # Errors
/// [`CoreError::Mismatch`] when the vertex counts differ.
pub fn vertex_errors_mm(predicted: &[Vec3], truth: &[Vec3]) -> Result<Vec<Real>> {
    if predicted.len() != truth.len() {
        return Err(CoreError::Mismatch {
            what: "garment vertex counts".into(),
            expected: truth.len().to_string(),
            got: predicted.len().to_string(),
        }
        .into());
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
/// [`CoreError::Mismatch`] when the meshes or the error list disagree in size.
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
    use garmatnet_core::Resolution;

    #[test]
    fn omega_round_trips_and_bad_omega_says_what_to_fix() {
        let m = material_from_omega("0.1,0.2,0.3,0.4,0.5,0.6").expect("valid ω");
        let n = m.to_normalized();
        for (k, want) in [0.1, 0.2, 0.3, 0.4, 0.5, 0.6].iter().enumerate() {
            assert!((n[k] - want).abs() < 1e-9, "component {k}: {}", n[k]);
        }
        let few = material_from_omega("0.1,0.2").expect_err("two numbers");
        assert!(few.to_string().contains("6 comma-separated"), "{few}");
        let word = material_from_omega("0.1,0.2,x,0.4,0.5,0.6").expect_err("not a number");
        assert!(word.to_string().contains("component 3"), "{word}");
        assert!(material_from_omega("0.1,0.2,1.5,0.4,0.5,0.6").is_err());
        assert!(material_from_omega("0.1,0.2,NaN,0.4,0.5,0.6").is_err());
    }

    #[test]
    fn poses_resolve_from_frames_and_files() -> anyhow::Result<()> {
        assert_eq!(resolve_pose(None, None)?, Pose::zero());
        let frames = MotionGenerator::new(DEFAULT_MOTION_SEED, DEFAULT_MOTION_FRAMES).generate();
        assert_eq!(resolve_pose(Some("7"), None)?, frames[7]);
        let err = resolve_pose(Some("240"), None).expect_err("past the end");
        assert!(err.to_string().contains("239"), "{err}");
        let dir = tempfile::tempdir()?;
        let file = dir.path().join("p.json");
        garmatnet_core::write_poses_json(&file, &frames[..2])?;
        let file = file.to_str().expect("utf-8 path");
        assert_eq!(resolve_pose(Some(file), Some(1))?, frames[1]);
        assert!(resolve_pose(Some(file), Some(2)).is_err());
        assert!(resolve_pose(Some("/no/such/poses.json"), None).is_err());
        // A --frame with nothing to pick from is refused, not ignored.
        for (spec, frame) in [(None, Some(3)), (Some("5"), Some(3))] {
            let err = resolve_pose(spec, frame).expect_err("--frame without a file");
            assert!(err.to_string().contains("--pose FILE --frame N"), "{err}");
        }
        Ok(())
    }

    #[test]
    fn everyday_poses_resolve_by_index_name_and_range() -> anyhow::Result<()> {
        let suite = everyday_poses();
        assert_eq!(resolve_pose(Some("everyday"), None)?, suite[0].pose);
        assert_eq!(resolve_pose(Some("everyday"), Some(3))?, suite[3].pose);
        assert_eq!(
            resolve_pose(Some("everyday:arms-at-sides"), None)?,
            everyday_pose("arms-at-sides")?
        );
        let unknown = resolve_pose(Some("everyday:cartwheel"), None).expect_err("no such pose");
        assert!(unknown.to_string().contains("hands-on-hips"), "{unknown}");
        assert!(resolve_pose(Some("everyday"), Some(suite.len())).is_err());
        let all = resolve_frames(Some("everyday"), "all")?;
        assert_eq!(all.len(), suite.len());
        assert_eq!(all[5].1, suite[5].pose);
        Ok(())
    }

    #[test]
    fn frames_resolve_as_ranges_of_a_file_or_the_motion() -> anyhow::Result<()> {
        let motion = MotionGenerator::new(DEFAULT_MOTION_SEED, DEFAULT_MOTION_FRAMES).generate();
        let picked = resolve_frames(None, "10..13")?;
        assert_eq!(
            picked.iter().map(|(f, _)| *f).collect::<Vec<_>>(),
            vec![10, 11, 12]
        );
        assert_eq!(picked[2].1, motion[12]);
        assert_eq!(resolve_frames(None, "10..=12")?.len(), 3);
        assert_eq!(resolve_frames(None, "230..")?.len(), 10);
        assert_eq!(resolve_frames(None, "all")?.len(), DEFAULT_MOTION_FRAMES);
        let dir = tempfile::tempdir()?;
        let file = dir.path().join("p.json");
        garmatnet_core::write_poses_json(&file, &motion[..5])?;
        let file = file.to_str().expect("utf-8 path");
        let all = resolve_frames(Some(file), "all")?;
        assert_eq!(all.len(), 5);
        assert_eq!(all[4], (4, motion[4].clone()));
        for (bad, hint) in [
            ("3..9", "4"), // past the file's last pose, which is named
            ("3..3", "END must lie past START"),
            ("4..=2", "END must lie past START"),
            ("a..3", "START..END"),
            ("7", "START..END"),
            ("-1..3", "START..END"),
        ] {
            let err = resolve_frames(Some(file), bad).expect_err(bad);
            assert!(err.to_string().contains(hint), "{bad}: {err}");
        }
        assert!(resolve_frames(Some("/no/such/poses.json"), "all").is_err());
        Ok(())
    }

    #[test]
    fn a_simulated_sequence_walks_as_a_single_drape_does() -> anyhow::Result<()> {
        let body = CapsuleBody::smpl_neutral();
        let shirt = Garment::tshirt(Resolution::Coarse, &body)?;
        let motion = MotionGenerator::new(DEFAULT_MOTION_SEED, DEFAULT_MOTION_FRAMES).generate();
        let silk = Material::preset("Silk Chiffon")?;
        let settings = SequenceSettings::default();
        let drapes = simulate_sequence(&shirt, &body, &motion[2..4], &silk, &settings)?;
        assert_eq!(drapes.len(), 2);
        // Its first frame is the single drape of that pose: the same walk from rest.
        let single = simulate_drape(&shirt, &body, &motion[2], &silk, &settings)?;
        assert_eq!(drapes[0].vertices, single.vertices);
        assert_eq!(drapes[0].converged, single.converged);
        assert_ne!(drapes[1].vertices, drapes[0].vertices);
        assert!(drapes.iter().all(|d| d.wall_ms > 0.0));
        Ok(())
    }

    #[test]
    fn a_fabrics_stored_drapes_come_back_as_a_sequence() -> anyhow::Result<()> {
        let dir = tempfile::tempdir()?;
        crate::test_util::synthetic_dataset(dir.path(), 3, 6);
        let data = TrainingDataset::open(dir.path(), false)?;
        let name = data.spec().materials[1].name.clone();
        let stored = stored_sequence(&data, &name.to_uppercase(), "2..=4")?;
        assert_eq!(stored.material, name);
        assert_eq!(stored.frames, [2, 3, 4]);
        assert_eq!(stored.poses, data.spec().poses[2..=4]);
        for (k, garment) in stored.garments.iter().enumerate() {
            let truth = data.truth(SampleKey {
                material: 1,
                pose: 2 + k,
            })?;
            assert_eq!(garment.vertices, truth.simulated);
            assert_eq!(garment.faces, data.garment().rest.faces);
        }
        assert_eq!(stored_sequence(&data, &name, "all")?.frames.len(), 6);
        let unknown = stored_sequence(&data, "Velvet", "all").expect_err("not in the dataset");
        assert!(unknown.to_string().contains(&name), "{unknown}");
        let past = stored_sequence(&data, &name, "4..7").expect_err("past the poses");
        assert!(past.to_string().contains("5"), "{past}");
        Ok(())
    }

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
        let motion = MotionGenerator::new(DEFAULT_MOTION_SEED, DEFAULT_MOTION_FRAMES).generate();
        let frames = [3, 4];
        let poses = [motion[3].clone(), motion[4].clone()];
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
            Some(1 + garmatnet_core::JOINT_COUNT)
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
    fn materials_resolve_from_omega_names_values_or_the_default() -> anyhow::Result<()> {
        let silk = Material::preset("Silk Chiffon")?;
        assert_eq!(resolve_material(None, None, "silk chiffon")?, silk);
        assert_eq!(
            resolve_material(Some("Silk Chiffon"), None, "denim heavy")?,
            silk
        );
        let from_values = resolve_material(Some(&silk.to_string()), None, "denim heavy")?;
        assert_eq!(from_values, silk);
        let omega = "0.5,0.5,0.5,0.5,0.5,0.5";
        assert_eq!(
            resolve_material(Some("Silk Chiffon"), Some(omega), "x")?,
            material_from_omega(omega)?,
            "ω wins over a name"
        );
        let err = resolve_material(Some("sillk chifon"), None, "x").expect_err("typo");
        assert!(err.to_string().contains("Silk Chiffon"), "{err}");
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
            err.to_string().contains(".obj, .glb, .ply or .png"),
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
        let back = garmatnet_core::read_obj(dir.path().join("g.obj"))?;
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
