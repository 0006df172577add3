//! The optimal bridge's fixed point and the grid of bridge functions the pilot fixes.

use super::logsum::lae;

fn log_sum_exp(it: impl Iterator<Item = f64>) -> f64 {
    it.fold(f64::NEG_INFINITY, lae)
}

/// Offsets (nat) of the bridge grid around the pilot's fixed point; the first is the pilot
/// value itself.
pub(crate) const GRID_OFFSETS: [f64; 11] =
    [0.0, -0.5, 0.5, -1.0, 1.0, -2.0, 2.0, -4.0, 4.0, -8.0, 8.0];

/// The bridge function `h = 1/(s₁ r₀ f̃₁ + s₂ f̃₂)` of one pair at every grid point.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub(crate) struct PairGrid {
    pub ln_r: Vec<f64>,
    pub ln_s1: f64,
    pub ln_s2: f64,
}

/// Bridge functions of every pair `a < b`.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub(crate) struct Grid {
    pub(crate) k: usize,
    pub(crate) pairs: Vec<PairGrid>,
}

impl Grid {
    pub fn pair(&self, a: usize, b: usize) -> &PairGrid {
        &self.pairs[a * self.k + b]
    }
}

/// The optimal bridge's fixed point on raw draws `x` (from `f₁`) and `y` (from `f₂`), both in
/// the orientation `ρ = f₂/f₁` (shifted by the box masses); `None` when it does not converge.
pub(crate) fn fixed_point(x: &[f64], y: &[f64]) -> Option<f64> {
    let (n1, n2) = (x.len() as f64, y.len() as f64);
    if n2 == 0.0 {
        return Some(log_sum_exp(x.iter().copied()) - n1.ln());
    }
    if n1 == 0.0 {
        return Some(-(log_sum_exp(y.iter().map(|&v| -v)) - n2.ln()));
    }
    let (ls1, ls2) = ((n1 / (n1 + n2)).ln(), (n2 / (n1 + n2)).ln());
    let mean_num = |lr: f64| log_sum_exp(x.iter().map(|&xi| num_term(lr, ls1, ls2, xi))) - n1.ln();
    let mean_den = |lr: f64| log_sum_exp(y.iter().map(|&yj| den_term(lr, ls1, ls2, yj))) - n2.ln();
    let mut lr = log_sum_exp(x.iter().copied()) - n1.ln();
    if !lr.is_finite() {
        lr = -(log_sum_exp(y.iter().map(|&v| -v)) - n2.ln());
    }
    if !lr.is_finite() {
        lr = 0.0;
    }
    for _ in 0..10_000 {
        let next = mean_num(lr) - mean_den(lr);
        if !next.is_finite() {
            return None;
        }
        let done = (next - lr).abs() < 1e-10;
        lr = next;
        if done {
            return Some(lr);
        }
    }
    None
}

#[inline]
pub(crate) fn num_term(lr: f64, ls1: f64, ls2: f64, x: f64) -> f64 {
    if x == f64::NEG_INFINITY {
        f64::NEG_INFINITY
    } else {
        x - lae(ls1 + lr, ls2 + x)
    }
}

#[inline]
pub(crate) fn den_term(lr: f64, ls1: f64, ls2: f64, y: f64) -> f64 {
    if y == f64::INFINITY {
        f64::NEG_INFINITY
    } else {
        -lae(ls1 + lr, ls2 + y)
    }
}
