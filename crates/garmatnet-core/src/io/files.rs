//! Mesh files (Wavefront OBJ in and out, PLY out) and atomic file writing.
//!
//! # Reading OBJ
//! [`read_obj`] reads positions (`v`) and polygons (`f`), fan-triangulates polygons, and
//! merges every object and group into one mesh. It keeps the file's vertex numbering:
//! vertex `k` of the file is vertex `k - 1` of the mesh, including vertices no face uses.
//! That numbering is the contract between a garment template and everything indexed by it
//! (body anchors, training labels, predictions), which is why the reader is a small
//! line-oriented parser rather than `tobj`: `tobj` renumbers vertices in order of first use,
//! drops unused ones and, as configured in this workspace, reads `f32`. The parser reports
//! the 1-based line of the first problem; the tests check it against `tobj` on the same
//! files. Texture coordinates, normals, materials, lines and points are ignored.
//!
//! # Writing
//! Every writer goes through [`write_atomic`]: the content is written to a temporary file
//! in the destination directory and renamed over the destination only once it is complete,
//! so a failure (full disk, a bug in the writer, a killed process) never leaves a partial
//! file behind, and an existing file is either replaced whole or left untouched.

use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::error::{Error, Result, ensure_finite};
use crate::math::Vec3;
use crate::mesh::TriMesh;

/// Writes a file atomically: `write` fills a temporary file in `path`'s directory, which is
/// renamed to `path` only if `write` succeeds. Output is buffered, so `write` may issue many
/// small writes. An existing file at `path` is replaced.
///
/// The rename is atomic on the same file system (hence the temporary file in the same
/// directory); the data is not `fsync`ed, so this protects against failing processes, not
/// against power loss.
///
/// ```
/// use std::io::Write;
/// let dir = tempfile::tempdir()?;
/// let path = dir.path().join("report.txt");
/// garmatnet_core::write_atomic(&path, |w| writeln!(w, "mean error: {} mm", 12.5))?;
/// assert_eq!(std::fs::read_to_string(&path)?, "mean error: 12.5 mm\n");
/// # Ok::<(), anyhow::Error>(())
/// ```
///
/// # Errors
/// [`Error::Io`] naming the directory if the temporary file cannot be created, or `path` if
/// `write` fails or the rename does. On any error nothing is left at `path` that was not
/// there before.
pub fn write_atomic(
    path: impl AsRef<Path>,
    write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<()> {
    let path = path.as_ref();
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let mut tmp = tempfile::NamedTempFile::new_in(&dir).map_err(|e| Error::io(&dir, e))?;
    {
        let mut buffered = BufWriter::new(tmp.as_file_mut());
        write(&mut buffered).map_err(|e| Error::io(path, e))?;
        buffered.flush().map_err(|e| Error::io(path, e))?;
    }
    // Temporary files are created owner-only; what we write is an ordinary artefact.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        tmp.as_file()
            .set_permissions(std::fs::Permissions::from_mode(0o644))
            .map_err(|e| Error::io(path, e))?;
    }
    tmp.as_file().sync_all().map_err(|e| Error::io(path, e))?;
    // Dropping `tmp` on the error paths above deletes the temporary file.
    tmp.persist(path).map_err(|e| Error::io(path, e.error))?;
    Ok(())
}

/// An exclusive OS file lock on `path` (created if missing), held until dropped: the guard
/// every garmatnet writer of a dataset, model, baseline or report directory holds, so a
/// second process writing the same output is refused instead of interleaving with it. The
/// operating system releases the lock when the process dies, so a killed run never leaves a
/// stale lock behind.
#[derive(Debug)]
pub struct OutputLock {
    _file: std::fs::File,
}

impl OutputLock {
    /// Takes the lock at `path`, or fails at once if another holder has it. `what` names
    /// the output in the error (e.g. `"dataset /data/shirts"`).
    ///
    /// # Errors
    /// [`Error::Io`] naming `path`, with kind `WouldBlock` and a message saying what to do
    /// when another process holds the lock; with the OS's reason when the file cannot be
    /// created (missing or unwritable directory).
    pub fn acquire(path: impl AsRef<Path>, what: &str) -> Result<Self> {
        let path = path.as_ref();
        let file = std::fs::File::create(path).map_err(|e| Error::io(path, e))?;
        match file.try_lock() {
            Ok(()) => Ok(Self { _file: file }),
            Err(std::fs::TryLockError::WouldBlock) => Err(Error::io(
                path,
                std::io::Error::new(
                    std::io::ErrorKind::WouldBlock,
                    format!(
                        "another garmatnet process is writing the {what}; wait for it to \
                         finish or write somewhere else"
                    ),
                ),
            )),
            Err(std::fs::TryLockError::Error(e)) => Err(Error::io(path, e)),
        }
    }
}

/// Writes `bytes` to `path` atomically (see [`write_atomic`]).
///
/// # Errors
/// [`Error::Io`] naming `path` if any step fails.
pub fn write_bytes_atomic(path: impl AsRef<Path>, bytes: &[u8]) -> Result<()> {
    write_atomic(path, |w| w.write_all(bytes))
}

/// Reads a Wavefront OBJ file as one triangle mesh (see the module docs for what is kept).
///
/// # Errors
/// [`Error::Io`] if the file cannot be read; [`Error::Parse`] naming the line of a malformed
/// vertex (fewer than 3 coordinates, a non-number, NaN or infinity) or face (fewer than 3
/// corners, an index that is 0, not an integer or not a vertex defined above it, or a
/// repeated vertex), or with no line if the file has no faces.
pub fn read_obj(path: impl AsRef<Path>) -> Result<TriMesh> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    parse_obj(&String::from_utf8_lossy(&bytes), path)
}

/// Parses OBJ `text`; `path` only names the source in errors.
fn parse_obj(text: &str, path: &Path) -> Result<TriMesh> {
    let at = |line: usize, message: String| Error::Parse {
        path: path.to_path_buf(),
        line: Some(line),
        message,
    };
    let mut vertices: Vec<Vec3> = Vec::new();
    let mut faces: Vec<[u32; 3]> = Vec::new();
    let mut corners: Vec<u32> = Vec::new();
    for (k, raw) in text.lines().enumerate() {
        let line = k + 1;
        let content = raw.split('#').next().unwrap_or("");
        let mut words = content.split_whitespace();
        match words.next() {
            Some("v") => {
                let mut values = [0.0; 7];
                let mut count = 0;
                for word in words {
                    let value: f64 = word.parse().map_err(|_| {
                        at(line, format!("vertex coordinate `{word}` is not a number"))
                    })?;
                    if !value.is_finite() {
                        return Err(at(
                            line,
                            format!("vertex coordinate `{word}` is not finite; use finite metres"),
                        ));
                    }
                    if count < values.len() {
                        values[count] = value;
                    }
                    count += 1;
                }
                // x y z, optionally followed by a homogeneous w or by an r g b colour.
                let w = match count {
                    3 | 6 | 7 => 1.0,
                    4 if values[3] != 0.0 => values[3],
                    4 => return Err(at(line, "vertex weight w is 0".to_owned())),
                    _ => {
                        return Err(at(
                            line,
                            format!(
                                "a vertex needs `v x y z` (optionally w, or r g b), \
                                 found {count} numbers"
                            ),
                        ));
                    }
                };
                vertices.push(Vec3::new(values[0] / w, values[1] / w, values[2] / w));
            }
            Some("f") => {
                corners.clear();
                for word in words {
                    corners.push(parse_corner(word, vertices.len()).map_err(|m| at(line, m))?);
                }
                if corners.len() < 3 {
                    return Err(at(
                        line,
                        format!("a face needs at least 3 vertices, found {}", corners.len()),
                    ));
                }
                // A fan from the first corner, as tobj and most tools triangulate; exact for
                // convex polygons, which is what exporters write.
                for k in 1..corners.len() - 1 {
                    let tri = [corners[0], corners[k], corners[k + 1]];
                    if tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2] {
                        return Err(at(
                            line,
                            format!("the face uses a vertex twice (vertices {corners:?}, 0-based)"),
                        ));
                    }
                    faces.push(tri);
                }
            }
            _ => {}
        }
    }
    if faces.is_empty() {
        return Err(Error::Parse {
            path: path.to_path_buf(),
            line: None,
            message: format!(
                "no faces (`f` lines) among {} vertices; a mesh needs at least one triangle",
                vertices.len()
            ),
        });
    }
    // Everything TriMesh::new checks was checked above with line numbers; this cannot fail
    // short of a parser bug, which the error would still report rather than panic on.
    TriMesh::new(vertices, faces)
}

/// Resolves one face corner (`v`, `v/vt`, `v//vn` or `v/vt/vn`) to a 0-based vertex index,
/// given the number of vertices defined so far. The message says what is wrong.
fn parse_corner(word: &str, defined: usize) -> std::result::Result<u32, String> {
    let mut parts = word.split('/');
    let v = parts.next().unwrap_or("");
    let index: i64 = v
        .parse()
        .map_err(|_| format!("face corner `{word}` does not start with an integer vertex index"))?;
    if parts.any(|p| !p.is_empty() && p.parse::<i64>().is_err()) {
        return Err(format!(
            "face corner `{word}` has a non-integer texture or normal index"
        ));
    }
    let resolved = match index {
        0 => {
            return Err(format!(
                "face corner `{word}`: OBJ indices start at 1, not 0"
            ));
        }
        i if i > 0 => i - 1,
        i => defined as i64 + i,
    };
    if resolved < 0 || resolved >= defined as i64 {
        return Err(format!(
            "face corner `{word}` refers to a vertex that is not defined above it \
             (only {defined} vertices so far)"
        ));
    }
    u32::try_from(resolved).map_err(|_| format!("vertex index {index} exceeds 2^32"))
}

/// Checks a mesh before writing it (its fields are public, so it may have changed since
/// [`TriMesh::new`] checked it).
fn check_writable(mesh: &TriMesh) -> Result<()> {
    ensure_finite(
        "mesh vertex coordinates",
        mesh.vertices.iter().flat_map(|v| [v.x, v.y, v.z]),
    )?;
    let n = mesh.vertices.len();
    if let Some((f, face)) = mesh
        .faces
        .iter()
        .enumerate()
        .find(|(_, f)| f.iter().any(|&i| i as usize >= n))
    {
        return Err(Error::InvalidMesh(format!(
            "face {f} ({face:?}) indexes past the {n} vertices"
        )));
    }
    Ok(())
}

/// Writes `mesh` as a Wavefront OBJ file (positions and triangles), atomically. Coordinates
/// are written in the shortest form that reads back to the same `f64`, so [`read_obj`]
/// returns an identical mesh.
///
/// # Errors
/// [`Error::NonFinite`] or [`Error::InvalidMesh`] if the mesh has been corrupted since it
/// was built; [`Error::Io`] if the file cannot be written.
pub fn write_obj(path: impl AsRef<Path>, mesh: &TriMesh) -> Result<()> {
    check_writable(mesh)?;
    write_atomic(path, |w| {
        writeln!(
            w,
            "# garmatnet: {} vertices, {} triangles",
            mesh.vertex_count(),
            mesh.face_count()
        )?;
        for v in &mesh.vertices {
            writeln!(w, "v {} {} {}", v.x, v.y, v.z)?;
        }
        for [a, b, c] in &mesh.faces {
            writeln!(w, "f {} {} {}", a + 1, b + 1, c + 1)?;
        }
        Ok(())
    })
}

/// Writes `mesh` as a binary little-endian PLY file for viewers (MeshLab, Blender),
/// atomically: single-precision positions (metres), optionally one RGB colour per vertex,
/// and triangles.
///
/// # Shapes
/// `colors`: `[vertex_count]` when given.
///
/// # Errors
/// [`Error::Mismatch`] if `colors` does not have one entry per vertex; [`Error::NonFinite`]
/// or [`Error::InvalidMesh`] for a corrupted mesh; [`Error::Io`] if the file cannot be
/// written.
pub fn write_ply(path: impl AsRef<Path>, mesh: &TriMesh, colors: Option<&[[u8; 3]]>) -> Result<()> {
    check_writable(mesh)?;
    if let Some(c) = colors
        && c.len() != mesh.vertex_count()
    {
        return Err(Error::Mismatch {
            what: "PLY vertex colours (one RGB triple per vertex)".to_owned(),
            expected: format!("{} colours", mesh.vertex_count()),
            got: format!("{} colours", c.len()),
        });
    }
    write_atomic(path, |w| {
        write!(
            w,
            "ply\nformat binary_little_endian 1.0\ncomment garmatnet mesh (metres)\n\
             element vertex {}\nproperty float x\nproperty float y\nproperty float z\n",
            mesh.vertex_count()
        )?;
        if colors.is_some() {
            write!(
                w,
                "property uchar red\nproperty uchar green\nproperty uchar blue\n"
            )?;
        }
        write!(
            w,
            "element face {}\nproperty list uchar int vertex_indices\nend_header\n",
            mesh.face_count()
        )?;
        for (i, v) in mesh.vertices.iter().enumerate() {
            for x in [v.x, v.y, v.z] {
                // Narrowing to f32 is the point: PLY here is for viewing.
                w.write_all(&(x as f32).to_le_bytes())?;
            }
            if let Some(c) = colors {
                w.write_all(&c[i])?;
            }
        }
        for face in &mesh.faces {
            w.write_all(&[3u8])?;
            for &i in face {
                // Indices are < vertex_count, which PLY's int must hold.
                let i = i32::try_from(i).map_err(std::io::Error::other)?;
                w.write_all(&i.to_le_bytes())?;
            }
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::SplitMix64;

    #[test]
    fn an_output_lock_excludes_a_second_holder_until_dropped() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(".lock");
        let first = OutputLock::acquire(&path, "test output").unwrap();
        let err = OutputLock::acquire(&path, "test output").unwrap_err();
        assert!(
            err.to_string()
                .contains("another garmatnet process is writing the test output"),
            "{err}"
        );
        drop(first);
        OutputLock::acquire(&path, "test output").unwrap();
        let missing = OutputLock::acquire(dir.path().join("no/such/.lock"), "x").unwrap_err();
        assert!(missing.to_string().contains("no/such"), "{missing}");
    }

    #[cfg(unix)]
    #[test]
    fn written_files_are_readable_by_others_like_any_artefact() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.txt");
        write_bytes_atomic(&path, b"x").unwrap();
        let mode = std::fs::metadata(&path).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o644);
    }

    #[test]
    fn a_failing_writer_such_as_a_full_disk_leaves_no_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.bin");
        let err = write_atomic(&path, |w| {
            w.write_all(&[0; 10_000])?;
            Err(std::io::Error::from(std::io::ErrorKind::StorageFull))
        })
        .unwrap_err();
        assert!(err.to_string().contains("out.bin"), "{err}");
        let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert!(left.is_empty(), "left behind: {left:?}");
    }

    #[test]
    fn writing_to_a_full_device_is_an_error_naming_the_file() {
        // /dev/full answers every write with ENOSPC, as a full disk does.
        let full = Path::new("/dev/full");
        if !full.exists() {
            return;
        }
        let err = std::fs::write(full, [0u8; 64]).unwrap_err();
        assert_eq!(err.raw_os_error(), Some(28), "ENOSPC");
        let mapped = Error::io(full, err);
        assert!(mapped.to_string().contains("/dev/full"), "{mapped}");
    }

    fn parse(text: &str) -> Result<TriMesh> {
        parse_obj(text, Path::new("test.obj"))
    }

    fn parse_error_line(text: &str) -> (Option<usize>, String) {
        match parse(text) {
            Err(e @ Error::Parse { line, .. }) => (line, e.to_string()),
            other => panic!("expected a parse error for {text:?}, got {other:?}"),
        }
    }

    #[test]
    fn obj_round_trip_is_exact() {
        let dir = tempfile::tempdir().unwrap();
        let mut mesh = crate::mesh::tests::grid(4, 3, 0.1);
        let mut rng = SplitMix64::new(11);
        for v in &mut mesh.vertices {
            *v += Vec3::new(rng.normal(), rng.normal(), rng.normal()) * 1e-3;
        }
        // Faces that first use a high vertex, and an unused vertex, must not renumber.
        mesh.faces.reverse();
        mesh.vertices.push(Vec3::new(9.0, 9.0, 9.0));
        let path = dir.path().join("m.obj");
        write_obj(&path, &mesh).unwrap();
        assert_eq!(read_obj(&path).unwrap(), mesh);
    }

    #[test]
    fn polygons_are_fan_triangulated_and_objects_merged() {
        let text = "# two objects\no quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1/1 2/2 3/3 4/4\n\
                    o pentagon\nv 2 0 0\nv 3 0 0\nv 3.5 1 0\nv 2.5 2 0\nv 2 1 0\n\
                    f -5//1 -4//1 -3//1 -2//1 -1//1\n";
        let m = parse(text).unwrap();
        assert_eq!(m.vertex_count(), 9);
        assert_eq!(
            m.faces,
            vec![[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7], [4, 7, 8]]
        );
        // The same file through tobj: the same triangles, by position.
        let (models, _) = tobj::load_obj_buf(
            &mut std::io::Cursor::new(text),
            &tobj::LoadOptions {
                triangulate: true,
                ..Default::default()
            },
            |_| Err(tobj::LoadError::OpenFileFailed),
        )
        .unwrap();
        let mut theirs = Vec::new();
        for model in &models {
            let p = &model.mesh.positions;
            for tri in model.mesh.indices.chunks_exact(3) {
                let tri: [u32; 3] = tri.try_into().unwrap();
                theirs.push(tri.map(|i| {
                    let i = i as usize * 3;
                    [p[i], p[i + 1], p[i + 2]].map(f64::from)
                }));
            }
        }
        assert_eq!(m.face_count(), theirs.len());
        for (face, their) in m.faces.iter().zip(&theirs) {
            for (&i, p) in face.iter().zip(their) {
                let v = m.vertices[i as usize];
                assert!(
                    (v - Vec3::new(p[0], p[1], p[2])).amax() < 1e-6,
                    "{v} vs {p:?}"
                );
            }
        }
    }

    #[test]
    fn malformed_files_name_the_line() {
        let cases: [(&str, usize, &str); 8] = [
            ("v 0 0 0\nv 1 x 0\n", 2, "not a number"),
            ("v 0 0 0\n\nv 1 nan 0\n", 3, "not finite"),
            ("v 0 0\n", 1, "found 2 numbers"),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", 4, "not defined"),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 -4 2\n", 4, "not defined"),
            ("v 0 0 0\nv 1 0 0\nf 1 2\n", 3, "at least 3"),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", 4, "start at 1"),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/a 2 3\n", 4, "non-integer"),
        ];
        for (text, line, needle) in cases {
            let (got, message) = parse_error_line(text);
            assert_eq!(got, Some(line), "{message}");
            assert!(
                message.contains(needle) && message.contains(&format!("line {line}")),
                "{message}"
            );
        }
        let (line, message) = parse_error_line("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 2\n");
        assert_eq!(line, Some(4), "{message}");
        let (line, message) = parse_error_line("");
        assert_eq!(line, None);
        assert!(message.contains("no faces"), "{message}");
    }

    #[test]
    fn missing_file_is_an_io_error() {
        let dir = tempfile::tempdir().unwrap();
        let err = read_obj(dir.path().join("absent.obj")).unwrap_err();
        assert!(
            matches!(err, Error::Io { .. }) && err.to_string().contains("absent.obj"),
            "{err}"
        );
    }

    #[test]
    fn failing_writer_leaves_no_file_and_keeps_the_old_one() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.bin");
        let fail = |w: &mut dyn Write| {
            w.write_all(&[7u8; 100_000])?;
            Err(std::io::Error::other("simulated failure"))
        };
        let err = write_atomic(&path, fail).unwrap_err();
        assert!(matches!(err, Error::Io { .. }), "{err}");
        assert_eq!(
            std::fs::read_dir(dir.path()).unwrap().count(),
            0,
            "no file, no temporary"
        );
        write_atomic(&path, |w| w.write_all(b"old")).unwrap();
        write_atomic(&path, fail).unwrap_err();
        assert_eq!(std::fs::read(&path).unwrap(), b"old");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn ply_layout_and_colour_checks() {
        let dir = tempfile::tempdir().unwrap();
        let mesh = crate::mesh::tests::grid(2, 1, 0.5);
        let path = dir.path().join("m.ply");
        let few = vec![[255u8, 0, 0]; 2];
        let err = write_ply(&path, &mesh, Some(&few)).unwrap_err();
        assert!(matches!(err, Error::Mismatch { .. }), "{err}");
        assert!(!path.exists());
        let colors: Vec<[u8; 3]> = (0..mesh.vertex_count()).map(|i| [i as u8, 1, 2]).collect();
        write_ply(&path, &mesh, Some(&colors)).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let end = b"end_header\n";
        let body = bytes.windows(end.len()).position(|w| w == end).unwrap() + end.len();
        let header = std::str::from_utf8(&bytes[..body]).unwrap();
        assert!(header.contains("element vertex 6\n") && header.contains("element face 4\n"));
        assert_eq!(bytes.len() - body, 6 * (12 + 3) + 4 * (1 + 12));
        // Vertex 1 is (0.5, 0, 0) with colour (1, 1, 2).
        let v1 = &bytes[body + 15..body + 30];
        assert_eq!(f32::from_le_bytes(v1[0..4].try_into().unwrap()), 0.5);
        assert_eq!(&v1[12..15], &[1, 1, 2]);
        let faces = &bytes[body + 6 * 15..];
        assert_eq!(faces[0], 3);
        assert_eq!(i32::from_le_bytes(faces[5..9].try_into().unwrap()), 1);
        write_ply(dir.path().join("plain.ply"), &mesh, None).unwrap();
    }
}
