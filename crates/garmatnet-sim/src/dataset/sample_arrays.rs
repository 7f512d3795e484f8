//! The three per-sample point arrays and their `.npy` (float32, `[n, 3]`) files.

use std::path::Path;

use garmatnet_core::{Error, Result, Vec3};
use npyz::{DType, NpyFile, Order, TypeChar, WriterBuilder};

/// One sample's arrays, in metres, world frame of the posed body.
///
/// # Shapes
/// `simulated`, `smoothed`: `[vertex_count, 3]`; `body`: `[m, 3]` with `m ≥ 1`.
#[derive(Debug, Clone, PartialEq)]
pub struct SampleArrays {
    /// The solver's draped garment vertices.
    pub simulated: Vec<[f32; 3]>,
    /// The Laplacian-smoothed garment vertices (the coarse target).
    pub smoothed: Vec<[f32; 3]>,
    /// Points of the posed body the garment is expressed against (e.g. each garment vertex's
    /// body anchor, or the body's vertices).
    pub body: Vec<[f32; 3]>,
}

/// The array files of a sample directory, in the order they are written.
pub const ARRAY_NAMES: [&str; 3] = ["simulated", "smoothed", "body"];

impl SampleArrays {
    /// The arrays in [`ARRAY_NAMES`] order.
    #[must_use]
    pub fn by_name(&self) -> [(&'static str, &[[f32; 3]]); 3] {
        [
            ("simulated", &self.simulated),
            ("smoothed", &self.smoothed),
            ("body", &self.body),
        ]
    }

    /// Checks shapes and finiteness, naming `sample` in errors.
    ///
    /// # Errors
    /// [`Error::Mismatch`] if a garment array does not have `vertex_count` rows or the body
    /// array is empty; [`Error::NonFinite`] for NaN or infinity.
    pub fn validate(&self, sample: &str, vertex_count: usize) -> Result<()> {
        for (name, points) in self.by_name() {
            let ok = if name == "body" {
                !points.is_empty()
            } else {
                points.len() == vertex_count
            };
            if !ok {
                return Err(Error::Mismatch {
                    what: format!("sample {sample} {name} rows"),
                    expected: if name == "body" {
                        "at least 1".into()
                    } else {
                        vertex_count.to_string()
                    },
                    got: points.len().to_string(),
                });
            }
            let flat = points.as_flattened();
            if let Some(index) = flat.iter().position(|v| !v.is_finite()) {
                return Err(Error::NonFinite {
                    what: format!("sample {sample} {name}"),
                    index,
                });
            }
        }
        Ok(())
    }
}

/// Writes `points` as a float32 `[n, 3]` `.npy`, atomically.
///
/// # Errors
/// [`Error::Io`] naming `path`.
pub fn write_points_npy(path: &Path, points: &[[f32; 3]]) -> Result<()> {
    let mut bytes = Vec::with_capacity(128 + points.len() * 12);
    let io = |e| Error::io(path, e);
    let mut w = npyz::WriteOptions::<f32>::new()
        .default_dtype()
        .shape(&[points.len() as u64, 3])
        .writer(&mut bytes)
        .begin_nd()
        .map_err(io)?;
    w.extend(points.as_flattened().iter().copied())
        .map_err(io)?;
    w.finish().map_err(io)?;
    garmatnet_core::write_bytes_atomic(path, &bytes)
}

/// The simulated garment of the sample in `sample_dir` (its `simulated.npy`) as solver
/// positions: what a resumed sequence starts from and what derived arrays are computed from.
///
/// # Errors
/// As [`read_points_npy`].
pub(crate) fn read_simulated(sample_dir: &Path, sample: &str) -> Result<Vec<Vec3>> {
    let points = read_points_npy(&sample_dir.join("simulated.npy"), sample)?;
    Ok(solver_positions(&points))
}

/// Stored float32 points as solver positions (f64).
pub(crate) fn solver_positions(points: &[[f32; 3]]) -> Vec<Vec3> {
    points
        .iter()
        .map(|p| Vec3::new(p[0].into(), p[1].into(), p[2].into()))
        .collect()
}

/// Reads a float32 `[n, 3]` `.npy` (C order), naming `sample` in errors. Finiteness is not
/// checked here: callers decide whether NaN is an error or a statistic.
///
/// # Errors
/// [`Error::Io`] if the file cannot be opened; [`Error::Parse`] naming the file and sample
/// for a malformed file, a dtype other than float32, a shape other than `[n, 3]` (`n ≥ 1`),
/// Fortran order or truncated data.
pub fn read_points_npy(path: &Path, sample: &str) -> Result<Vec<[f32; 3]>> {
    let parse = |message: String| Error::Parse {
        path: path.to_owned(),
        line: None,
        message: format!("sample {sample}: {message}"),
    };
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let data_start = garmatnet_core::npy_guard::plain_npy_header(&bytes).map_err(parse)?;
    let npy = NpyFile::new(&bytes[..]).map_err(|e| parse(format!("not a valid .npy file: {e}")))?;
    let shape = npy.shape().to_vec();
    let rows = match shape[..] {
        [n, 3] if n >= 1 => n,
        _ => {
            return Err(parse(format!(
                "array has shape {shape:?}; expected [n, 3] with n >= 1"
            )));
        }
    };
    let is_f32 = matches!(npy.dtype(), DType::Plain(ts) if ts.type_char() == TypeChar::Float && ts.size_field() == 4);
    if !is_f32 {
        return Err(parse(format!(
            "array has dtype {:?}; expected float32",
            npy.dtype()
        )));
    }
    if npy.order() != Order::C {
        return Err(parse("array is in Fortran order; expected C order".into()));
    }
    // Refuse a declared shape the file cannot hold before allocating for it.
    if rows.saturating_mul(12) > (bytes.len() - data_start) as u64 {
        return Err(parse(format!(
            "array data is truncated: shape [{rows}, 3] needs {} bytes, the file has {}",
            rows.saturating_mul(12),
            bytes.len() - data_start
        )));
    }
    let flat = npy
        .into_vec::<f32>()
        .map_err(|e| parse(format!("cannot read data: {e}")))?;
    if flat.len() as u64 != rows * 3 {
        return Err(parse("array data is truncated".into()));
    }
    Ok(flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn npy_round_trip_and_typed_errors() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.npy");
        let pts = vec![[1.0f32, -2.0, 3.5], [0.25, 0.0, -1e-3]];
        write_points_npy(&p, &pts).unwrap();
        assert_eq!(read_points_npy(&p, "m000_p0000").unwrap(), pts);

        std::fs::write(&p, b"\x93NUMPY garbage").unwrap();
        let e = read_points_npy(&p, "m001_p0002").unwrap_err();
        assert!(
            matches!(&e, Error::Parse { .. }) && e.to_string().contains("m001_p0002"),
            "{e}"
        );

        let mut full = Vec::new();
        let mut w = npyz::WriteOptions::<f32>::new()
            .default_dtype()
            .shape(&[2, 2])
            .writer(&mut full)
            .begin_nd()
            .unwrap();
        w.extend([0.0f32; 4]).unwrap();
        w.finish().unwrap();
        std::fs::write(&p, &full).unwrap();
        assert!(
            read_points_npy(&p, "s")
                .unwrap_err()
                .to_string()
                .contains("[2, 2]")
        );

        write_points_npy(&p, &pts).unwrap();
        let mut truncated = std::fs::read(&p).unwrap();
        truncated.truncate(truncated.len() - 4);
        std::fs::write(&p, &truncated).unwrap();
        assert!(matches!(read_points_npy(&p, "s"), Err(Error::Parse { .. })));
    }

    #[test]
    fn validate_names_the_sample() {
        let a = SampleArrays {
            simulated: vec![[0.0; 3]; 4],
            smoothed: vec![[0.0; 3]; 4],
            body: vec![[0.0; 3]; 2],
        };
        a.validate("m000_p0000", 4).unwrap();
        let e = a.validate("m000_p0000", 5).unwrap_err();
        assert!(matches!(e, Error::Mismatch { .. }) && e.to_string().contains("m000_p0000"));
        let mut nan = a.clone();
        nan.smoothed[1][2] = f32::NAN;
        assert!(matches!(
            nan.validate("x", 4),
            Err(Error::NonFinite { index: 5, .. })
        ));
    }
}
