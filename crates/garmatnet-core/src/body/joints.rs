//! SMPL's joint tables: count, names, parents and mirror twins, which poses and skeletons
//! both read (re-exported by [`crate::body::skeleton`]).

/// The number of SMPL joints.
pub const JOINT_COUNT: usize = 24;

/// SMPL's joint names in SMPL's order.
pub const JOINT_NAMES: [&str; JOINT_COUNT] = [
    "pelvis",
    "left_hip",
    "right_hip",
    "spine1",
    "left_knee",
    "right_knee",
    "spine2",
    "left_ankle",
    "right_ankle",
    "spine3",
    "left_foot",
    "right_foot",
    "neck",
    "left_collar",
    "right_collar",
    "head",
    "left_shoulder",
    "right_shoulder",
    "left_elbow",
    "right_elbow",
    "left_wrist",
    "right_wrist",
    "left_hand",
    "right_hand",
];

/// Each joint's parent (`None` for the root, the pelvis). Parents precede children.
pub const PARENTS: [Option<usize>; JOINT_COUNT] = [
    None,
    Some(0),
    Some(0),
    Some(0),
    Some(1),
    Some(2),
    Some(3),
    Some(4),
    Some(5),
    Some(6),
    Some(7),
    Some(8),
    Some(9),
    Some(9),
    Some(9),
    Some(12),
    Some(13),
    Some(14),
    Some(16),
    Some(17),
    Some(18),
    Some(19),
    Some(20),
    Some(21),
];

/// Each joint's left-right twin: `MIRRORED_JOINTS[j]` is the joint that plays `j`'s part in
/// the body mirrored through its sagittal plane (x → −x). Left and right joints swap; the
/// centre joints (pelvis, spine, neck, head) map to themselves. An involution.
pub const MIRRORED_JOINTS: [usize; JOINT_COUNT] = [
    0, 2, 1, 3, 5, 4, 6, 8, 7, 9, 11, 10, 12, 14, 13, 15, 17, 16, 19, 18, 21, 20, 23, 22,
];

/// SMPL's mirror twin of joint `j` across the sagittal plane: a left joint's right one and
/// back; centre joints (pelvis, spine, neck, head) are their own twins.
///
/// # Panics
/// If `j` is not a joint index (23 or less).
#[must_use]
pub fn mirror_joint(j: usize) -> usize {
    assert!(j < JOINT_COUNT, "joint index {j} past {}", JOINT_COUNT - 1);
    match j {
        1 | 4 | 7 | 10 | 13 | 16 | 18 | 20 | 22 => j + 1,
        2 | 5 | 8 | 11 | 14 | 17 | 19 | 21 | 23 => j - 1,
        _ => j,
    }
}

/// The index of the joint called `name` (SMPL naming), if any.
#[must_use]
pub fn joint_index(name: &str) -> Option<usize> {
    JOINT_NAMES.iter().position(|n| *n == name)
}
