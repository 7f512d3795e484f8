//! The fabrics a model was trained on: their box of normalised materials and how far a
//! material lies outside it, and the fabrics themselves and which lies nearest a material.
//!
//! A network answers for any ω in `[0, 1]^6`, but it has only learned the fabrics it was
//! trained on. Outside their range it extrapolates, and an MLP extrapolates poorly: on the
//! frictional 30 × 200 dataset, Trim Fusible Rigid (outside the 26 training fabrics in 5 of
//! 6 components) erred by 48.9 mm where the three targets inside the range erred by about 10
//! (book/src/experiments/frictional-ground-truth.md). [`MaterialRange`] records the training
//! box so that callers can tell when a prediction is an extrapolation.
//!
//! Inside the box a fabric can still lie far from every training fabric, and there the error
//! can grow with that distance: on revision 2's walks, Table 2's four targets erred 8.2 mm at
//! 0.07 from the nearest training fabric and 16–21 mm at 0.33–0.46
//! (book/src/experiments/r2-shipped-model.md). On revision 3's independent poses the error is
//! flat in that distance up to 0.40 and grows beyond it (book/src/results.md).
//! [`TrainingFabric`] records the fabrics themselves and [`nearest`] finds the nearest.
//!
//! ```
//! use garmatnet_model::MaterialRange;
//!
//! let range = MaterialRange::of([[0.2, 0.3, 0.1, 0.1, 0.4, 0.5], [0.6, 0.5, 0.3, 0.2, 0.5, 0.6]])
//!     .expect("two materials");
//! assert!(range.outside(&[0.4, 0.4, 0.2, 0.15, 0.45, 0.55]).is_empty());
//! let out = range.outside(&[0.4, 0.4, 0.9, 0.15, 0.45, 0.55]);
//! assert_eq!(out.len(), 1);
//! assert_eq!(out[0].component, 2);
//! assert!((out[0].excess() - 0.6).abs() < 1e-12);
//! ```

use std::fmt;

use garmatnet_core::{COMPONENT_NAMES, Real};
use serde::{Deserialize, Serialize};

use crate::net::garmatnet_net::MATERIAL_DIM;

/// Distance in normalised ω from the nearest training fabric at and beyond which a fabric is
/// far from what a model learned. Measured on the revision-2 30 × 200 dataset (one walk per
/// fabric) over 42 (fabric, model) pairs — fabrics held out of models trained on 13, 26 or
/// 52 fabrics (book/src/api.md) — the error over all poses of a fabric nearer than this
/// averaged 8.7 mm (31 pairs), and 17.4 mm at or beyond it (11 pairs, none below 10.2). On
/// revision 3's independent poses the error is flat in the distance up to 0.40
/// (book/src/results.md).
pub const FAR_FROM_TRAINING: Real = 0.3;

/// A fabric a model was trained on: its name and normalised ω.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrainingFabric {
    /// The fabric's name in the training dataset (a preset's name, or a random fabric's).
    pub name: String,
    /// Its normalised ω, the nets' material input.
    pub omega: [Real; MATERIAL_DIM],
}

/// The candidate nearest to `target` in normalised ω (Euclidean distance), with that distance:
/// the first candidate on a tie, `None` without candidates.
///
/// ```
/// use garmatnet_model::material_range::nearest;
///
/// let candidates = [("a", [0.0; 6]), ("b", [0.5, 0.5, 0.5, 0.5, 0.5, 0.4])];
/// let (name, distance) = nearest(&[0.5; 6], candidates).expect("two candidates");
/// assert_eq!(name, "b");
/// assert!((distance - 0.1).abs() < 1e-12);
/// ```
pub fn nearest<T>(
    target: &[Real; MATERIAL_DIM],
    candidates: impl IntoIterator<Item = (T, [Real; MATERIAL_DIM])>,
) -> Option<(T, Real)> {
    let squared = |w: &[Real; MATERIAL_DIM]| {
        w.iter()
            .zip(target)
            .map(|(a, b)| (a - b) * (a - b))
            .sum::<Real>()
    };
    candidates
        .into_iter()
        .map(|(c, w)| (c, squared(&w)))
        .fold(None, |best: Option<(T, Real)>, (c, d)| match best {
            Some((_, bd)) if bd <= d => best,
            _ => Some((c, d)),
        })
        .map(|(c, d)| (c, d.sqrt()))
}

/// The per-component minimum and maximum of normalised ω over a model's training samples.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MaterialRange {
    /// Smallest normalised value of each component.
    pub min: [Real; MATERIAL_DIM],
    /// Largest normalised value of each component.
    pub max: [Real; MATERIAL_DIM],
}

/// One component of a material outside a [`MaterialRange`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct OutsideComponent {
    /// Component index (0 structural vertical … 5 density).
    pub component: usize,
    /// The material's normalised value.
    pub value: Real,
    /// The range's smallest value of that component.
    pub min: Real,
    /// The range's largest value of that component.
    pub max: Real,
}

impl OutsideComponent {
    /// How far outside the range the value lies (normalised units, > 0).
    #[must_use]
    pub fn excess(&self) -> Real {
        (self.min - self.value).max(self.value - self.max)
    }
}

impl fmt::Display for OutsideComponent {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let side = if self.value > self.max {
            "above"
        } else {
            "below"
        };
        write!(
            f,
            "{} {:.3} is {:.3} {side} the trained {:.3}..{:.3}",
            COMPONENT_NAMES[self.component],
            self.value,
            self.excess(),
            self.min,
            self.max
        )
    }
}

impl MaterialRange {
    /// The range of `materials` (normalised ω), or `None` when there are none or any value is
    /// not finite.
    pub fn of(materials: impl IntoIterator<Item = [Real; MATERIAL_DIM]>) -> Option<Self> {
        let mut range: Option<Self> = None;
        for m in materials {
            if !m.iter().all(|v| v.is_finite()) {
                return None;
            }
            let r = range.get_or_insert(Self { min: m, max: m });
            for (i, v) in m.into_iter().enumerate() {
                r.min[i] = r.min[i].min(v);
                r.max[i] = r.max[i].max(v);
            }
        }
        range
    }

    /// The components of `material` (normalised ω) outside the range, in component order;
    /// empty when it lies inside.
    #[must_use]
    pub fn outside(&self, material: &[Real; MATERIAL_DIM]) -> Vec<OutsideComponent> {
        (0..MATERIAL_DIM)
            .filter(|&i| !(self.min[i]..=self.max[i]).contains(&material[i]))
            .map(|i| OutsideComponent {
                component: i,
                value: material[i],
                min: self.min[i],
                max: self.max[i],
            })
            .collect()
    }

    /// The largest [`OutsideComponent::excess`] of `material`; 0 inside the range.
    #[must_use]
    pub fn largest_excess(&self, material: &[Real; MATERIAL_DIM]) -> Real {
        self.outside(material)
            .iter()
            .map(OutsideComponent::excess)
            .fold(0.0, Real::max)
    }

    /// Whether the range is usable: finite bounds with `min <= max` in every component.
    #[must_use]
    pub fn is_valid(&self) -> bool {
        (0..MATERIAL_DIM).all(|i| {
            self.min[i].is_finite() && self.max[i].is_finite() && self.min[i] <= self.max[i]
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn range_of_materials_and_what_lies_outside() {
        let a = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6];
        let b = [0.3, 0.1, 0.5, 0.4, 0.2, 0.7];
        let r = MaterialRange::of([a, b]).unwrap();
        assert_eq!(r.min, [0.1, 0.1, 0.3, 0.4, 0.2, 0.6]);
        assert_eq!(r.max, [0.3, 0.2, 0.5, 0.4, 0.5, 0.7]);
        assert!(r.is_valid());
        // Every training material, and the box's corners, lie inside.
        for m in [a, b, r.min, r.max] {
            assert!(r.outside(&m).is_empty(), "{m:?}");
            assert_eq!(r.largest_excess(&m), 0.0);
        }
        let out = r.outside(&[0.05, 0.15, 0.9, 0.4, 0.3, 0.65]);
        assert_eq!(
            out.iter().map(|o| o.component).collect::<Vec<_>>(),
            vec![0, 2]
        );
        assert!((out[0].excess() - 0.05).abs() < 1e-12);
        assert!((out[1].excess() - 0.4).abs() < 1e-12);
        let text = out[1].to_string();
        assert!(
            text.contains(COMPONENT_NAMES[2]) && text.contains("0.400 above"),
            "{text}"
        );
        assert!(out[0].to_string().contains("below"));
        assert!((r.largest_excess(&[0.05, 0.15, 0.9, 0.4, 0.3, 0.65]) - 0.4).abs() < 1e-12);
    }

    #[test]
    fn the_nearest_candidate_is_the_closest_and_the_first_on_a_tie() {
        let target = [0.5; MATERIAL_DIM];
        let at = |x: Real| {
            let mut w = [0.5; MATERIAL_DIM];
            w[2] = x;
            w
        };
        let candidates = [(7, at(0.9)), (3, at(0.6)), (9, at(0.4)), (1, at(0.45))];
        let (which, distance) = nearest(&target, candidates).unwrap();
        assert_eq!(which, 1);
        assert!((distance - 0.05).abs() < 1e-12);
        let tie = [(4, at(0.75)), (2, at(0.25))];
        assert_eq!(nearest(&target, tie).map(|(c, _)| c), Some(4));
        assert_eq!(nearest(&target, [(5, target)]), Some((5, 0.0)));
        assert_eq!(nearest(&target, std::iter::empty::<(usize, _)>()), None);
    }

    #[test]
    fn no_materials_or_non_finite_give_no_range() {
        assert!(MaterialRange::of(std::iter::empty()).is_none());
        assert!(MaterialRange::of([[0.5, 0.5, Real::NAN, 0.5, 0.5, 0.5]]).is_none());
        let bad = MaterialRange {
            min: [0.5; MATERIAL_DIM],
            max: [0.4; MATERIAL_DIM],
        };
        assert!(!bad.is_valid());
    }
}
