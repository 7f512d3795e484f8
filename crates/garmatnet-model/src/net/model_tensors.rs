//! The tensors of a model file: module parameters to safetensors views and back, the
//! corruption checksum and the atomic write. [`crate::file::model_file`] describes the layout.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::Path;

use burn::module::Param;
use burn::nn::{DropoutConfig, Linear};
use burn::prelude::*;
use garmatnet_core::Real;
use safetensors::{Dtype, tensor::TensorView};

use crate::error::{Error, Result};
use crate::net::garmatnet_net::{GarMatNet, GarMatNetConfig};
use crate::net::output_normalizer::OutputNormalizer;
use crate::net::tensor_util::{matrix, to_f32, vector};

/// One tensor ready for the file.
pub(crate) struct Stored {
    pub(crate) name: String,
    pub(crate) dtype: Dtype,
    pub(crate) shape: Vec<usize>,
    pub(crate) bytes: Vec<u8>,
}

/// FNV-1a 64: every single changed byte changes the result (each step is a bijection of the
/// state), which is what a corruption check needs; not a cryptographic hash.
pub(crate) fn checksum<'a>(
    document: &str,
    tensors: impl Iterator<Item = (&'a str, Dtype, &'a [usize], &'a [u8])>,
) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |bytes: &[u8]| {
        for &b in bytes {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
    };
    eat(document.as_bytes());
    for (name, dtype, shape, data) in tensors {
        eat(name.as_bytes());
        eat(format!("{dtype:?}").as_bytes());
        shape.iter().for_each(|&d| eat(&(d as u64).to_le_bytes()));
        eat(data);
    }
    h
}

pub(crate) fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let io = |source| Error::Io {
        path: path.to_owned(),
        source,
    };
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let mut tmp = tempfile::NamedTempFile::new_in(dir).map_err(io)?;
    tmp.write_all(bytes).map_err(io)?;
    // Temporary files are created owner-only; a model file is an ordinary artefact.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::Permissions::from_mode(0o644);
        tmp.as_file().set_permissions(mode).map_err(io)?;
    }
    tmp.as_file().sync_all().map_err(io)?;
    tmp.persist(path).map_err(|e| io(e.error))?;
    Ok(())
}

fn f32_tensor<const D: usize>(name: String, t: Tensor<D>) -> Stored {
    let shape = t.dims().to_vec();
    let bytes = to_f32(t).iter().flat_map(|v| v.to_le_bytes()).collect();
    Stored {
        name,
        dtype: Dtype::F32,
        shape,
        bytes,
    }
}

pub(crate) fn net_tensors(prefix: &str, net: &GarMatNet) -> Vec<Stored> {
    let mut out = Vec::new();
    for (name, layer) in [
        ("pose_in", &net.pose_in),
        ("material_in", &net.material_in),
        ("merge", &net.merge),
        ("output", &net.output),
    ] {
        out.push(f32_tensor(
            format!("{prefix}.{name}.weight"),
            layer.weight.val(),
        ));
        let bias = layer.bias.as_ref().map(|b| b.val());
        let bias = bias.unwrap_or_else(|| {
            Tensor::zeros([layer.weight.dims()[1]], &layer.weight.val().device())
        });
        out.push(f32_tensor(format!("{prefix}.{name}.bias"), bias));
    }
    if let (Some(b), Some(m)) = (&net.basis, &net.basis_mean) {
        out.push(f32_tensor(format!("{prefix}.basis"), b.val()));
        out.push(f32_tensor(format!("{prefix}.basis_mean"), m.val()));
    }
    out
}

pub(crate) fn norm_tensors(prefix: &str, norm: &OutputNormalizer) -> Vec<Stored> {
    let f64s = |v: &[Real]| v.iter().flat_map(|x| x.to_le_bytes()).collect();
    vec![
        Stored {
            name: format!("{prefix}.mean"),
            dtype: Dtype::F64,
            shape: vec![norm.dim()],
            bytes: f64s(norm.mean()),
        },
        Stored {
            name: format!("{prefix}.std"),
            dtype: Dtype::F64,
            shape: vec![norm.dim()],
            bytes: f64s(norm.std()),
        },
    ]
}

/// The file's tensors, consumed by name so leftovers can be reported.
pub(crate) struct TensorSource<'a> {
    pub(crate) views: BTreeMap<String, TensorView<'a>>,
    pub(crate) path: &'a Path,
}

impl TensorSource<'_> {
    fn take(&mut self, name: &str, dtype: Dtype, shape: &[usize]) -> Result<TensorView<'_>> {
        let corrupt = |message| Error::Corrupt {
            path: self.path.to_owned(),
            message,
        };
        let view = self
            .views
            .remove(name)
            .ok_or_else(|| corrupt(format!("tensor `{name}` is missing")))?;
        if view.dtype() != dtype || view.shape() != shape {
            return Err(corrupt(format!(
                "tensor `{name}` is {:?} {:?}, expected {dtype:?} {shape:?}",
                view.dtype(),
                view.shape()
            )));
        }
        Ok(view)
    }

    fn f32(&mut self, name: &str, shape: &[usize]) -> Result<Vec<f32>> {
        let path = self.path.to_owned();
        let view = self.take(name, Dtype::F32, shape)?;
        let values: Vec<f32> = view
            .data()
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        if let Some(i) = values.iter().position(|v| !v.is_finite()) {
            let message = format!("tensor `{name}` has a non-finite value at index {i}");
            return Err(Error::Corrupt { path, message });
        }
        Ok(values)
    }

    pub(crate) fn f64(&mut self, name: &str, shape: &[usize]) -> Result<Vec<f64>> {
        let path = self.path.to_owned();
        let view = self.take(name, Dtype::F64, shape)?;
        let values: Vec<f64> = view
            .data()
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().unwrap_or([0; 8])))
            .collect();
        if let Some(i) = values.iter().position(|v| !v.is_finite()) {
            let message = format!("tensor `{name}` has a non-finite value at index {i}");
            return Err(Error::Corrupt { path, message });
        }
        Ok(values)
    }

    fn linear(&mut self, name: &str, d_in: usize, d_out: usize, device: &Device) -> Result<Linear> {
        let w = self.f32(&format!("{name}.weight"), &[d_in, d_out])?;
        let b = self.f32(&format!("{name}.bias"), &[d_out])?;
        Ok(Linear {
            weight: Param::from_tensor(matrix(w, d_in, d_out, device)),
            bias: Some(Param::from_tensor(vector(b, device))),
        })
    }
}

pub(crate) fn net_from_tensors(
    prefix: &str,
    config: GarMatNetConfig,
    tensors: &mut TensorSource<'_>,
    device: &Device,
) -> Result<GarMatNet> {
    let c = &config;
    let out_width = c.output_rank.unwrap_or(c.output_dim());
    let pose_in = tensors.linear(
        &format!("{prefix}.pose_in"),
        c.pose_encoding.width(),
        c.pose_hidden,
        device,
    )?;
    let material_in = tensors.linear(
        &format!("{prefix}.material_in"),
        c.material_dim,
        c.material_hidden,
        device,
    )?;
    let merge = tensors.linear(
        &format!("{prefix}.merge"),
        c.pose_hidden + c.material_hidden,
        c.hidden,
        device,
    )?;
    let output = tensors.linear(&format!("{prefix}.output"), c.hidden, out_width, device)?;
    let (basis, basis_mean) = match c.output_rank {
        Some(k) => {
            let b = tensors.f32(&format!("{prefix}.basis"), &[k, c.output_dim()])?;
            let m = tensors.f32(&format!("{prefix}.basis_mean"), &[c.output_dim()])?;
            (
                Some(Param::from_tensor(matrix(b, k, c.output_dim(), device))),
                Some(Param::from_tensor(vector(m, device))),
            )
        }
        None => (None, None),
    };
    Ok(GarMatNet {
        pose_in,
        material_in,
        merge,
        dropout: DropoutConfig::new(c.dropout).init(),
        output,
        basis,
        basis_mean,
        config,
    })
}
