//! The capsule table of the procedural body: proportions close to SMPL's mean neutral body in
//! the T-pose, with every capsule end placed relative to a joint so the table fits any
//! skeleton with SMPL's topology.
//!
//! Metres, y up, facing +z, left = +x. Offsets are from the named joint; right-side capsules
//! mirror the left ones (x negated, left joints swapped for right ones). Radii at the two
//! ends, in metres; "carrier" is the joint whose skinning transform moves the capsule.
//!
//! | part               | carrier   | from (joint + offset)         | to (joint + offset)          | r from | r to  |
//! |--------------------|-----------|-------------------------------|------------------------------|--------|-------|
//! | pelvis centre      | pelvis    | pelvis + (0, -.02, -.01)      | spine1                       | .105   | .095  |
//! | waist centre       | spine1    | spine1                        | spine2 + (0, 0, -.01)        | .095   | .105  |
//! | lower chest centre | spine2    | spine2 + (0, 0, -.01)         | spine3 + (0, .05, -.015)     | .105   | .11   |
//! | upper chest centre | spine3    | spine3 + (0, .05, -.015)      | neck + (0, -.02, .01)        | .11    | .06   |
//! | pelvis side ×2     | pelvis    | pelvis + (.072, -.02, -.01)   | spine1 + (.055, 0, 0)        | .105   | .09   |
//! | waist side ×2      | spine1    | spine1 + (.055, 0, 0)         | spine2 + (.06, 0, -.01)      | .09    | .097  |
//! | lower chest side ×2| spine2    | spine2 + (.06, 0, -.01)       | spine3 + (.067, .05, -.015)  | .097   | .098  |
//! | upper chest side ×2| spine3    | spine3 + (.067, .05, -.015)   | spine3 + (.06, .115, -.02)   | .098   | .075  |
//! | neck               | neck      | neck + (0, -.02, 0)           | head + (0, 0, -.01)          | .06    | .052  |
//! | head               | head      | head + (0, .05, .015)         | head + (0, .095, .005)       | .078   | .085  |
//! | shoulder ×2        | collar    | collar + (0, .01, 0)          | shoulder                     | .065   | .058  |
//! | upper arm ×2       | shoulder  | shoulder                      | elbow                        | .055   | .042  |
//! | forearm ×2         | elbow     | elbow                         | wrist                        | .042   | .032  |
//! | palm ×2            | wrist     | wrist                         | hand                         | .033   | .03   |
//! | fingers ×2         | hand      | hand                          | hand + (.08, -.005, 0)       | .025   | .015  |
//! | thigh ×2           | hip       | hip + (.005, 0, 0)            | knee                         | .09    | .058  |
//! | calf ×2            | knee      | knee                          | ankle                        | .055   | .038  |
//! | foot ×2            | ankle     | ankle + (0, -.045, -.035)     | foot + (0, .005, 0)          | .038   | .03   |
//! | toes ×2            | foot      | foot + (0, .005, 0)           | foot + (.005, -.003, .06)    | .03    | .02   |
//!
//! The three torso chains side by side give an elliptical cross-section: about 0.33 m wide
//! and 0.22 m deep at the chest, 0.29 m wide at the waist, 0.35 m at the hips.

use crate::body::capsule::Capsule;
use crate::body::skeleton::{Skeleton, mirror_joint};
use crate::math::{Real, Vec3};

const PELVIS: usize = 0;
const LEFT_HIP: usize = 1;
const SPINE1: usize = 3;
const LEFT_KNEE: usize = 4;
const SPINE2: usize = 6;
const LEFT_ANKLE: usize = 7;
const SPINE3: usize = 9;
const LEFT_FOOT: usize = 10;
const NECK: usize = 12;
const LEFT_COLLAR: usize = 13;
const HEAD: usize = 15;
const LEFT_SHOULDER: usize = 16;
const LEFT_ELBOW: usize = 18;
const LEFT_WRIST: usize = 20;
const LEFT_HAND: usize = 22;

/// One row of the table: the capsule's carrier joint, its ends as (joint, offset) and radii.
struct Row {
    carrier: usize,
    from: (usize, [Real; 3]),
    to: (usize, [Real; 3]),
    radius_from: Real,
    radius_to: Real,
    /// Whether the row describes a left part to be mirrored onto the right.
    mirrored: bool,
}

const fn row(
    carrier: usize,
    from: (usize, [Real; 3]),
    to: (usize, [Real; 3]),
    radius_from: Real,
    radius_to: Real,
    mirrored: bool,
) -> Row {
    Row {
        carrier,
        from,
        to,
        radius_from,
        radius_to,
        mirrored,
    }
}

const ZERO: [Real; 3] = [0.0, 0.0, 0.0];

/// The table above, torso first: the union is folded in this order, and big, central
/// capsules first let the bounding-sphere test skip the limbs sooner.
const ROWS: [Row; 19] = [
    row(
        PELVIS,
        (PELVIS, [0.0, -0.02, -0.01]),
        (SPINE1, ZERO),
        0.105,
        0.095,
        false,
    ),
    row(
        SPINE1,
        (SPINE1, ZERO),
        (SPINE2, [0.0, 0.0, -0.01]),
        0.095,
        0.105,
        false,
    ),
    row(
        SPINE2,
        (SPINE2, [0.0, 0.0, -0.01]),
        (SPINE3, [0.0, 0.05, -0.015]),
        0.105,
        0.11,
        false,
    ),
    row(
        SPINE3,
        (SPINE3, [0.0, 0.05, -0.015]),
        (NECK, [0.0, -0.02, 0.01]),
        0.11,
        0.06,
        false,
    ),
    row(
        PELVIS,
        (PELVIS, [0.072, -0.02, -0.01]),
        (SPINE1, [0.055, 0.0, 0.0]),
        0.105,
        0.09,
        true,
    ),
    row(
        SPINE1,
        (SPINE1, [0.055, 0.0, 0.0]),
        (SPINE2, [0.06, 0.0, -0.01]),
        0.09,
        0.097,
        true,
    ),
    row(
        SPINE2,
        (SPINE2, [0.06, 0.0, -0.01]),
        (SPINE3, [0.067, 0.05, -0.015]),
        0.097,
        0.098,
        true,
    ),
    row(
        SPINE3,
        (SPINE3, [0.067, 0.05, -0.015]),
        (SPINE3, [0.06, 0.115, -0.02]),
        0.098,
        0.075,
        true,
    ),
    row(
        NECK,
        (NECK, [0.0, -0.02, 0.0]),
        (HEAD, [0.0, 0.0, -0.01]),
        0.06,
        0.052,
        false,
    ),
    row(
        HEAD,
        (HEAD, [0.0, 0.05, 0.015]),
        (HEAD, [0.0, 0.095, 0.005]),
        0.078,
        0.085,
        false,
    ),
    row(
        LEFT_COLLAR,
        (LEFT_COLLAR, [0.0, 0.01, 0.0]),
        (LEFT_SHOULDER, ZERO),
        0.065,
        0.058,
        true,
    ),
    row(
        LEFT_SHOULDER,
        (LEFT_SHOULDER, ZERO),
        (LEFT_ELBOW, ZERO),
        0.055,
        0.042,
        true,
    ),
    row(
        LEFT_ELBOW,
        (LEFT_ELBOW, ZERO),
        (LEFT_WRIST, ZERO),
        0.042,
        0.032,
        true,
    ),
    row(
        LEFT_WRIST,
        (LEFT_WRIST, ZERO),
        (LEFT_HAND, ZERO),
        0.033,
        0.03,
        true,
    ),
    row(
        LEFT_HAND,
        (LEFT_HAND, ZERO),
        (LEFT_HAND, [0.08, -0.005, 0.0]),
        0.025,
        0.015,
        true,
    ),
    row(
        LEFT_HIP,
        (LEFT_HIP, [0.005, 0.0, 0.0]),
        (LEFT_KNEE, ZERO),
        0.09,
        0.058,
        true,
    ),
    row(
        LEFT_KNEE,
        (LEFT_KNEE, ZERO),
        (LEFT_ANKLE, ZERO),
        0.055,
        0.038,
        true,
    ),
    row(
        LEFT_ANKLE,
        (LEFT_ANKLE, [0.0, -0.045, -0.035]),
        (LEFT_FOOT, [0.0, 0.005, 0.0]),
        0.038,
        0.03,
        true,
    ),
    row(
        LEFT_FOOT,
        (LEFT_FOOT, [0.0, 0.005, 0.0]),
        (LEFT_FOOT, [0.005, -0.003, 0.06]),
        0.03,
        0.02,
        true,
    ),
];

/// The procedural body's capsules (the table in this module's docs) placed on `skeleton`'s
/// rest joints. Feed them to [`crate::CapsuleBody::new`] to build a body on a custom
/// skeleton with the neutral proportions.
#[must_use]
pub fn smpl_neutral_capsules(skeleton: &Skeleton) -> Vec<Capsule> {
    let joints = skeleton.rest_joints();
    let place = |(joint, offset): (usize, [Real; 3]), mirror: bool| {
        let [x, y, z] = offset;
        if mirror {
            joints[mirror_joint(joint)] + Vec3::new(-x, y, z)
        } else {
            joints[joint] + Vec3::new(x, y, z)
        }
    };
    let mut capsules = Vec::with_capacity(2 * ROWS.len());
    for r in &ROWS {
        let sides: &[bool] = if r.mirrored { &[false, true] } else { &[false] };
        for &mirror in sides {
            capsules.push(Capsule {
                joint: if mirror {
                    mirror_joint(r.carrier)
                } else {
                    r.carrier
                },
                a: place(r.from, mirror),
                b: place(r.to, mirror),
                radius_a: r.radius_from,
                radius_b: r.radius_to,
            });
        }
    }
    capsules
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body::skeleton::{JOINT_NAMES, PARENTS};

    #[test]
    fn mirroring_swaps_left_for_right() {
        for (j, name) in JOINT_NAMES.iter().enumerate() {
            if name.starts_with("right_") {
                continue;
            }
            let twin = JOINT_NAMES[mirror_joint(j)];
            assert_eq!(twin, name.replace("left_", "right_"), "joint {name}");
        }
    }

    #[test]
    fn capsules_ride_on_a_bone_they_touch() {
        let skeleton = Skeleton::smpl_neutral();
        let capsules = smpl_neutral_capsules(&skeleton);
        assert_eq!(capsules.len(), 32);
        for c in &capsules {
            c.validate().unwrap();
            // The carrier joint or one of its children lies within 12 cm of the capsule's
            // axis ends: no capsule floats away from the bone that moves it.
            let near = |p: Vec3| (p - c.a).norm().min((p - c.b).norm()) < 0.12;
            let joints = skeleton.rest_joints();
            let touches = near(joints[c.joint])
                || (0..joints.len()).any(|k| PARENTS[k] == Some(c.joint) && near(joints[k]));
            assert!(
                touches,
                "capsule on {} is far from its bone",
                JOINT_NAMES[c.joint]
            );
        }
    }
}
