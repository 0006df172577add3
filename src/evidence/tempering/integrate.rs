//! The estimators along the ladder: thermodynamic integration by the cubic Hermite rule with
//! its discretisation error, stepping stone, and their batch-means errors.

use crate::evidence::mvn::log_add_exp;
use serde::Serialize;

/// Thermodynamic-integration estimate of `ln Z`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ThermodynamicEstimate {
    /// `ln Z` by the cubic Hermite rule (trapezoid plus the `f′ = Var_β ln L` end corrections).
    pub ln_z: f64,
    /// One-sigma Monte-Carlo error of `ln_z` (batch means over sweeps, all rungs together).
    pub std_err: f64,
    /// Estimated quadrature error of `ln_z`: `|I_H − I_H(every other rung)|/15`. Not a
    /// random error; add it to `std_err` (in quadrature or linearly) for a total.
    pub discretisation_err: f64,
    /// `ln Z` by the plain trapezoid on the same ladder, for comparison.
    pub ln_z_trapezoid: f64,
}

impl ThermodynamicEstimate {
    /// `√(std_err² + discretisation_err²)`.
    pub fn total_err(&self) -> f64 {
        self.std_err.hypot(self.discretisation_err)
    }
}

/// Stepping-stone estimate of `ln Z`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SteppingStoneEstimate {
    /// `ln Z`.
    pub ln_z: f64,
    /// One-sigma Monte-Carlo error (delta method and batch means over sweeps).
    pub std_err: f64,
}

/// Per rung: the post-burn-in mean and variance of `ln L` and the mean's batch-means error
/// (NaN where the mean is not finite).
pub(crate) fn rung_moments(
    series: &[f64],
    n_t: usize,
    n_post: usize,
    batch: usize,
) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let col = |i: usize| (0..n_post).map(move |t| series[t * n_t + i]);
    let mut mean = Vec::with_capacity(n_t);
    let mut var = Vec::with_capacity(n_t);
    let mut mean_se = Vec::with_capacity(n_t);
    for i in 0..n_t {
        let m = col(i).sum::<f64>() / n_post as f64;
        let v = if m.is_finite() {
            col(i).map(|l| (l - m).powi(2)).sum::<f64>() / n_post as f64
        } else {
            f64::NAN
        };
        let se = if m.is_finite() {
            batch_means_var(|t| series[t * n_t + i], n_post, batch).sqrt()
        } else {
            f64::NAN
        };
        mean.push(m);
        var.push(v);
        mean_se.push(se);
    }
    (mean, var, mean_se)
}

/// `Var(ū)` of the mean of `u(0..n)` by batch means with batch size `b` (the first `n mod b`
/// values are dropped).
fn batch_means_var(u: impl Fn(usize) -> f64, n: usize, b: usize) -> f64 {
    let a = n / b;
    let start = n - a * b;
    let means: Vec<f64> = (0..a)
        .map(|j| (0..b).map(|i| u(start + j * b + i)).sum::<f64>() / b as f64)
        .collect();
    let grand = means.iter().sum::<f64>() / a as f64;
    let s2 = b as f64 * means.iter().map(|m| (m - grand).powi(2)).sum::<f64>() / (a - 1) as f64;
    s2 / n as f64
}

/// Trapezoid and cubic-Hermite integrals of `f` (values `f`, slopes `fp`) over the ladder.
pub(crate) fn hermite_integral(betas: &[f64], f: &[f64], fp: &[f64]) -> (f64, f64) {
    let mut trap = 0.0;
    let mut corr = 0.0;
    for i in 0..betas.len() - 1 {
        let h = betas[i + 1] - betas[i];
        trap += h * (f[i] + f[i + 1]) / 2.0;
        corr += h * h / 12.0 * (fp[i] - fp[i + 1]);
    }
    (trap, trap + corr)
}

/// The Hermite integral and its discretisation-error estimate `|I_H − I_H(coarse)|/15`, the
/// coarse ladder being every other rung counted from β = 1, with β = 0 always kept.
pub(crate) fn hermite_with_error(betas: &[f64], f: &[f64], fp: &[f64]) -> (f64, f64, f64) {
    let (trap, fine) = hermite_integral(betas, f, fp);
    let n = betas.len();
    let mut idx: Vec<usize> = (0..n).rev().step_by(2).collect();
    if *idx.last().unwrap() != 0 {
        idx.push(0);
    }
    idx.reverse();
    let pick = |v: &[f64]| idx.iter().map(|&i| v[i]).collect::<Vec<f64>>();
    let (_, coarse) = hermite_integral(&pick(betas), &pick(f), &pick(fp));
    (fine, (fine - coarse).abs() / 15.0, trap)
}

/// Thermodynamic integration over the post-burn-in series (or why it does not apply).
pub(crate) fn thermodynamic(
    betas: &[f64],
    mean: &[f64],
    var: &[f64],
    series: &[f64],
    batch: usize,
) -> Result<ThermodynamicEstimate, String> {
    if let Some(i) = mean.iter().position(|m| !m.is_finite()) {
        return Err(format!(
            "E[ln L] at β = {} is not finite: the rung drew points where L = 0 (or ln L is not a number), so ∫ E_β[ln L] dβ diverges at that rung; use the stepping-stone estimate, or restrict the prior to where the likelihood is positive",
            betas[i]
        ));
    }
    let n_t = betas.len();
    let n = series.len() / n_t;
    let (ln_z, disc, trap) = hermite_with_error(betas, mean, var);
    let h = |i: usize| {
        if i + 1 < n_t {
            betas[i + 1] - betas[i]
        } else {
            0.0
        }
    };
    let w: Vec<f64> = (0..n_t)
        .map(|i| (h(i) + if i > 0 { h(i - 1) } else { 0.0 }) / 2.0)
        .collect();
    let c: Vec<f64> = (0..n_t)
        .map(|i| (h(i).powi(2) - if i > 0 { h(i - 1).powi(2) } else { 0.0 }) / 12.0)
        .collect();
    let v = batch_means_var(
        |t| {
            let row = &series[t * n_t..(t + 1) * n_t];
            (0..n_t)
                .map(|i| w[i] * (row[i] - mean[i]) + c[i] * ((row[i] - mean[i]).powi(2) - var[i]))
                .sum()
        },
        n,
        batch,
    );
    Ok(ThermodynamicEstimate {
        ln_z,
        std_err: v.sqrt(),
        discretisation_err: disc,
        ln_z_trapezoid: trap,
    })
}

/// The stepping-stone estimate over the post-burn-in series (or why it does not apply).
pub(crate) fn stepping_stone(
    betas: &[f64],
    series: &[f64],
    batch: usize,
) -> Result<SteppingStoneEstimate, String> {
    let n_t = betas.len();
    let n = series.len() / n_t;
    let mut ln_r = Vec::with_capacity(n_t - 1);
    for i in 0..n_t - 1 {
        let dbeta = betas[i + 1] - betas[i];
        let lse = (0..n)
            .map(|t| dbeta * series[t * n_t + i])
            .fold(f64::NEG_INFINITY, log_add_exp);
        let r = lse - (n as f64).ln();
        if !r.is_finite() {
            return Err(format!(
                "every sample of the rung at β = {} has L = 0 (or ln L is not finite), so the stepping-stone ratio to β = {} is undefined; start the chain in the likelihood's support",
                betas[i],
                betas[i + 1]
            ));
        }
        ln_r.push(r);
    }
    let v = batch_means_var(
        |t| {
            (0..n_t - 1)
                .map(|i| {
                    let x = (betas[i + 1] - betas[i]) * series[t * n_t + i];
                    (x - ln_r[i]).exp() - 1.0
                })
                .sum()
        },
        n,
        batch,
    );
    Ok(SteppingStoneEstimate {
        ln_z: ln_r.iter().sum(),
        std_err: v.sqrt(),
    })
}
