//! Pose sequences on disk: JSON lists, NumPy `.npy` arrays and AMASS-style `.npz` archives.
//!
//! | extension | content |
//! |---|---|
//! | `.json` | a list of pose vectors, each 72 (SMPL) or 156 (SMPL+H) numbers |
//! | `.npy` | one `float32`/`float64` array of shape `[T, 72]` or `[T, 156]` |
//! | `.npz` | an archive whose array `poses` has shape `[T, 72]` or `[T, 156]` (AMASS) |
//!
//! 156-vectors are converted with [`Pose::from_smplh`] (hand joints dropped). Every failure
//! is an [`Error::Parse`] naming the file and what to fix; nothing here panics on bad bytes.

use std::fs::File;
use std::io::{BufReader, Read, Seek};
use std::path::Path;

use npyz::{DType, NpyFile, Order, TypeChar};

use crate::body::pose::{POSE_DIM, Pose, SMPLH_POSE_DIM};
use crate::error::{Error, Result};
use crate::io::files::write_bytes_atomic;
use crate::math::Real;

/// Reads a pose sequence from `path`, choosing the format by extension (`.json`, `.npy`,
/// `.npz`; case-insensitive).
///
/// # Errors
/// [`Error::Io`] if the file cannot be opened; [`Error::Parse`] naming the path for an
/// unknown extension, malformed content, a missing `poses` array (`.npz`), a shape other than
/// `[T, 72]`/`[T, 156]`, a dtype other than `float32`/`float64`, a non-finite value (with its
/// frame) or an empty sequence.
pub fn read_poses(path: impl AsRef<Path>) -> Result<Vec<Pose>> {
    let path = path.as_ref();
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("json") => read_json(path),
        Some("npy") => {
            let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
            poses_from_npy_bytes(&bytes, path)
        }
        Some("npz") => {
            let file = File::open(path).map_err(|e| Error::io(path, e))?;
            read_npz(BufReader::new(file), path)
        }
        _ => Err(parse(
            path,
            "unknown pose file extension; use .json (list of 72- or 156-vectors), .npy or .npz \
             (AMASS, array `poses`)"
                .into(),
        )),
    }
}

/// The frame rate an AMASS-style `.npz` records for its poses, in frames a second:
/// `mocap_framerate` (AMASS's SMPL+H releases) or `mocap_frame_rate` (its SMPL-X ones).
/// `None` for `.json` and `.npy` files and for archives without either.
///
/// # Errors
/// [`Error::Io`] if an `.npz` cannot be opened; [`Error::Parse`] naming the path for an
/// archive that is not one, or a frame rate that is not one finite, positive number.
pub fn read_pose_frame_rate(path: impl AsRef<Path>) -> Result<Option<Real>> {
    let path = path.as_ref();
    let is_npz = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("npz"));
    if !is_npz {
        return Ok(None);
    }
    let file = File::open(path).map_err(|e| Error::io(path, e))?;
    let mut archive = npyz::npz::NpzArchive::new(BufReader::new(file))
        .map_err(|e| parse(path, format!("not a valid .npz (zip) archive: {e}")))?;
    let names: Vec<String> = archive.array_names().map(str::to_owned).collect();
    let Some(key) = FRAME_RATE_KEYS
        .into_iter()
        .find(|k| names.iter().any(|n| n == k))
    else {
        return Ok(None);
    };
    let bad = |what: String| {
        parse(
            path,
            format!("array `{key}` {what}; expected one positive number"),
        )
    };
    let bytes = npz_member(&mut archive, key, MAX_FRAME_RATE_BYTES)
        .map_err(|e| bad(format!("cannot be read: {e}")))?;
    if bytes.len() as u64 > MAX_FRAME_RATE_BYTES {
        return Err(bad("is far too large".into()));
    }
    crate::io::npy_guard::plain_npy_header(&bytes).map_err(bad)?;
    let npy = NpyFile::new(&bytes[..]).map_err(|e| bad(format!("is not a valid array: {e}")))?;
    if npy.shape().iter().product::<u64>() != 1 {
        return Err(bad(format!("has shape {:?}", npy.shape())));
    }
    let value = match npy.dtype() {
        DType::Plain(t) if t.type_char() == TypeChar::Float && t.size_field() == 8 => {
            npy.into_vec::<f64>().map(|v| v[0])
        }
        DType::Plain(t) if t.type_char() == TypeChar::Float && t.size_field() == 4 => {
            npy.into_vec::<f32>().map(|v| Real::from(v[0]))
        }
        DType::Plain(t) if t.type_char() == TypeChar::Int && t.size_field() == 8 => {
            npy.into_vec::<i64>().map(|v| v[0] as Real)
        }
        other => return Err(bad(format!("has dtype {}", other.descr()))),
    }
    .map_err(|e| bad(format!("cannot be read: {e}")))?;
    if !(value.is_finite() && value > 0.0) {
        return Err(bad(format!("holds {value}")));
    }
    Ok(Some(value))
}

/// The bytes of array `key` of `archive`, at most `cap + 1` of them (more than `cap` means
/// the array is too large; the caller says so), or why they cannot be read.
fn npz_member<R: Read + Seek>(
    archive: &mut npyz::npz::NpzArchive<R>,
    key: &str,
    cap: u64,
) -> std::result::Result<Vec<u8>, String> {
    let mut bytes = Vec::new();
    archive
        .zip_archive()
        .by_name(&npyz::npz::file_name_from_array_name(key))
        .map_err(|e| e.to_string())?
        .take(cap + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| e.to_string())?;
    Ok(bytes)
}

/// The arrays AMASS stores its frame rate in, in the order they are looked for.
const FRAME_RATE_KEYS: [&str; 2] = ["mocap_framerate", "mocap_frame_rate"];

/// The largest frame-rate array read (a scalar takes about 130 bytes).
const MAX_FRAME_RATE_BYTES: u64 = 4096;

/// Writes `poses` as a JSON list of 72-vectors, atomically (a temporary file in the same
/// directory, renamed over `path` once complete), so readers never see a half-written file.
///
/// # Errors
/// [`Error::Io`] if the directory is not writable.
pub fn write_poses_json(path: impl AsRef<Path>, poses: &[Pose]) -> Result<()> {
    let path = path.as_ref();
    let bytes = serde_json::to_vec(poses).map_err(|e| Error::io(path, e.into()))?;
    write_bytes_atomic(path, &bytes)
}

fn parse(path: &Path, message: String) -> Error {
    Error::Parse {
        path: path.to_owned(),
        line: None,
        message,
    }
}

fn read_json(path: &Path) -> Result<Vec<Pose>> {
    let text = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let rows: Vec<Vec<Real>> = serde_json::from_slice(&text).map_err(|e| Error::Parse {
        path: path.to_owned(),
        line: Some(e.line()),
        message: format!("expected a JSON list of pose vectors (72 or 156 numbers each): {e}"),
    })?;
    let frames: Vec<&[Real]> = rows.iter().map(Vec::as_slice).collect();
    poses_from_rows(&frames, path)
}

fn read_npz<R: Read + Seek>(reader: R, path: &Path) -> Result<Vec<Pose>> {
    let mut archive = npyz::npz::NpzArchive::new(reader)
        .map_err(|e| parse(path, format!("not a valid .npz (zip) archive: {e}")))?;
    let names: Vec<String> = archive.array_names().map(str::to_owned).collect();
    if !names.iter().any(|n| n == "poses") {
        return Err(parse(
            path,
            format!(
                "archive has no `poses` array (found: [{}]); AMASS files store poses there",
                names.join(", ")
            ),
        ));
    }
    let bytes = npz_member(&mut archive, "poses", MAX_POSE_ARRAY_BYTES)
        .map_err(|e| parse(path, format!("cannot read array `poses`: {e}")))?;
    if bytes.len() as u64 > MAX_POSE_ARRAY_BYTES {
        return Err(parse(
            path,
            format!(
                "array `poses` decompresses to over {} MB; split the sequence into smaller files",
                MAX_POSE_ARRAY_BYTES >> 20
            ),
        ));
    }
    poses_from_npy_bytes(&bytes, path)
}

/// The largest `poses` array read from an `.npz` (bytes, decompressed): 400,000 SMPL+H
/// frames in float64, and a guard against zip bombs.
const MAX_POSE_ARRAY_BYTES: u64 = 512 << 20;

/// Decodes a whole `.npy` file's bytes, its header checked first
/// ([`crate::io::npy_guard::plain_npy_header`]).
fn poses_from_npy_bytes(bytes: &[u8], path: &Path) -> Result<Vec<Pose>> {
    crate::io::npy_guard::plain_npy_header(bytes).map_err(|m| parse(path, m))?;
    let npy =
        NpyFile::new(bytes).map_err(|e| parse(path, format!("not a valid .npy file: {e}")))?;
    poses_from_npy(npy, path)
}

/// Decodes a `[T, 72]` or `[T, 156]` float array into poses.
fn poses_from_npy<R: Read>(npy: NpyFile<R>, path: &Path) -> Result<Vec<Pose>> {
    let shape = npy.shape().to_vec();
    let (frames, width) = match shape[..] {
        [t, w] if w == POSE_DIM as u64 || w == SMPLH_POSE_DIM as u64 => (t, w as usize),
        _ => {
            return Err(parse(
                path,
                format!(
                    "pose array has shape {shape:?}; expected [T, {POSE_DIM}] (SMPL) or \
                     [T, {SMPLH_POSE_DIM}] (SMPL+H / AMASS)"
                ),
            ));
        }
    };
    if frames == 0 {
        return Err(parse(
            path,
            "pose array has no frames (shape [0, _])".into(),
        ));
    }
    let dtype = npy.dtype();
    let float_bytes = match &dtype {
        DType::Plain(ts) if ts.type_char() == TypeChar::Float => ts.size_field(),
        _ => 0,
    };
    // A crafted shape can overflow the element count (npyz's too): refuse it by size first.
    if frames
        .checked_mul(width as u64)
        .and_then(|n| n.checked_mul(float_bytes.max(1)))
        .is_none_or(|bytes| bytes > MAX_POSE_ARRAY_BYTES)
    {
        return Err(parse(
            path,
            format!(
                "pose array declares shape {shape:?}, more than the {} MiB a pose file may hold",
                MAX_POSE_ARRAY_BYTES >> 20
            ),
        ));
    }
    let order = npy.order();
    let read_err = |e: std::io::Error| parse(path, format!("cannot read pose data: {e}"));
    let values: Vec<Real> = match float_bytes {
        8 => npy.into_vec::<f64>().map_err(read_err)?,
        4 => npy
            .into_vec::<f32>()
            .map_err(read_err)?
            .into_iter()
            .map(Real::from)
            .collect(),
        _ => {
            return Err(parse(
                path,
                format!("pose array has dtype {dtype:?}; expected float32 or float64"),
            ));
        }
    };
    let frames = usize::try_from(frames).map_err(|_| parse(path, "too many frames".into()))?;
    if frames.checked_mul(width) != Some(values.len()) {
        return Err(parse(path, "pose array is truncated".into()));
    }
    let values = match order {
        Order::C => values,
        // Column-major: element (t, c) lives at c * T + t.
        Order::Fortran => (0..frames * width)
            .map(|i| values[(i % width) * frames + i / width])
            .collect(),
    };
    let rows: Vec<&[Real]> = values.chunks_exact(width).collect();
    poses_from_rows(&rows, path)
}

fn poses_from_rows(rows: &[&[Real]], path: &Path) -> Result<Vec<Pose>> {
    if rows.is_empty() {
        return Err(parse(
            path,
            "pose sequence is empty; give at least one frame".into(),
        ));
    }
    rows.iter()
        .enumerate()
        .map(|(k, row)| {
            if let Some(i) = row.iter().position(|v| !v.is_finite()) {
                return Err(parse(
                    path,
                    format!("frame {k} has a non-finite value (NaN or infinity) at index {i}"),
                ));
            }
            Pose::from_smplh(row).map_err(|e| parse(path, format!("frame {k}: {e}")))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;
    use npyz::WriterBuilder;
    use proptest::prelude::*;

    fn sample_poses(n: usize) -> Vec<Pose> {
        (0..n)
            .map(|i| {
                let mut p = Pose::zero();
                p.set_joint(16, Vec3::new(0.1 * i as Real, -0.3, 0.25));
                p.set_joint(3, Vec3::new(-0.05, 0.01 * i as Real, 0.0));
                p
            })
            .collect()
    }

    /// Adds array `key` of `shape` holding `data` to `npz`.
    fn put<T: npyz::AutoSerialize + Copy>(
        npz: &mut npyz::npz::NpzWriter<std::io::BufWriter<File>>,
        key: &str,
        shape: &[u64],
        data: &[T],
    ) {
        let mut w = npz
            .array::<T>(key, Default::default())
            .unwrap()
            .default_dtype()
            .shape(shape)
            .begin_nd()
            .unwrap();
        w.extend(data.iter().copied()).unwrap();
        w.finish().unwrap();
    }

    fn write_npz<T: npyz::AutoSerialize + Copy>(path: &Path, key: &str, shape: &[u64], data: &[T]) {
        put(
            &mut npyz::npz::NpzWriter::create(path).unwrap(),
            key,
            shape,
            data,
        );
    }

    /// An AMASS-like archive: `poses` (`[2, 72]`, zeros) and one more array.
    fn write_npz_with<T: npyz::AutoSerialize + Copy>(
        path: &Path,
        key: &str,
        shape: &[u64],
        data: &[T],
    ) {
        let mut npz = npyz::npz::NpzWriter::create(path).unwrap();
        put(&mut npz, "poses", &[2, 72], &[0.0_f64; 144]);
        put(&mut npz, key, shape, data);
    }

    #[test]
    fn amass_frame_rates_are_read_and_checked() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.npz");
        write_npz_with(&p, "mocap_framerate", &[], &[120.0_f64]);
        assert_eq!(read_pose_frame_rate(&p).unwrap(), Some(120.0));
        assert_eq!(read_poses(&p).unwrap().len(), 2);
        write_npz_with(&p, "mocap_frame_rate", &[], &[59.94_f32]);
        let rate = read_pose_frame_rate(&p).unwrap().unwrap();
        assert!((rate - 59.94).abs() < 1e-5, "{rate}");
        write_npz_with(&p, "mocap_framerate", &[1], &[60_i64]);
        assert_eq!(read_pose_frame_rate(&p).unwrap(), Some(60.0));
        // No rate: none, for an archive without one and for the other formats.
        write_npz_with(&p, "betas", &[16], &[0.0_f64; 16]);
        assert_eq!(read_pose_frame_rate(&p).unwrap(), None);
        let json = dir.path().join("p.json");
        write_poses_json(&json, &[Pose::zero()]).unwrap();
        assert_eq!(read_pose_frame_rate(&json).unwrap(), None);
        // A rate that is no rate is refused, naming the array.
        for (shape, values) in [
            (vec![], vec![0.0]),
            (vec![], vec![f64::NAN]),
            (vec![2], vec![30.0, 60.0]),
        ] {
            write_npz_with(&p, "mocap_framerate", &shape, &values);
            let err = message(read_pose_frame_rate(&p).unwrap_err());
            assert!(err.contains("mocap_framerate"), "{err}");
        }
        std::fs::write(&p, b"not a zip").unwrap();
        assert!(read_pose_frame_rate(&p).is_err());
    }

    fn write_npy<T: npyz::AutoSerialize + Copy>(path: &Path, shape: &[u64], data: &[T]) {
        let file = std::io::BufWriter::new(File::create(path).unwrap());
        let mut w = npyz::WriteOptions::new()
            .default_dtype()
            .shape(shape)
            .writer(file)
            .begin_nd()
            .unwrap();
        w.extend(data.iter().copied()).unwrap();
        w.finish().unwrap();
    }

    fn message(err: Error) -> String {
        match err {
            Error::Parse { message, .. } => message,
            other => panic!("expected Error::Parse, got {other:?}"),
        }
    }

    #[test]
    fn json_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("poses.json");
        let poses = sample_poses(5);
        write_poses_json(&path, &poses).unwrap();
        assert_eq!(read_poses(&path).unwrap(), poses);
        // Only the target file remains: the temporary was renamed, not left behind.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn json_accepts_smplh_vectors() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("h.json");
        let row: Vec<Real> = (0..156).map(|i| i as Real * 1e-3).collect();
        std::fs::write(
            &path,
            serde_json::to_string(&vec![row.clone(), row.clone()]).unwrap(),
        )
        .unwrap();
        let poses = read_poses(&path).unwrap();
        assert_eq!(poses.len(), 2);
        assert_eq!(poses[1].to_vec()[..66], row[..66]);
        assert!(poses[1].to_vec()[66..].iter().all(|v| *v == 0.0));
    }

    #[test]
    fn npz_smplh_f64_and_smpl_f32() {
        let dir = tempfile::tempdir().unwrap();
        let t = 4;
        let h: Vec<f64> = (0..t * 156)
            .map(|i| ((i % 156) as f64 - 70.0) * 1e-3)
            .collect();
        let p = dir.path().join("amass.npz");
        write_npz(&p, "poses", &[t as u64, 156], &h);
        let poses = read_poses(&p).unwrap();
        assert_eq!(poses.len(), t);
        assert_eq!(poses[3].to_vec()[..66], h[3 * 156..3 * 156 + 66]);

        let s: Vec<f32> = (0..t * 72).map(|i| (i as f32) * 1e-3).collect();
        let p = dir.path().join("smpl.npz");
        write_npz(&p, "poses", &[t as u64, 72], &s);
        let poses = read_poses(&p).unwrap();
        for (k, pose) in poses.iter().enumerate() {
            for (c, v) in pose.to_vec().iter().enumerate() {
                assert_eq!(*v, f64::from(s[k * 72 + c]));
            }
        }
    }

    #[test]
    fn npy_c_order_matches_json() {
        let dir = tempfile::tempdir().unwrap();
        let poses = sample_poses(3);
        let flat: Vec<f64> = poses.iter().flat_map(Pose::to_vec).collect();
        let p = dir.path().join("p.npy");
        write_npy(&p, &[3, 72], &flat);
        assert_eq!(read_poses(&p).unwrap(), poses);
    }

    #[test]
    fn malformed_inputs_are_typed_errors() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let j = d.join("bad.json");
        std::fs::write(&j, "[[0.0, 1.0,").unwrap();
        assert!(matches!(
            read_poses(&j),
            Err(Error::Parse { line: Some(1), .. })
        ));

        std::fs::write(
            &j,
            serde_json::to_string(&vec![vec![0.0; 72], vec![0.0; 70]]).unwrap(),
        )
        .unwrap();
        let m = message(read_poses(&j).unwrap_err());
        assert!(m.contains("frame 1") && m.contains("70"), "{m}");

        std::fs::write(&j, "[]").unwrap();
        assert!(message(read_poses(&j).unwrap_err()).contains("empty"));

        let mut nan = vec![0.0f64; 5 * 72];
        nan[3 * 72 + 10] = f64::NAN;
        let p = d.join("nan.npz");
        write_npz(&p, "poses", &[5, 72], &nan);
        let m = message(read_poses(&p).unwrap_err());
        assert!(m.contains("frame 3") && m.contains("non-finite"), "{m}");

        let p = d.join("nokey.npz");
        write_npz(&p, "trans", &[5, 3], &[0.0f64; 15]);
        let m = message(read_poses(&p).unwrap_err());
        assert!(m.contains("`poses`") && m.contains("trans"), "{m}");

        let p = d.join("shape.npy");
        write_npy(&p, &[2, 71], &[0.0f64; 142]);
        assert!(message(read_poses(&p).unwrap_err()).contains("[2, 71]"));

        let p = d.join("empty.npy");
        write_npy::<f64>(&p, &[0, 72], &[]);
        assert!(message(read_poses(&p).unwrap_err()).contains("no frames"));

        let p = d.join("int.npy");
        write_npy(&p, &[1, 72], &[0i32; 72]);
        assert!(message(read_poses(&p).unwrap_err()).contains("float32 or float64"));

        let p = d.join("poses.txt");
        std::fs::write(&p, "x").unwrap();
        assert!(message(read_poses(&p).unwrap_err()).contains("extension"));

        assert!(matches!(
            read_poses(d.join("missing.json")),
            Err(Error::Io { .. })
        ));
    }

    #[test]
    fn huge_declared_shape_with_no_data_is_an_error_not_an_allocation() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("huge.npy");
        // The second shape's element count wraps to a small number in 64 bits.
        for frames in ["100000000000", "256204778801521551"] {
            let mut header =
                format!("{{'descr': '<f8', 'fortran_order': False, 'shape': ({frames}, 72), }}");
            while !(10 + header.len() + 1).is_multiple_of(64) {
                header.push(' ');
            }
            header.push('\n');
            let mut bytes = b"\x93NUMPY\x01\x00".to_vec();
            bytes.extend_from_slice(&(header.len() as u16).to_le_bytes());
            bytes.extend_from_slice(header.as_bytes());
            bytes.extend_from_slice(&[0u8; 64]);
            std::fs::write(&p, bytes).unwrap();
            let err = read_poses(&p).unwrap_err();
            assert!(matches!(err, Error::Parse { .. }), "{err}");
            assert!(
                err.to_string().contains("declares shape"),
                "{frames}: {err}"
            );
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        #[test]
        fn garbage_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..600)) {
            let dir = tempfile::tempdir().unwrap();
            for ext in ["json", "npy", "npz"] {
                let p = dir.path().join(format!("g.{ext}"));
                std::fs::write(&p, &bytes).unwrap();
                prop_assert!(read_poses(&p).is_err());
            }
            // Garbage after a valid npy magic and zip signature reaches the deeper parsers.
            let mut npy = b"\x93NUMPY\x01\x00".to_vec();
            npy.extend_from_slice(&bytes);
            let p = dir.path().join("m.npy");
            std::fs::write(&p, &npy).unwrap();
            let _ = read_poses(&p);
            let mut zip = b"PK\x03\x04".to_vec();
            zip.extend_from_slice(&bytes);
            let p = dir.path().join("m.npz");
            std::fs::write(&p, &zip).unwrap();
            let _ = read_poses(&p);
        }
    }
}
