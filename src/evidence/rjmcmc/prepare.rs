//! Per-model constants of the jump proposals: Cholesky factors, normalisers and the box masses.

use std::f64::consts::PI;

use nalgebra::DMatrix;
use rand::SeedableRng;
use rand_distr::{ChiSquared, Distribution, StandardNormal};
use rand_xoshiro::Xoshiro256PlusPlus;
use statrs::function::gamma::ln_gamma;

use super::logsum::lae;
use super::options::{ProposalShape, RjModel, RjOptions};
use crate::density::LogDensity;
use crate::evidence::error::EvidenceError;
use crate::evidence::mvn::mvn_rectangle;
use crate::linalg::{SpdOptions, forward_solve_norm2};

/// Per-model constants.
pub(crate) struct Prepared<'a> {
    pub target: &'a dyn LogDensity,
    pub dim: usize,
    pub center: Vec<f64>,
    /// Row-major Cholesky factor of `c²Σ`.
    pub lq: Vec<f64>,
    /// Normalising constant of `ln q` (everything but the quadratic form).
    pub ln_q_norm: f64,
    /// Row-major Cholesky factor of `s²Σ`.
    pub lrw: Vec<f64>,
}

impl Prepared<'_> {
    /// `ln g(θ)` of the Gaussian/t part; `buf` is scratch of length ≥ dim.
    pub fn ln_q(&self, theta: &[f64], shape: ProposalShape, buf: &mut [f64]) -> f64 {
        let d = self.dim;
        for ((b, t), c) in buf[..d].iter_mut().zip(theta).zip(&self.center) {
            *b = t - c;
        }
        let m2 = forward_solve_norm2(&self.lq, d, &mut buf[..d]);
        match shape {
            ProposalShape::Gaussian => self.ln_q_norm - 0.5 * m2,
            ProposalShape::StudentT { nu } => {
                self.ln_q_norm - 0.5 * (nu + d as f64) * (m2 / nu).ln_1p()
            }
        }
    }
}

pub(crate) fn prepare<'a>(
    models: &[RjModel<'a>],
    opts: &RjOptions,
) -> Result<Vec<Prepared<'a>>, EvidenceError> {
    let c2 = opts.jump_scale * opts.jump_scale;
    models
        .iter()
        .map(|m| {
            let d = m.target.dim();
            if d == 0 {
                return Ok(Prepared {
                    target: m.target,
                    dim: 0,
                    center: vec![],
                    lq: vec![],
                    ln_q_norm: 0.0,
                    lrw: vec![],
                });
            }
            let chol = SpdOptions::default()
                .names(m.target.prior().names())
                .factor(&m.cov)
                .map_err(EvidenceError::matrix(
                    format!("proposal covariance of model `{}`", m.name),
                    "pass the inverse Fisher matrix or another positive-definite posterior covariance",
                ))?;
            let l = chol.l_row_major();
            let ln_det_sigma = chol.ln_det();
            let ln_det_q = ln_det_sigma + d as f64 * c2.ln();
            let df = d as f64;
            let ln_q_norm = match opts.proposal {
                ProposalShape::Gaussian => -0.5 * df * (2.0 * PI).ln() - 0.5 * ln_det_q,
                ProposalShape::StudentT { nu } => {
                    ln_gamma(0.5 * (nu + df))
                        - ln_gamma(0.5 * nu)
                        - 0.5 * df * (nu * PI).ln()
                        - 0.5 * ln_det_q
                }
            };
            let s = opts.rw_scale.unwrap_or(2.38 / df.sqrt());
            Ok(Prepared {
                target: m.target,
                dim: d,
                center: m.center.clone(),
                lq: l.iter().map(|v| v * opts.jump_scale).collect(),
                ln_q_norm,
                lrw: l.iter().map(|v| v * s).collect(),
            })
        })
        .collect()
}

/// `ln P_k(box)` of each jump proposal and its standard error.
/// Box masses of the jump proposals: the mixture's and the Gaussian/t part's, with errors.
pub(crate) struct BoxMasses {
    pub(crate) ln_p: Vec<f64>,
    pub(crate) se: Vec<f64>,
    pub(crate) ln_p_g: Vec<f64>,
    pub(crate) se_g: Vec<f64>,
}

pub(crate) fn box_masses(
    prepared: &[Prepared<'_>],
    opts: &RjOptions,
) -> Result<BoxMasses, EvidenceError> {
    let mut out = BoxMasses {
        ln_p: Vec::with_capacity(prepared.len()),
        se: Vec::with_capacity(prepared.len()),
        ln_p_g: Vec::with_capacity(prepared.len()),
        se_g: Vec::with_capacity(prepared.len()),
    };
    let mut push = |ln_pg: f64, se_g: f64| {
        let (lp, s) = defensive_mass(ln_pg, se_g, opts.defensive);
        out.ln_p.push(lp);
        out.se.push(s);
        out.ln_p_g.push(ln_pg);
        out.se_g.push(se_g);
    };
    let mut mc_rng = Xoshiro256PlusPlus::seed_from_u64(opts.seed);
    mc_rng.long_jump();
    for m in prepared {
        let d = m.dim;
        let kinds = m.target.prior().kinds();
        let bounded: Vec<usize> = (0..d)
            .filter(|&i| {
                let (lo, hi) = kinds[i].bounds();
                lo.is_finite() || hi.is_finite()
            })
            .collect();
        if bounded.is_empty() {
            push(0.0, 0.0);
            continue;
        }
        match opts.proposal {
            ProposalShape::Gaussian => {
                let mut cov = DMatrix::zeros(d, d);
                for i in 0..d {
                    for j in 0..=i {
                        cov[(i, j)] = (0..=j).map(|r| m.lq[i * d + r] * m.lq[j * d + r]).sum();
                        cov[(j, i)] = cov[(i, j)];
                    }
                }
                let sub = cov.select_rows(&bounded).select_columns(&bounded);
                let lo: Vec<f64> = bounded.iter().map(|&i| kinds[i].bounds().0).collect();
                let hi: Vec<f64> = bounded.iter().map(|&i| kinds[i].bounds().1).collect();
                let mean: Vec<f64> = bounded.iter().map(|&i| m.center[i]).collect();
                let p = mvn_rectangle(&lo, &hi, &mean, &sub, &opts.box_mass)?;
                push(p.ln_p, p.ln_p_std_err);
            }
            ProposalShape::StudentT { nu } => {
                let n = 1usize << 16;
                let chi2 = ChiSquared::new(nu).map_err(|_| {
                    EvidenceError::option("proposal nu", nu, "ν must be finite and > 0")
                })?;
                let mut x = vec![0.0; d];
                let mut z = vec![0.0; d];
                let mut hits = 0usize;
                for _ in 0..n {
                    for zi in z.iter_mut() {
                        *zi = StandardNormal.sample(&mut mc_rng);
                    }
                    let s = (nu / chi2.sample(&mut mc_rng)).sqrt();
                    for (i, xi) in x.iter_mut().enumerate() {
                        let row = &m.lq[i * d..i * d + i + 1];
                        *xi = m.center[i] + s * row.iter().zip(&z).map(|(a, b)| a * b).sum::<f64>();
                    }
                    if m.target.prior().contains(&x) {
                        hits += 1;
                    }
                }
                let p = hits as f64 / n as f64;
                let s = if hits > 0 {
                    ((1.0 - p) / (p * n as f64)).sqrt()
                } else {
                    f64::INFINITY
                };
                push(p.ln(), s);
            }
        }
    }
    Ok(out)
}

/// `ln[(1 − w)·P_g + w]` and its error from `ln P_g ± se`: the mixture's box mass (the prior
/// part has mass 1 in its own support). With `w = 0` the inputs are returned unchanged.
fn defensive_mass(ln_pg: f64, se: f64, w: f64) -> (f64, f64) {
    if w == 0.0 {
        return (ln_pg, se);
    }
    let a = (1.0 - w).ln() + ln_pg;
    let ln_p = lae(a, w.ln());
    // d ln P / d ln P_g = (1 − w)P_g / P
    let s = if se.is_finite() {
        (a - ln_p).exp() * se
    } else {
        // no Gaussian mass measured: P ∈ [w, 1]
        0.5 * (-w.ln())
    };
    (ln_p, s)
}
