//! Haario-style covariance adaptation (see [`Adapt`](super::Adapt) for the rules).

use serde::{Deserialize, Serialize};

use crate::linalg::cholesky_in_place;

/// Running mean and scatter matrix of one chain's states since the adaptation started.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub(crate) struct AdaptState {
    dim: usize,
    count: u64,
    accepted: u64,
    #[serde(with = "super::bits::vec")]
    mean: Vec<f64>,
    /// Welford scatter, lower triangle of a row-major `dim × dim` matrix.
    #[serde(with = "super::bits::vec")]
    m2: Vec<f64>,
    #[serde(skip)]
    delta: Vec<f64>,
    #[serde(skip)]
    work: Vec<f64>,
}

impl AdaptState {
    pub(crate) fn new(dim: usize) -> Self {
        let mut s = Self {
            dim,
            count: 0,
            accepted: 0,
            mean: vec![0.0; dim],
            m2: vec![0.0; dim * dim],
            delta: Vec::new(),
            work: Vec::new(),
        };
        s.prepare();
        s
    }

    /// Whether the stored buffers fit dimension `dim` (for checkpoints read from disk).
    pub(crate) fn has_dim(&self, dim: usize) -> bool {
        self.dim == dim && self.mean.len() == dim && self.m2.len() == dim * dim
    }

    /// Sizes the scratch buffers (after construction or deserialisation).
    pub(crate) fn prepare(&mut self) {
        self.delta.resize(self.dim, 0.0);
        self.work.resize(self.dim * self.dim, 0.0);
    }

    /// Adds the chain's current state (Welford: `M₂ += (x − m_{k−1})(x − m_k)ᵀ`).
    pub(crate) fn observe(&mut self, x: &[f64], accepted: bool) {
        let d = self.dim;
        self.count += 1;
        self.accepted += u64::from(accepted);
        let k = self.count as f64;
        for ((dl, m), xi) in self.delta.iter_mut().zip(&mut self.mean).zip(x) {
            *dl = xi - *m;
            *m += *dl / k;
        }
        for (i, row) in self.m2.chunks_exact_mut(d).enumerate() {
            let di = self.delta[i];
            for ((r, xj), mj) in row[..=i].iter_mut().zip(x).zip(&self.mean) {
                *r += di * (xj - mj);
            }
        }
    }

    /// Writes the Cholesky factor of `scale · (C + ridge · diag C)` into `chol` and returns
    /// `true`, or leaves `chol` untouched and returns `false` when there are fewer than `2D`
    /// accepted moves or the matrix does not factorise.
    pub(crate) fn update_cholesky(&mut self, scale: f64, ridge: f64, chol: &mut [f64]) -> bool {
        let d = self.dim;
        if self.count < 2 || self.accepted < 2 * d as u64 {
            return false;
        }
        let norm = scale / (self.count - 1) as f64;
        for i in 0..d {
            for j in 0..=i {
                let c = norm * self.m2[i * d + j];
                self.work[i * d + j] = c;
                self.work[j * d + i] = c;
            }
            self.work[i * d + i] *= 1.0 + ridge;
        }
        if cholesky_in_place(&mut self.work, d, 0.0).is_err() {
            return false;
        }
        chol.copy_from_slice(&self.work);
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn welford_matches_two_pass_covariance() {
        let xs: Vec<[f64; 2]> = (0..50)
            .map(|i| {
                let t = i as f64;
                [t.sin() * 3.0 + 1.0, (0.7 * t).cos() - 0.5 * t.sin()]
            })
            .collect();
        let mut a = AdaptState::new(2);
        for x in &xs {
            a.observe(x, true);
        }
        let n = xs.len() as f64;
        let m0 = xs.iter().map(|x| x[0]).sum::<f64>() / n;
        let m1 = xs.iter().map(|x| x[1]).sum::<f64>() / n;
        let c = |f: &dyn Fn(&[f64; 2]) -> f64| xs.iter().map(f).sum::<f64>() / (n - 1.0);
        let c00 = c(&|x| (x[0] - m0) * (x[0] - m0));
        let c10 = c(&|x| (x[1] - m1) * (x[0] - m0));
        let c11 = c(&|x| (x[1] - m1) * (x[1] - m1));
        let mut l = [0.0; 4];
        assert!(a.update_cholesky(1.0, 0.0, &mut l));
        // L Lᵀ must reproduce the two-pass covariance to round-off.
        let (l00, l10, l11) = (l[0], l[2], l[3]);
        assert!((l00 * l00 - c00).abs() < 1e-12 * c00);
        assert!((l10 * l00 - c10).abs() < 1e-12 * c00);
        assert!((l10 * l10 + l11 * l11 - c11).abs() < 1e-12 * c11);
    }

    #[test]
    fn refuses_with_too_few_accepted_moves() {
        let mut a = AdaptState::new(2);
        for i in 0..10 {
            a.observe(&[i as f64, 0.5 * i as f64], i < 3);
        }
        let mut l = [9.0; 4];
        assert!(!a.update_cholesky(1.0, 0.0, &mut l));
        assert_eq!(l, [9.0; 4]);
    }
}
