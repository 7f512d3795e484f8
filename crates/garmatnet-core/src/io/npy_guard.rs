//! A pre-check of `.npy` headers before `npyz` parses them. The header is a Python dict
//! literal; `npyz`'s parser takes exponential time on deeply nested literals (found by
//! fuzzing: a 571-byte file with a few hundred `{` ran for minutes), so every `.npy` we read
//! must first pass this linear check, which accepts exactly the plain-array headers numpy
//! writes.

/// The largest header accepted (numpy writes about 128 bytes; the format allows 4 GiB).
pub const MAX_NPY_HEADER: usize = 64 * 1024;

/// Checks that `bytes` begin with a `.npy` preamble and a plain-array header (one dict, at
/// most one shape tuple, no lists or nesting) and returns the offset where the array data
/// starts.
///
/// ```
/// let mut file = b"\x93NUMPY\x01\x00\x46\x00".to_vec();
/// let header = "{'descr': '<f4', 'fortran_order': False, 'shape': (2, 3), }";
/// file.extend(format!("{header:<69}\n").bytes());
/// assert_eq!(garmatnet_core::npy_guard::plain_npy_header(&file), Ok(80));
/// assert!(garmatnet_core::npy_guard::plain_npy_header(b"\x93NUMPY\x01\x00\x04\x00{{{{").is_err());
/// ```
///
/// # Errors
/// A message saying what is wrong: not a `.npy` file, an unknown version, a truncated or
/// oversized header, or a header that is not a plain array's.
pub fn plain_npy_header(bytes: &[u8]) -> Result<usize, String> {
    if bytes.len() < 10 || &bytes[..6] != b"\x93NUMPY" {
        return Err("not a valid .npy file (no \\x93NUMPY magic)".into());
    }
    let (length, start) = match bytes[6] {
        1 => (usize::from(u16::from_le_bytes([bytes[8], bytes[9]])), 10),
        2 | 3 if bytes.len() >= 12 => (
            u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize,
            12,
        ),
        v => return Err(format!("unsupported .npy format version {v}")),
    };
    if length > MAX_NPY_HEADER {
        return Err(format!(
            ".npy header of {length} bytes; plain arrays need under {MAX_NPY_HEADER}"
        ));
    }
    let end = start + length;
    let header = bytes
        .get(start..end)
        .ok_or_else(|| format!("truncated .npy header ({length} bytes declared)"))?;
    let count = |c: u8| header.iter().filter(|&&b| b == c).count();
    let plain = count(b'{') == 1
        && count(b'}') == 1
        && count(b'(') <= 1
        && count(b')') <= 1
        && count(b'[') == 0
        && count(b']') == 0;
    if !plain {
        return Err(
            "the .npy header is not a plain array's (nested or structured dtype); save a \
             plain numeric array"
                .into(),
        );
    }
    Ok(end)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn npy(header: &str) -> Vec<u8> {
        let mut b = b"\x93NUMPY\x01\x00".to_vec();
        b.extend((header.len() as u16).to_le_bytes());
        b.extend(header.bytes());
        b
    }

    #[test]
    fn plain_headers_pass_and_nested_or_broken_ones_fail_fast() {
        let ok = npy("{'descr': '<f8', 'fortran_order': False, 'shape': (4, 72), }\n");
        assert_eq!(plain_npy_header(&ok), Ok(ok.len()));
        let nested = npy(&format!(
            "{{'descr': {}'<f4'{}}}",
            "{".repeat(5000),
            "}".repeat(5000)
        ));
        let started = std::time::Instant::now();
        assert!(plain_npy_header(&nested).is_err());
        assert!(started.elapsed().as_secs_f64() < 0.1);
        assert!(plain_npy_header(&npy("{'descr': [('a', '<f4')], 'shape': (1,)}")).is_err());
        assert!(plain_npy_header(b"NUMPY").is_err());
        let mut cut = ok.clone();
        cut.truncate(20);
        assert!(plain_npy_header(&cut).unwrap_err().contains("truncated"));
        let mut v9 = ok;
        v9[6] = 9;
        assert!(plain_npy_header(&v9).unwrap_err().contains("version 9"));
    }
}
