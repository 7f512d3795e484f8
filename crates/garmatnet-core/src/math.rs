//! The one place that chooses garmatnet's scalar and vector types.
//!
//! Geometry and simulation run in `f64` (the solver's residuals go below 1e-6 N and the
//! decomposition must round-trip exactly); the networks convert to `f32` at their boundary.

/// The scalar of all geometry: metres, radians, newtons, kilograms.
pub type Real = f64;
/// A 3-vector: positions (metres), displacements, forces.
pub type Vec3 = nalgebra::Vector3<Real>;
/// A 3x3 matrix.
pub type Mat3 = nalgebra::Matrix3<Real>;
/// A rotation matrix (orthonormal, determinant 1).
pub type Rot3 = nalgebra::Rotation3<Real>;
/// A unit quaternion.
pub type UnitQuat = nalgebra::UnitQuaternion<Real>;
/// A rigid transform (rotation then translation), used for joints and skinning.
pub type Iso3 = nalgebra::Isometry3<Real>;
