//! One model's evidence by bridge sampling between its posterior draws and a Gaussian fitted
//! to them (Meng & Wong 1996, in the form of Gronau et al. 2017), with the error of
//! Frühwirth-Schnatter (2004).
//!
//! # Why this estimator
//! Both of its averages have bounded terms, whatever the posterior's shape. With `p = Lπ` and
//! a normalised `g`, the optimal bridge `h = 1/(s₁ Z g + s₂ p)` gives
//! ```text
//! Z = E_g[p h] / E_post[g h],   p h ≤ 1/s₂ at the draws from g,   g h ≤ 1/(s₁ Z) at the posterior draws,
//! ```
//! so both means have a variance, and the error the draws estimate holds. The reciprocal
//! identity `1/Z = E_post[g/p]`, which the reversible-jump rows fall back on when a model is
//! never visited, has terms that are unbounded where the posterior is lighter-tailed than `g`
//! in some direction: on skewed posteriors they have no variance, and the error estimated from
//! the draws falls short however long the run (the estimators reference shows it on
//! `examples/accel-asymmetry.toml`: misses of up to 4.3 stated σ against importance sampling).
//!
//! # Procedure
//! 1. The first half of every chain fixes `g = N(μ, Σ)`, the mean and covariance of those
//!    draws; the second halves are the posterior draws of the bridge (reusing the draws that
//!    fitted `g` would bias it by an amount its error does not show).
//! 2. As many draws from `g` as there are posterior draws, from the given seed (drawn before any
//!    evaluation, so the result does not depend on the number of threads); `p` is evaluated at
//!    each (in parallel). Draws outside the prior box have `p = 0` and stay in the average:
//!    `Z` is the integral over the box.
//! 3. The optimal bridge's fixed point (`s_i` the two draw fractions).
//! 4. The relative error of `Ẑ`, which is the standard error of `ln Ẑ`:
//!    ```text
//!    RE² = V_g[p h]/(N₂ E_g[p h]²) + τ · V_post[g h]/(N₁ E_post[g h]²),
//!    ```
//!    with `τ = N₁/ESS` the integrated autocorrelation time of the posterior-side terms along
//!    the chains (split-chain ESS of [`crate::sampler::ess`]): correlated draws, a chain that
//!    barely moves, few distinct samples all make the error grow.
//!
//! ```
//! use occam::density::LogDensity;
//! use occam::evidence::bridge_sampling::{PosteriorDraws, bridge_sampling};
//! use occam::prior::{Prior, PriorKind};
//! use rand::SeedableRng;
//! use rand_distr::{Distribution, StandardNormal};
//!
//! /// ln L = −x²/2 on a uniform prior over [−10, 10]: Z = √(2π)/20.
//! struct Gauss(Prior);
//! impl LogDensity for Gauss {
//!     fn ln_likelihood(&self, th: &[f64]) -> f64 { -0.5 * th[0] * th[0] }
//!     fn prior(&self) -> &Prior { &self.0 }
//! }
//! let t = Gauss(Prior::new(vec!["x".into()], vec![PriorKind::Uniform { lo: -10.0, hi: 10.0 }]).unwrap());
//! let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(1);
//! let x: Vec<f64> = (0..4000).map(|_| StandardNormal.sample(&mut rng)).collect();
//! let lp: Vec<f64> = x.iter().map(|&v| t.ln_posterior(&[v])).collect();
//! let draws = [PosteriorDraws { samples: &x[..2000], ln_posterior: &lp[..2000] },
//!              PosteriorDraws { samples: &x[2000..], ln_posterior: &lp[2000..] }];
//! let b = bridge_sampling(&t, &draws, 7).unwrap();
//! let exact = (2.0 * std::f64::consts::PI).sqrt().ln() - 20f64.ln();
//! assert!((b.ln_z - exact).abs() < 4.0 * b.std_err, "{} ± {}", b.ln_z, b.std_err);
//! assert!(b.std_err < 0.02);
//! ```

use super::error::EvidenceError;
use crate::density::LogDensity;
use crate::linalg::{SpdOptions, forward_solve_norm2};
use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;

/// One chain's posterior draws.
#[derive(Debug, Clone, Copy)]
pub struct PosteriorDraws<'a> {
    /// Row-major `n × d` draws, in chain order.
    pub samples: &'a [f64],
    /// `ln L + ln π` of each draw, on the density the bridge evaluates at the draws from `g`.
    pub ln_posterior: &'a [f64],
}

/// A bridge-sampling `ln Z` and what it rests on.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BridgeSamplingEstimate {
    pub ln_z: f64,
    /// Standard error of `ln Z` (see the module docs).
    pub std_err: f64,
    /// Posterior draws in the bridge (the second halves of the chains).
    pub posterior_draws: usize,
    /// Their effective number for the posterior-side terms.
    pub posterior_ess: f64,
    /// Draws from the fitted Gaussian, and the share of them inside the prior box.
    pub proposal_draws: usize,
    pub proposal_in_box: f64,
}

/// Fewest draws per chain: each half needs 4 for the split-chain ESS.
pub const MIN_DRAWS_PER_CHAIN: usize = 8;

/// `ln Z` of `target` by bridge sampling from the posterior draws of its chains (every chain
/// with the same number of draws, at least [`MIN_DRAWS_PER_CHAIN`]); the draws from the fitted
/// Gaussian come from `seed`. Errors say why there is no number: too few draws, a
/// non-finite `ln π + ln L` at a posterior draw, a covariance that is singular (a parameter
/// that never moved), a fixed point that does not converge.
pub fn bridge_sampling(
    target: &dyn LogDensity,
    chains: &[PosteriorDraws<'_>],
    seed: u64,
) -> Result<BridgeSamplingEstimate, EvidenceError> {
    let d = target.dim();
    let n = check(chains, d)?;
    let half = n / 2;
    // rows of the first halves fit g, rows of the second halves are the posterior draws
    let fit: Vec<&[f64]> = chains
        .iter()
        .flat_map(|c| c.samples[..half * d].chunks(d))
        .collect();
    if let Some(i) = (0..d).find(|&i| fit.iter().all(|r| r[i] == fit[0][i])) {
        return Err(EvidenceError::SingularCovariance {
            what: "bridge sampling: the chains' first halves".into(),
            detail: format!(
                "`{}` never moved from {}",
                target.param_names()[i],
                fit[0][i]
            ),
        });
    }
    let (mu, l) = gaussian(&fit, d)?;
    let ln_norm = -0.5 * d as f64 * (2.0 * std::f64::consts::PI).ln()
        - (0..d).map(|i| l[i * d + i].ln()).sum::<f64>();
    let ln_g = |theta: &[f64], buf: &mut [f64]| {
        for ((b, t), m) in buf.iter_mut().zip(theta).zip(&mu) {
            *b = t - m;
        }
        ln_norm - 0.5 * forward_solve_norm2(&l, d, buf)
    };
    let mut buf = vec![0.0; d];
    // ln(p/g) at the posterior draws, per chain
    let post: Vec<Vec<f64>> = chains
        .iter()
        .map(|c| {
            c.samples[half * d..n * d]
                .chunks(d)
                .zip(&c.ln_posterior[half..n])
                .map(|(th, lp)| lp - ln_g(th, &mut buf))
                .collect()
        })
        .collect();
    let n1 = post.iter().map(Vec::len).sum::<usize>();
    // draws from g, all drawn before any is evaluated
    let mut rng = crate::sampler::chain_rng(seed, 0);
    let mut phi = vec![0.0; n1 * d];
    let mut ln_g_phi = vec![0.0; n1];
    for (row, lg) in phi.chunks_mut(d).zip(ln_g_phi.iter_mut()) {
        let z: Vec<f64> = (0..d).map(|_| StandardNormal.sample(&mut rng)).collect();
        for (i, r) in row.iter_mut().enumerate() {
            *r = mu[i] + (0..=i).map(|j| l[i * d + j] * z[j]).sum::<f64>();
        }
        *lg = ln_norm - 0.5 * z.iter().map(|v| v * v).sum::<f64>();
    }
    // ln(p/g) at the draws from g; outside the box, or where ln L is not finite, p = 0
    let evaluated: Vec<(f64, bool)> = phi
        .par_chunks(d)
        .zip(ln_g_phi.par_iter())
        .map(|(th, lg)| {
            if target.prior().ln_pdf(th) == f64::NEG_INFINITY {
                return (f64::NEG_INFINITY, false);
            }
            let lp = target.ln_posterior(th);
            (
                if lp.is_finite() {
                    lp - lg
                } else {
                    f64::NEG_INFINITY
                },
                true,
            )
        })
        .collect();
    let in_box = evaluated.iter().filter(|v| v.1).count();
    let prop: Vec<f64> = evaluated.iter().map(|v| v.0).collect();
    if prop.iter().all(|v| !v.is_finite()) {
        return Err(EvidenceError::option(
            "bridge sampling",
            format!("{n1} draws from the fitted Gaussian"),
            &format!(
                "none has a positive density ({} outside the prior box, {} with ln L not finite)",
                n1 - in_box,
                in_box
            ),
        ));
    }
    // the fixed point converges to an absolute 1e-10, finer than the spacing of doubles near
    // an LTP ln Z (~2.5e6): it runs on the values less their mean
    let y: Vec<f64> = post.iter().flatten().copied().collect();
    let shift = y.iter().sum::<f64>() / y.len() as f64;
    let less = |v: &[f64]| v.iter().map(|l| l - shift).collect::<Vec<f64>>();
    let ln_z = super::rjmcmc::fixed_point(&less(&prop), &less(&y))
        .filter(|v| v.is_finite())
        .ok_or_else(|| {
            EvidenceError::option(
                "bridge sampling",
                "the optimal bridge's fixed point",
                "it did not converge: the fitted Gaussian and the posterior hardly overlap",
            )
        })?
        + shift;
    let std_err = relative_error(&prop, &post, ln_z)?;
    Ok(BridgeSamplingEstimate {
        ln_z,
        std_err: std_err.0,
        posterior_draws: n1,
        posterior_ess: std_err.1,
        proposal_draws: n1,
        proposal_in_box: in_box as f64 / n1 as f64,
    })
}

/// The chains' common length, after checking them.
fn check(chains: &[PosteriorDraws<'_>], d: usize) -> Result<usize, EvidenceError> {
    if d == 0 {
        return Err(EvidenceError::option(
            "bridge sampling",
            "0 parameters",
            "a model without free parameters has Z = L; nothing to sample",
        ));
    }
    let n = chains.first().map_or(0, |c| c.ln_posterior.len());
    for (i, c) in chains.iter().enumerate() {
        if c.ln_posterior.len() != n {
            return Err(EvidenceError::dimension(
                format!("chain {i}'s draws"),
                n,
                c.ln_posterior.len(),
            ));
        }
        if c.samples.len() != n * d {
            return Err(EvidenceError::dimension(
                format!("chain {i}'s samples"),
                n * d,
                c.samples.len(),
            ));
        }
        if let Some(v) = c.ln_posterior.iter().find(|v| !v.is_finite()) {
            return Err(EvidenceError::non_finite(
                format!("ln π + ln L of a posterior draw of chain {i}"),
                *v,
                "posterior draws must lie where the density is positive",
            ));
        }
    }
    if n < MIN_DRAWS_PER_CHAIN {
        return Err(EvidenceError::TooFewSamples {
            what: "bridge sampling".into(),
            n: n * chains.len(),
            dim: d,
            min: MIN_DRAWS_PER_CHAIN * chains.len().max(1),
        });
    }
    Ok(n)
}

/// Mean and row-major lower Cholesky factor of the covariance of `rows`.
fn gaussian(rows: &[&[f64]], d: usize) -> Result<(Vec<f64>, Vec<f64>), EvidenceError> {
    let m = rows.len() as f64;
    let mut mu = vec![0.0; d];
    for r in rows {
        for (a, b) in mu.iter_mut().zip(*r) {
            *a += b / m;
        }
    }
    let mut cov = nalgebra::DMatrix::<f64>::zeros(d, d);
    for r in rows {
        for i in 0..d {
            for j in 0..=i {
                cov[(i, j)] += (r[i] - mu[i]) * (r[j] - mu[j]) / (m - 1.0);
            }
        }
    }
    let spd = SpdOptions::lower().jacobi().factor(&cov).map_err(|e| {
        EvidenceError::SingularCovariance {
            what: "bridge sampling: the covariance of the chains' first halves".into(),
            detail: e.to_string(),
        }
    })?;
    Ok((mu, spd.l_row_major()))
}

/// Standard error of `ln Ẑ` (module docs, step 4) and the posterior side's ESS.
fn relative_error(prop: &[f64], post: &[Vec<f64>], ln_z: f64) -> Result<(f64, f64), EvidenceError> {
    let (n2, n1) = (
        prop.len() as f64,
        post.iter().map(Vec::len).sum::<usize>() as f64,
    );
    let (s1, s2) = (n2 / (n1 + n2), n1 / (n1 + n2));
    // both terms scaled to be bounded: p h ∝ 1/(s₁ e^{−(l − ln Z)} + s₂) at the g draws,
    // g h ∝ 1/(s₁ + s₂ e^{l − ln Z}) at the posterior draws
    let a: Vec<f64> = prop
        .iter()
        .map(|&l| 1.0 / (s1 * (ln_z - l).exp() + s2))
        .collect();
    let b: Vec<Vec<f64>> = post
        .iter()
        .map(|c| {
            c.iter()
                .map(|&l| 1.0 / (s1 + s2 * (l - ln_z).exp()))
                .collect()
        })
        .collect();
    let rel_var = |v: &mut dyn Iterator<Item = f64>| {
        let (mut k, mut s, mut s2) = (0.0, 0.0, 0.0);
        for x in v {
            k += 1.0;
            s += x;
            s2 += x * x;
        }
        let mean = s / k;
        ((s2 / k - mean * mean).max(0.0) * k / (k - 1.0)) / (mean * mean)
    };
    let va = rel_var(&mut a.iter().copied());
    let vb = rel_var(&mut b.iter().flatten().copied());
    let series: Vec<&[f64]> = b.iter().map(Vec::as_slice).collect();
    let ess = if vb > 0.0 {
        crate::sampler::ess(&series)
            .map_err(|e| EvidenceError::option("bridge sampling", "ESS", &e.to_string()))?
            .clamp(1.0, n1)
    } else {
        n1
    };
    Ok(((va / n2 + vb / ess).sqrt(), ess))
}

#[cfg(test)]
mod tests;
