//! The T-shirt's ease and proportions, derived from the skeleton: the boxy construction
//! and what the fitted cut adds to it (metres, radians).

use crate::body::pose::A_POSE_SHOULDER_ANGLE;
use crate::body::skeleton::{Skeleton, joint_index};
use crate::error::{Error, Result};
use crate::garment::style::GarmentStyle;
use crate::math::{Real, Vec3};

/// Ease and proportions, all derived from the skeleton (metres).
#[derive(Debug, Clone)]
pub(crate) struct ShirtShape {
    /// Torso half-width (x) and half-depth (z), ease included.
    pub(crate) a: Real,
    pub(crate) c: Real,
    /// Torso centre depth (z).
    pub(crate) zc: Real,
    /// Hem height, shoulder ridge height at the centre.
    pub(crate) y_hem: Real,
    pub(crate) y_ridge_centre: Real,
    /// Height of the shoulder cap (ridge down to where the torso is vertical).
    pub(crate) cap_height: Real,
    /// Sleeve radius (around the arm bone), ease included.
    pub(crate) sleeve_radius: Real,
    /// |x| of the cuffs.
    pub(crate) x_cuff: Real,
    /// |x| of the neck opening's sides.
    pub(crate) x_neck: Real,
    /// Pattern depths of the neck cut-out, front and back (metres).
    pub(crate) neck_drop_front: Real,
    pub(crate) neck_drop_back: Real,
    /// Shoulder and elbow joints of the left (+x) and right (-x) arms.
    pub(crate) arm: [(Vec3, Vec3); 2],
    /// How far the armpit (the side seam's top) sits below the sleeve's underarm line.
    pub(crate) armpit_drop: Real,
    /// The fitted cut's extra shape, `None` for the boxy shirt.
    pub(crate) fitted: Option<FittedShape>,
}

/// What the fitted cut adds to the boxy construction (metres, radians).
#[derive(Debug, Clone)]
pub(crate) struct FittedShape {
    /// Ridge (shoulder seam) height over the neck's sides; it slopes down from `x_neck` to
    /// the shoulder point `a` by `SHOULDER_SLOPE`.
    pub(crate) y_ridge_neck: Real,
    /// The (left) sleeve's top seam runs from the shoulder point `top_start` (over the
    /// torso's side) to the cuff's top `top_end`; its underarm seam from the armpit
    /// `under_start` to the cuff's bottom `under_end`. The cuff ring lies square to the arm
    /// in the A-pose.
    pub(crate) top_start: Vec3,
    pub(crate) top_end: Vec3,
    pub(crate) under_start: Vec3,
    pub(crate) under_end: Vec3,
    /// Half-depth (z) of the armhole and radius of the cuff.
    pub(crate) armhole_half_depth: Real,
    pub(crate) cuff_radius: Real,
    /// The arm's depth (z): the sleeve's mid-plane.
    pub(crate) arm_z: Real,
    /// The A-posed arm's upward normal (in the x-y plane) and how far the top seam bows
    /// out along it halfway to the cuff.
    pub(crate) arm_up: Vec3,
    pub(crate) shoulder_bow: Real,
    /// The sleeve band's height in the pattern (metres): half the sleeve's circumference.
    pub(crate) sleeve_band: Real,
}

/// The fitted cut's shoulder seam slope below horizontal (radians): 12°. Real T-shirts have
/// 15-20°; the capsule body's shoulders are square (they rise outward), and a steeper seam
/// would float several centimetres above the neck's sides.
pub(crate) const SHOULDER_SLOPE: Real = 12.0 * std::f64::consts::PI / 180.0;

impl ShirtShape {
    pub(crate) fn from_skeleton(skeleton: &Skeleton, style: GarmentStyle) -> Result<Self> {
        match style {
            GarmentStyle::Boxy => Self::boxy(skeleton),
            GarmentStyle::Fitted => Self::fitted(skeleton),
        }
    }

    /// The fitted cut on the skeleton made left-right symmetric (each left joint averaged
    /// with its mirrored right twin, centre joints on x = 0), so the shirt is exactly
    /// mirror-symmetric.
    pub(crate) fn fitted(skeleton: &Skeleton) -> Result<Self> {
        let j = skeleton.rest_joints();
        let at = |name: &str| j[joint_index(name).expect("SMPL joint names are fixed")];
        let twin = |left: &str| {
            let (l, r) = (at(left), at(&left.replace("left", "right")));
            Vec3::new(0.5 * (l.x - r.x), 0.5 * (l.y + r.y), 0.5 * (l.z + r.z))
        };
        let (ls, le) = (twin("left_shoulder"), twin("left_elbow"));
        let span = 2.0 * ls.x;
        if !(0.1..=1.0).contains(&span) || le.x <= ls.x {
            return Err(Error::NotATPose {
                shoulder_span: span,
            });
        }
        let spine = ["pelvis", "spine1", "spine2", "spine3", "neck"];
        let zc = spine.iter().map(|n| at(n).z).sum::<Real>() / spine.len() as Real;
        let neck_y = at("neck").y;
        // Regular fit: ~2.2 cm off SMPL's mean chest all round (about 10 cm of circumference
        // ease), 2 cm round the upper arm, a crew neck 1.5-2 cm off the neck's base.
        let a = 0.47 * span + 0.022;
        let sleeve_radius = 0.16 * span + 0.019;
        let x_neck = 0.22 * span;
        let y_sleeve_top = ls.y + sleeve_radius;
        let y_ridge_neck = y_sleeve_top + SHOULDER_SLOPE.tan() * (a - x_neck);
        let right = |v: Vec3| Vec3::new(-v.x, v.y, v.z);
        let armpit_drop = 0.07;
        // The A-posed arm: the upper arm turned down about the shoulder joint.
        let (sin, cos) = A_POSE_SHOULDER_ANGLE.sin_cos();
        let bone = le - ls;
        let along = Vec3::new(
            bone.x * cos + bone.y * sin,
            -bone.x * sin + bone.y * cos,
            0.0,
        )
        .normalize();
        let up = Vec3::new(-along.y, along.x, 0.0);
        let cuff_radius = sleeve_radius - 0.01;
        let cuff_centre = Vec3::new(ls.x, ls.y, zc) + along * (0.8 * bone.norm());
        Ok(Self {
            a,
            c: 0.315 * span + 0.024,
            zc,
            y_hem: at("pelvis").y - 0.05,
            y_ridge_centre: y_ridge_neck,
            cap_height: 0.12,
            sleeve_radius,
            x_cuff: ls.x + 0.8 * (le.x - ls.x),
            x_neck,
            neck_drop_front: 0.1,
            neck_drop_back: 0.08,
            arm: [(ls, le), (right(ls), right(le))],
            armpit_drop,
            fitted: Some(FittedShape {
                y_ridge_neck: y_ridge_neck.max(neck_y),
                top_start: Vec3::new(a, y_sleeve_top, zc),
                top_end: cuff_centre + up * cuff_radius,
                under_start: Vec3::new(a, ls.y - sleeve_radius - armpit_drop, zc),
                under_end: cuff_centre - up * cuff_radius,
                armhole_half_depth: sleeve_radius + 0.01,
                cuff_radius,
                arm_z: ls.z,
                arm_up: up,
                shoulder_bow: 0.015,
                sleeve_band: 0.26,
            }),
        })
    }

    pub(crate) fn boxy(skeleton: &Skeleton) -> Result<Self> {
        let j = skeleton.rest_joints();
        let at = |name: &str| j[joint_index(name).expect("SMPL joint names are fixed")];
        let (ls, rs) = (at("left_shoulder"), at("right_shoulder"));
        let (le, re) = (at("left_elbow"), at("right_elbow"));
        let span = ls.x - rs.x;
        if !(0.1..=1.0).contains(&span) || le.x <= ls.x || re.x >= rs.x {
            return Err(Error::NotATPose {
                shoulder_span: span,
            });
        }
        let spine = ["pelvis", "spine1", "spine2", "spine3", "neck"];
        let zc = spine.iter().map(|n| at(n).z).sum::<Real>() / spine.len() as Real;
        // SMPL's mean body: chest ~0.94 x shoulder span wide, ~0.63 x deep, upper arm
        // ~0.16 x thick; the ease (4 cm torso, 3.5 cm sleeve) is what keeps the shirt clear.
        let sleeve_radius = 0.16 * span + 0.035;
        Ok(Self {
            a: 0.47 * span + 0.04,
            c: 0.315 * span + 0.04,
            zc,
            y_hem: at("pelvis").y - 0.05,
            y_ridge_centre: at("neck").y + 0.045,
            cap_height: 0.1,
            sleeve_radius,
            x_cuff: ls.x + 0.75 * (le.x - ls.x),
            x_neck: 0.6 * (ls.x - at("neck").x),
            neck_drop_front: 0.16,
            neck_drop_back: 0.1,
            arm: [(ls, le), (rs, re)],
            armpit_drop: 0.025,
            fitted: None,
        })
    }

    /// The arm bone's axis point at `x` (extrapolated along shoulder -> elbow).
    pub(crate) fn arm_axis(&self, x: Real) -> Vec3 {
        let (s, e) = self.arm[usize::from(x < 0.0)];
        s + (e - s) * ((x - s.x) / (e.x - s.x))
    }

    pub(crate) fn sleeve_top(&self, sign: Real) -> Real {
        self.arm_axis(sign * self.a).y + self.sleeve_radius
    }
}
