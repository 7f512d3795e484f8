//! The networks in Burn: GarMatNet's two MLPs, the paper's baseline, their output
//! normalisation and tensor plumbing.

pub(crate) mod baseline_net;
pub(crate) mod garmatnet_net;
pub(crate) mod model_tensors;
pub(crate) mod output_normalizer;
pub(crate) mod tensor_util;
