//! Small conversions between host vectors and Burn tensors used across the crate.

use burn::prelude::*;

/// A float tensor's values as `f32`, row-major.
///
/// # Panics
/// If the backend cannot read the tensor back (a broken device, not bad input).
pub(crate) fn to_f32<const D: usize>(t: Tensor<D>) -> Vec<f32> {
    t.into_data()
        .try_into_vec_as::<f32>()
        .unwrap_or_else(|e| panic!("reading a tensor back from the device failed: {e:?}"))
}

/// A `[rows, cols]` tensor from row-major `f32` values.
pub(crate) fn matrix(values: Vec<f32>, rows: usize, cols: usize, device: &Device) -> Tensor<2> {
    Tensor::from_data(TensorData::new(values, [rows, cols]), device)
}

/// A `[len]` tensor from `f32` values.
pub(crate) fn vector(values: Vec<f32>, device: &Device) -> Tensor<1> {
    let n = values.len();
    Tensor::from_data(TensorData::new(values, [n]), device)
}
