//! Left-right mirror symmetry of a drape: the permutation that pairs each template vertex
//! with its mirror twin across the body's sagittal plane `x = 0`, and how far a drape is from
//! its own mirror image.
//!
//! A left-right symmetric pose (the T-pose, both arms lowered alike) on the neutral body
//! should give a left-right symmetric drape; the mean distance between each vertex and its
//! twin's mirror image measures how far it is off.

use garmatnet_core::{Error as CoreError, Garment, Real, Vec3};

use crate::error::{Error, Result};

/// How far (metres) a vertex's mirror image may lie from its twin's rest position for the two
/// to be paired: a template built mirror-symmetric matches to rounding, far below this; an
/// asymmetric one misses by a fraction of its grid spacing (millimetres).
pub const MIRROR_TOLERANCE: Real = 1e-6;

/// The mirror image of `p` across the sagittal plane `x = 0` (y up, z forward).
#[must_use]
pub fn mirror_point(p: &Vec3) -> Vec3 {
    Vec3::new(-p.x, p.y, p.z)
}

/// The mirror permutation of a template: `twin(i)` is the vertex whose rest position is
/// vertex `i`'s mirrored across `x = 0` (vertices on the plane are their own twins).
///
/// ```
/// use garmatnet_core::Vec3;
/// use garmatnet_sim::MirrorMap;
/// let rest = [Vec3::new(-0.1, 0.0, 0.0), Vec3::new(0.0, 0.2, 0.0), Vec3::new(0.1, 0.0, 0.0)];
/// let map = MirrorMap::new(&rest)?;
/// assert_eq!(map.twin(0), 2);
/// assert_eq!(map.twin(1), 1);
/// // A drape shifted 1 cm to the left is 2 cm from its mirror image at every vertex.
/// let shifted: Vec<Vec3> = rest.iter().map(|p| p + Vec3::new(0.01, 0.0, 0.0)).collect();
/// assert!((map.asymmetry(&shifted)? - 0.02).abs() < 1e-12);
/// # Ok::<(), garmatnet_sim::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MirrorMap {
    twins: Vec<usize>,
}

impl MirrorMap {
    /// Pairs every vertex of `rest` (metres) with the one at its mirror image, within
    /// [`MIRROR_TOLERANCE`].
    ///
    /// # Errors
    /// [`Error::NotMirrorSymmetric`] naming the first vertex whose mirror image has no vertex
    /// within the tolerance (or shares its twin with another vertex), and how far the nearest
    /// one is; [`CoreError::Empty`] for an empty template.
    pub fn new(rest: &[Vec3]) -> Result<Self> {
        Self::with_tolerance(rest, MIRROR_TOLERANCE)
    }

    /// As [`MirrorMap::new`], pairing within `tolerance` metres: for a template that is
    /// mirror-symmetric in its topology but not quite in its rest positions (the procedural
    /// T-shirt on SMPL's skeleton, whose left and right joints differ by up to 6 mm), a
    /// tolerance below half the grid spacing still finds the twin.
    ///
    /// # Errors
    /// As [`MirrorMap::new`]; [`CoreError::OutOfRange`] for a tolerance that is not finite
    /// and positive.
    pub fn with_tolerance(rest: &[Vec3], tolerance: Real) -> Result<Self> {
        if !(tolerance.is_finite() && tolerance > 0.0) {
            return Err(CoreError::OutOfRange {
                what: "mirror map tolerance (metres)".into(),
                value: tolerance,
                min: Real::MIN_POSITIVE,
                max: Real::INFINITY,
                hint: format!("; the default is {MIRROR_TOLERANCE}"),
            }
            .into());
        }
        if rest.is_empty() {
            return Err(CoreError::Empty {
                what: "a mirror map".into(),
                item: "vertex",
            }
            .into());
        }
        // Sort by (y, z) so each vertex's twin, which shares them, is found by a short scan.
        let mut order: Vec<usize> = (0..rest.len()).collect();
        order.sort_by(|&a, &b| {
            (rest[a].y, rest[a].z)
                .partial_cmp(&(rest[b].y, rest[b].z))
                .unwrap_or(std::cmp::Ordering::Equal)
        });
        let mut twins = vec![usize::MAX; rest.len()];
        for i in 0..rest.len() {
            let target = mirror_point(&rest[i]);
            let start = order.partition_point(|&k| rest[k].y < target.y - tolerance);
            let mut best = (Real::INFINITY, usize::MAX);
            for &k in order[start..]
                .iter()
                .take_while(|&&k| rest[k].y <= target.y + tolerance)
            {
                let d = (rest[k] - target).norm();
                if d < best.0 {
                    best = (d, k);
                }
            }
            if best.0 > tolerance {
                // Report how far off the nearest vertex is, wherever it lies.
                let nearest = rest
                    .iter()
                    .map(|p| (p - target).norm())
                    .fold(Real::INFINITY, Real::min);
                return Err(Error::NotMirrorSymmetric {
                    vertex: i,
                    nearest_twin_m: nearest,
                });
            }
            twins[i] = best.1;
        }
        // An involution: the twin's twin is the vertex itself.
        if let Some(i) = (0..twins.len()).find(|&i| twins[twins[i]] != i) {
            return Err(Error::NotMirrorSymmetric {
                vertex: i,
                nearest_twin_m: 0.0,
            });
        }
        Ok(Self { twins })
    }

    /// The mirror map a template lists itself ([`Garment::mirror_twins`]: `twins[i]` is
    /// vertex `i`'s twin), without searching its rest positions.
    ///
    /// # Errors
    /// [`Error::NotMirrorSymmetric`] naming the first vertex whose twin is past the vertices
    /// or does not pair back; [`CoreError::Empty`] for no twins.
    pub fn from_twins(twins: &[u32]) -> Result<Self> {
        if twins.is_empty() {
            return Err(CoreError::Empty {
                what: "a mirror map".into(),
                item: "vertex",
            }
            .into());
        }
        let twins: Vec<usize> = twins.iter().map(|&t| t as usize).collect();
        if let Some(vertex) =
            (0..twins.len()).find(|&i| twins.get(twins[i]).is_none_or(|&back| back != i))
        {
            return Err(Error::NotMirrorSymmetric {
                vertex,
                nearest_twin_m: 0.0,
            });
        }
        Ok(Self { twins })
    }

    /// The mirror map of `garment`'s rest mesh.
    ///
    /// # Errors
    /// As [`MirrorMap::new`].
    pub fn of_garment(garment: &Garment) -> Result<Self> {
        Self::new(&garment.rest.vertices)
    }

    /// Vertex `i`'s mirror twin.
    ///
    /// # Panics
    /// If `i` is not a vertex of the template.
    #[must_use]
    pub fn twin(&self, i: usize) -> usize {
        self.twins[i]
    }

    /// The number of vertices.
    #[must_use]
    pub fn len(&self) -> usize {
        self.twins.len()
    }

    /// Whether the map is empty (never, for a map [`MirrorMap::new`] made).
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.twins.is_empty()
    }

    /// The mirror image of a per-vertex field (positions or displacements): vertex `i` takes
    /// `mirror(field[twin(i)])`. A drape at a pose mirrored to the field's gives this field.
    ///
    /// # Errors
    /// [`CoreError::WrongLength`] unless there is one value per template vertex.
    pub fn mirrored(&self, field: &[Vec3]) -> Result<Vec<Vec3>> {
        if field.len() != self.twins.len() {
            return Err(CoreError::WrongLength {
                what: "a per-vertex field to mirror".into(),
                expected: self.twins.len().to_string(),
                got: field.len(),
            }
            .into());
        }
        Ok(self
            .twins
            .iter()
            .map(|&t| mirror_point(&field[t]))
            .collect())
    }

    /// The mirror asymmetry of `positions` (metres): the mean over vertices of
    /// `|x_i - mirror(x_twin(i))|`. Zero for a drape that is its own mirror image; a drape
    /// shifted sideways by `s` reads `2 s`.
    ///
    /// # Errors
    /// [`CoreError::WrongLength`] unless there is one position per template vertex;
    /// [`CoreError::NonFinite`] for NaN or infinite positions.
    pub fn asymmetry(&self, positions: &[Vec3]) -> Result<Real> {
        if positions.len() != self.twins.len() {
            return Err(CoreError::WrongLength {
                what: "drape positions for the mirror asymmetry".into(),
                expected: self.twins.len().to_string(),
                got: positions.len(),
            }
            .into());
        }
        garmatnet_core::error::ensure_finite(
            "drape positions for the mirror asymmetry (metres)",
            positions.iter().flat_map(|p| [p.x, p.y, p.z]),
        )?;
        let total: Real = positions
            .iter()
            .zip(&self.twins)
            .map(|(p, &t)| (p - mirror_point(&positions[t])).norm())
            .sum();
        Ok(total / positions.len() as Real)
    }
}

/// The mirror asymmetry (metres) of `positions`, a drape of `garment`
/// ([`MirrorMap::asymmetry`] on [`MirrorMap::of_garment`]).
///
/// # Errors
/// As [`MirrorMap::new`] (a template that is not mirror-symmetric) and
/// [`MirrorMap::asymmetry`].
pub fn mirror_asymmetry(garment: &Garment, positions: &[Vec3]) -> Result<Real> {
    MirrorMap::of_garment(garment)?.asymmetry(positions)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::grid_sheet::{SheetStiffness, grid_sheet};
    use approx::assert_relative_eq;

    #[test]
    fn a_grid_centred_on_the_plane_pairs_its_columns() {
        let stiffness = SheetStiffness {
            structural_warp: 300.0,
            structural_weft: 250.0,
            shear: 30.0,
            flexion_warp: 2.0,
            flexion_weft: 2.0,
        };
        let model = grid_sheet(5, 4, 0.1, 0.2, stiffness).unwrap();
        let rest = model.rest_positions();
        let map = MirrorMap::new(rest).unwrap();
        for i in 0..map.len() {
            assert_relative_eq!(rest[map.twin(i)], mirror_point(&rest[i]), epsilon = 1e-12);
            assert_eq!(map.twin(map.twin(i)), i);
        }
        assert!(map.asymmetry(rest).unwrap() < 1e-15);
        // A symmetric mesh is its own mirror image; mirroring twice gives the field back.
        let mirrored = map.mirrored(rest).unwrap();
        for (a, b) in mirrored.iter().zip(rest) {
            assert!((a - b).norm() < 1e-12);
        }
        let field: Vec<Vec3> = (0..map.len())
            .map(|i| Vec3::new(i as Real, 1.0, 2.0))
            .collect();
        assert_eq!(map.mirrored(&map.mirrored(&field).unwrap()).unwrap(), field);
        assert!(map.mirrored(&field[1..]).is_err());
        // The twins a template lists give the same map.
        let twins: Vec<u32> = (0..map.len()).map(|i| map.twin(i) as u32).collect();
        assert_eq!(MirrorMap::from_twins(&twins).unwrap(), map);
    }

    #[test]
    fn asymmetric_templates_and_bad_positions_are_refused_by_type() {
        let rest = [Vec3::new(-0.1, 0.0, 0.0), Vec3::new(0.1005, 0.0, 0.0)];
        match MirrorMap::new(&rest) {
            Err(Error::NotMirrorSymmetric {
                vertex,
                nearest_twin_m,
            }) => {
                assert_eq!(vertex, 0);
                assert_relative_eq!(nearest_twin_m, 5e-4, epsilon = 1e-12);
            }
            other => panic!("{other:?}"),
        }
        // Two vertices on one mirror image: not a permutation.
        let crowded = [
            Vec3::new(-0.1, 0.0, 0.0),
            Vec3::new(0.1, 0.0, 0.0),
            Vec3::new(0.1, 0.0, 0.0),
        ];
        assert!(matches!(
            MirrorMap::new(&crowded),
            Err(Error::NotMirrorSymmetric { .. })
        ));
        assert!(matches!(
            MirrorMap::new(&[]),
            Err(Error::Core(CoreError::Empty { item: "vertex", .. }))
        ));
        // Listed twins that do not pair back, or point past the vertices.
        for bad in [&[1u32, 1][..], &[0, 2]] {
            assert!(matches!(
                MirrorMap::from_twins(bad),
                Err(Error::NotMirrorSymmetric { .. })
            ));
        }
        assert!(MirrorMap::from_twins(&[]).is_err());
        let map = MirrorMap::new(&[Vec3::zeros()]).unwrap();
        assert!(map.asymmetry(&[]).is_err());
        assert!(map.asymmetry(&[Vec3::new(Real::NAN, 0.0, 0.0)]).is_err());
    }
}
