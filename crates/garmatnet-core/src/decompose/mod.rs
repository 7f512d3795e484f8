//! The split of a drape into a smooth garment and its wrinkles: Laplacian smoothing and
//! the displacement decomposition.

pub(crate) mod decomposition;
pub(crate) mod laplacian;
