//! Principal components of the training displacements: the basis of the low-rank output
//! head (`--rank K`), computed once before training.

use faer::{Mat, Side};
use garmatnet_model::OutputNormalizer;

use crate::error::{Error, Result};

/// The top-`k` principal directions of the normalised label rows (`labels`: row-major
/// `[S, dim]` in metres, normalised with `norm` first), each scaled by the standard deviation
/// of the data along it, and the mean row. A net that outputs `k` coefficients `c` predicts
/// `mean + c · basis`; on the training data the ideal coefficients have unit variance.
///
/// At most `max_rows` rows, spread evenly, enter the analysis (the Gram matrix is
/// `max_rows²`).
///
/// # Shapes
/// Returns `basis`: `[k, dim]` row-major, `mean`: `[dim]`.
///
/// # Errors
/// [`Error::InvalidConfig`] if `k` is zero or exceeds the rows used or `dim`, or if the
/// eigen-decomposition fails.
pub(crate) fn pca_basis(
    labels: &[f32],
    dim: usize,
    norm: &OutputNormalizer,
    k: usize,
    max_rows: usize,
) -> Result<(Vec<f32>, Vec<f32>)> {
    let total = labels.len() / dim.max(1);
    let s = total.min(max_rows.max(1));
    if k == 0 || k > s || k > dim {
        return Err(Error::InvalidConfig(format!(
            "output rank {k} must lie in [1, min(training samples used = {s}, 3n = {dim})]"
        )));
    }
    let rows: Vec<Vec<f64>> = (0..s)
        .map(|i| {
            let r = i * total / s;
            let raw: Vec<f64> = labels[r * dim..(r + 1) * dim]
                .iter()
                .map(|&v| f64::from(v))
                .collect();
            norm.normalize(&raw)
        })
        .collect();
    let mut mean = vec![0.0; dim];
    for row in &rows {
        mean.iter_mut().zip(row).for_each(|(m, v)| *m += v);
    }
    mean.iter_mut().for_each(|m| *m /= s as f64);
    let y = Mat::<f64>::from_fn(s, dim, |i, j| rows[i][j] - mean[j]);
    let gram = &y * y.transpose();
    let eigen = gram
        .self_adjoint_eigen(Side::Lower)
        .map_err(|e| Error::InvalidConfig(format!("PCA eigen-decomposition failed: {e:?}")))?;
    let values = eigen.S().column_vector();
    let vectors = eigen.U();
    // Eigenvalues come in ascending order: the last k are the principal ones.
    let mut basis = Vec::with_capacity(k * dim);
    for c in (s - k..s).rev() {
        let lambda = values[c].max(0.0);
        if lambda <= 1e-12 {
            basis.extend(std::iter::repeat_n(0.0f32, dim));
            continue;
        }
        let u = vectors.col(c);
        let direction = y.transpose() * u;
        // |Yᵀu| = sqrt(λ); scaled by the std along it, sqrt(λ / S): factor 1 / sqrt(S).
        let scale = 1.0 / (s as f64).sqrt();
        basis.extend((0..dim).map(|j| (direction[j] * scale) as f32));
    }
    Ok((basis, mean.iter().map(|&m| m as f32).collect()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use garmatnet_core::SplitMix64;

    #[test]
    fn the_basis_spans_data_of_low_rank_and_scales_to_its_spread() {
        // 200 rows in 12 dimensions driven by 2 latent factors of std 3 and 0.5.
        let (s, dim) = (200, 12);
        let mut rng = SplitMix64::new(1);
        let a: Vec<f64> = (0..dim).map(|_| rng.uniform(-1.0, 1.0)).collect();
        let b: Vec<f64> = (0..dim).map(|_| rng.uniform(-1.0, 1.0)).collect();
        let mut labels = Vec::new();
        for _ in 0..s {
            let (x, z) = (3.0 * rng.uniform(-1.7, 1.7), 0.5 * rng.uniform(-1.7, 1.7));
            labels.extend((0..dim).map(|j| (1.0 + x * a[j] + z * b[j]) as f32));
        }
        let norm = OutputNormalizer::identity(dim);
        let (basis, mean) = pca_basis(&labels, dim, &norm, 2, 1000).unwrap();
        assert_eq!((basis.len(), mean.len()), (2 * dim, dim));
        // Every row is reproduced by mean + least-squares coefficients on the basis.
        let row = |k: usize| &basis[k * dim..(k + 1) * dim];
        for r in labels.chunks_exact(dim).take(20) {
            let d: Vec<f64> = r.iter().zip(&mean).map(|(v, m)| f64::from(v - m)).collect();
            let mut residual = d.clone();
            for k in 0..2 {
                let bk = row(k);
                let nn: f64 = bk.iter().map(|&v| f64::from(v) * f64::from(v)).sum();
                let c: f64 = bk
                    .iter()
                    .zip(&d)
                    .map(|(&v, x)| f64::from(v) * x)
                    .sum::<f64>()
                    / nn;
                residual
                    .iter_mut()
                    .zip(bk)
                    .for_each(|(e, &v)| *e -= c * f64::from(v));
            }
            let err: f64 = residual.iter().map(|e| e * e).sum::<f64>().sqrt();
            assert!(err < 1e-3, "residual {err}");
        }
        let n0: f64 = row(0)
            .iter()
            .map(|&v| f64::from(v).powi(2))
            .sum::<f64>()
            .sqrt();
        let n1: f64 = row(1)
            .iter()
            .map(|&v| f64::from(v).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!(
            n0 > 3.0 * n1,
            "the first component carries the larger spread: {n0} vs {n1}"
        );
        assert!(pca_basis(&labels, dim, &norm, 0, 1000).is_err());
        assert!(pca_basis(&labels, dim, &norm, 13, 1000).is_err());
    }
}
