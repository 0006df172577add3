//! Maximum-likelihood / MAP search for any model by Fisher scoring (Gauss–Newton).
//!
//! The template is smooth and the posterior close to Gaussian, so Newton steps with the
//! Fisher matrix as the Hessian converge in a few iterations from anywhere the linearisation
//! holds. Nelder–Mead ([`crate::sampler::find_map`]) is the derivative-free alternative for
//! other models.
//!
//! # The bounded search (projected Newton with an active set)
//! At low SNR the posterior fills its prior box and the maximum of `ln L + ln π` often sits on
//! a face or a corner of the box. Each iteration:
//! 1. gradient `g` of `ln L + ln π` and Fisher matrix `F` (plus the curvature of a Gaussian
//!    prior) over the free parameters;
//! 2. *active set*: the parameters on a bound whose gradient points out of the box; they stay
//!    put (the Karush–Kuhn–Tucker condition there is `g` pointing outward);
//! 3. Newton step `F_II⁻¹ g_I` over the inactive set `I`, projected onto the box, halved
//!    until `ln L + ln π` does not decrease; if no halving gives an ascent, a projected,
//!    diagonally scaled gradient step is tried the same way. No accepted step ever decreases
//!    `ln L + ln π`. When a shortened step undoes the previous shortened one (the scoring
//!    matrix far below the curvature along it), the step goes to the vertex of the parabola
//!    through the three points of its line search instead (`Problem::vertex`).
//!
//! **Convergence**: every inactive parameter's Newton step is below `tol` Cramér–Rao σ of
//! the inactive block (`√diag(F_II⁻¹)`), and every active parameter's gradient points out of
//! the box; or every free parameter is active (a vertex satisfying the KKT condition); or no
//! step along the Newton or the gradient direction increases `ln L + ln π` (or only one that
//! leaves it as it was) and every Newton step is below [`NONSMOOTH`] × `tol`, for a model
//! whose `ln L` has kinks (one carrying modelled glitches). That is a maximum on a kink, where
//! the one-sided gradient does not vanish and no Newton step gets small: a modelled glitch's
//! start time enters its sampled template through the first sample after it, so `ln L` has a
//! kink at every sample time (`model::glitch_response`). At 1 Hz the kinks lie about a
//! Cramér–Rao σ of the start apart: on realisation 3023 of `examples/glitches-short.toml` the
//! search sat at `g2_t0` = 13 188 s exactly, the Newton step 0.033 σ every iteration with
//! `ln L` unchanged, and ran out of iterations. Smooth models keep the first two rules only
//! (taken for all, the third changed eight of the 29 CI goldens, MAPs in their last digits).
//!
//! # The unbounded search
//! Without the box, the same iteration looks for the maximum of `ln L` (plus the Gaussian
//! terms of the prior), the expansion point of the box-corrected Laplace–Fisher estimate.
//! When the likelihood has no maximum near the box (a direction along which `ln L` keeps
//! rising towards a plateau, as at low SNR) the iterates run away. The search stops with
//! [`MapError::Diverged`] when a parameter leaves the box by more than
//! [`RUNAWAY_WIDTHS`] box widths (or, for a Gaussian prior, that many prior σ), when
//! `ln L`, its gradient or its Fisher matrix turns non-finite, or when the iteration neither
//! increases `ln L` nor converges.

use super::exact::Likelihood;
use super::fisher::gradient_and_fisher;
use crate::density::LogDensity;
use crate::linalg::SpdOptions;
use crate::prior::PriorKind;
use nalgebra::{DMatrix, DVector};

/// How far (in prior widths beyond the box, or prior σ around a Gaussian prior's mean) the
/// unbounded search may wander before it is declared divergent. The box-corrected Laplace
/// estimate uses the quadratic expansion of `ln L` at the unbounded maximum across the whole
/// box; from more than a few widths away that is an extrapolation the Fisher matrix does not
/// support. Measured on the guidance-delay study (`examples/bounds_low_snr.rs`): at ρ = 60
/// model X's unbounded maximum has `a_df` 8 widths and `dt1` 2.4 widths beyond the box; at
/// ρ = 5 model Y's has `d21` 4.8 widths beyond; at ρ = 450 it is inside the box.
pub const RUNAWAY_WIDTHS: f64 = 3.0;

/// How many times `tol` a Newton step may be where no step ascends and the search still counts
/// as converged (module docs: a maximum on a kink of `ln L`). Ten: 0.1σ at the glitch models'
/// tolerance (`model::map_tolerance`), three times the 0.033σ step measured at a kink.
pub const NONSMOOTH: f64 = 10.0;

/// Result of [`fisher_scoring`].
#[derive(Debug, Clone, PartialEq)]
pub struct ScoringResult {
    /// The maximum found (full parameter vector; fixed parameters unchanged).
    pub theta: Vec<f64>,
    /// `ln L + ln π` there.
    pub ln_posterior: f64,
    pub iterations: usize,
    /// Whether the convergence criterion of the module documentation was met.
    pub converged: bool,
    /// Per free parameter (in the order of `free`): whether it sits on a bound of its prior
    /// at the result. Always `false` for the unbounded search.
    pub at_bound: Vec<bool>,
}

impl ScoringResult {
    /// Names of the free parameters on a bound of the prior box.
    pub fn bound_names(&self, names: &[String], free: &[usize]) -> Vec<String> {
        free.iter()
            .zip(&self.at_bound)
            .filter(|(_, b)| **b)
            .map(|(&i, _)| names[i].clone())
            .collect()
    }

    /// Each free parameter on a bound of its prior box: which bound, its value, and the
    /// `[prior]` entry that widens it, e.g. `` `a1` = 1.3 on the upper bound (hi = 1.3 of
    /// [prior] a1 = { kind = "uniform", lo = 0.8, hi = 1.3 }: raise hi) ``; with `true` where
    /// that bound is the parameter's physical limit (`limits`, from
    /// [`crate::model::Model::physical_limits`]; the text then says so, with no remedy).
    pub fn bound_report(
        &self,
        names: &[String],
        kinds: &[PriorKind],
        free: &[usize],
        limits: &[[Option<f64>; 2]],
    ) -> Vec<(String, bool)> {
        free.iter()
            .zip(&self.at_bound)
            .filter(|(_, b)| **b)
            .map(|(&i, _)| {
                let limit = limits.get(i).copied().unwrap_or([None, None]);
                describe_bound(&names[i], &kinds[i], self.theta[i], limit)
            })
            .collect()
    }
}

/// `` `name` = v on the lower bound (lo = … of [prior] name = {…}: lower lo) ``, and whether
/// that bound is the parameter's physical limit (`limit`, `[lower, upper]`): then
/// `` `name` = 0 is at its physical limit, the lower bound (lo = 0 of [prior] name = {…}) ``.
pub fn describe_bound(
    name: &str,
    kind: &PriorKind,
    value: f64,
    limit: [Option<f64>; 2],
) -> (String, bool) {
    use crate::numfmt::fmt_roundtrip as r;
    let (lo, hi) = kind.bounds();
    let upper = (value - hi).abs() <= (value - lo).abs();
    let (side, key, verb) = if upper {
        ("upper", "hi", "raise")
    } else {
        ("lower", "lo", "lower")
    };
    let bound = if upper { hi } else { lo };
    let entry = kind.entry();
    if limit[usize::from(upper)] == Some(bound) {
        return (
            format!(
                "`{name}` = {} is at its physical limit, the {side} bound ({key} = {} of [prior] {name} = {entry})",
                r(value),
                r(bound)
            ),
            true,
        );
    }
    (
        format!(
            "`{name}` = {} is on the {side} bound ({key} = {} of [prior] {name} = {entry}: {verb} {key} if the bound is not physical)",
            r(value),
            r(bound)
        ),
        false,
    )
}

/// Errors of the MAP search.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum MapError {
    #[error("MAP search: the start point is outside the prior (parameter `{0}`)")]
    StartOutsidePrior(String),
    /// The start lies inside the prior but `ln L` is not finite there (an unstable loop, a
    /// delay through zero): what the model's check says.
    #[error(
        "MAP search: the likelihood cannot be evaluated at the start point, which lies inside the prior: {0}; start where the model is stable ([fit] start, the [truth], or priors centred on a working system)"
    )]
    StartNotEvaluable(String),
    /// The scoring matrix of the free parameters off their bounds is singular;
    /// `unconstrained` names the parameters along its null directions
    /// ([`super::fisher::describe_unconstrained`]), `detail` says how.
    #[error(
        "MAP search: the Fisher matrix is singular: {detail}; fix {} (`fixed` of [fit] or of the [[select.model]]) or add an experiment that excites {}",
        if unconstrained.len() == 1 { "it" } else { "them" },
        if unconstrained.len() == 1 { "it" } else { "them" }
    )]
    Singular {
        unconstrained: Vec<String>,
        detail: String,
    },
    #[error(
        "MAP search: {what} is not finite at θ = {theta:?} (parameters {params:?}); the model cannot be evaluated there — narrow the prior or start elsewhere"
    )]
    NonFinite {
        what: String,
        params: Vec<String>,
        theta: Vec<f64>,
    },
    #[error(
        "unbounded MAP search diverged after {iterations} iterations: {detail}; parameters that ran away: {params:?}. The likelihood has no maximum near the prior box along them (the posterior is bounded by the prior, not the data), so the box-corrected Laplace–Fisher estimate does not apply; use the sampled estimators"
    )]
    Diverged {
        params: Vec<String>,
        detail: String,
        iterations: usize,
    },
}

/// Fisher scoring over the parameters `free`, from `start`, until the convergence criterion
/// (module documentation; `tol` in Cramér–Rao σ) holds or `max_iter` iterations. The search
/// is projected onto the prior box, so the result is the MAP, possibly on a face or a corner
/// of the box ([`ScoringResult::at_bound`]).
pub fn fisher_scoring(
    lik: &Likelihood,
    start: &[f64],
    free: &[usize],
    tol: f64,
    max_iter: usize,
) -> Result<ScoringResult, MapError> {
    scoring(lik, start, free, tol, max_iter, true)
}

/// As [`fisher_scoring`] but without the prior box: the maximum of `ln L` (plus the prior's
/// Gaussian terms) where the likelihood is defined beyond the box, e.g. at negative delays.
/// This is the expansion point of the box-corrected Laplace estimate (ltp-model.md §9.3).
/// Returns [`MapError::Diverged`] when there is no such maximum near the box, or when the
/// search does not converge within `max_iter` iterations.
pub fn fisher_scoring_unbounded(
    lik: &Likelihood,
    start: &[f64],
    free: &[usize],
    tol: f64,
    max_iter: usize,
) -> Result<ScoringResult, MapError> {
    scoring(lik, start, free, tol, max_iter, false)
}

fn scoring(
    lik: &Likelihood,
    start: &[f64],
    free: &[usize],
    tol: f64,
    max_iter: usize,
    bounded: bool,
) -> Result<ScoringResult, MapError> {
    let names = lik.param_names();
    let kinds = lik.prior().kinds().to_vec();
    let full = |x: &[f64]| {
        let mut th = start.to_vec();
        for (&a, &v) in free.iter().zip(x) {
            th[a] = v;
        }
        th
    };
    let post = |x: &[f64]| {
        let th = full(x);
        // the Gaussian (Whittle) ln L whatever the statistic: the gradient and the scoring
        // matrix are of that ln L, and the line search must climb the same surface
        if bounded {
            let lp = lik.prior().ln_pdf(&th);
            if lp == f64::NEG_INFINITY {
                f64::NEG_INFINITY
            } else {
                lp + lik.ln_likelihood_whittle(&th)
            }
        } else {
            lik.ln_likelihood_whittle(&th) + lik.prior().ln_pdf_extended(&th).unwrap_or(f64::NAN)
        }
    };
    let grad_fisher = |x: &[f64]| {
        let th = full(x);
        let (mut g, mut f) = gradient_and_fisher(lik, &th, free);
        for (i, &a) in free.iter().enumerate() {
            let (dg, df) = prior_terms(&kinds[a], th[a]);
            g[i] += dg;
            f[(i, i)] += df;
        }
        (g, f)
    };
    if let Some(bad) = (0..start.len()).find(|&i| !start[i].is_finite()) {
        return Err(MapError::StartOutsidePrior(names[bad].clone()));
    }
    let lp0 = lik.ln_posterior(start);
    if bounded && lp0 == f64::NEG_INFINITY {
        // the prior names the parameter outside its box; else the likelihood is what failed
        // (it was blamed on the first parameter's prior)
        return Err(
            match (0..start.len()).find(|&i| !lik.prior().kinds()[i].ln_pdf(start[i]).is_finite()) {
                Some(bad) => MapError::StartOutsidePrior(names[bad].clone()),
                None => MapError::StartNotEvaluable(match lik.model().check(start) {
                    Err(why) => why,
                    Ok(()) => format!("ln L = {}", lik.ln_likelihood_whittle(start)),
                }),
            },
        );
    }
    let problem = Problem {
        names: free.iter().map(|&i| names[i].clone()).collect(),
        bounds: free.iter().map(|&i| kinds[i].bounds()).collect(),
        window: free.iter().map(|&i| runaway_window(&kinds[i])).collect(),
        bounded,
        tol,
        max_iter,
        kinked: crate::model::glitch::carries_glitches(lik.model().as_ref()),
    };
    let x0: Vec<f64> = free.iter().map(|&i| start[i]).collect();
    let r = problem.solve(&x0, &post, &grad_fisher)?;
    Ok(ScoringResult {
        theta: full(&r.x),
        ln_posterior: r.lp,
        iterations: r.iterations,
        converged: r.converged,
        at_bound: r.at_bound,
    })
}

/// The maximum of the statistic's `ln L + ln π` ([`Likelihood::ln_likelihood_full`]) near
/// `theta` (the Whittle MAP of [`fisher_scoring`]), with the observed information
/// `−∇² (ln L)` there (the prior's curvature is left to the caller, as for a Fisher matrix).
///
/// For a non-Whittle statistic the MAP search and the Fisher matrix are Gaussian: they find
/// the neighbourhood, and this Newton iteration with central-difference derivatives of the
/// actual `ln L` (steps `0.2 σ` of the Gaussian Cramér–Rao bound `sigma`, so the
/// quadratic model is sampled where it matters) moves to the statistic's own maximum inside
/// the prior box. Each step is halved until `ln L + ln π` increases; the search stops when a
/// step is below `10⁻³ σ` or after `max_iter` iterations. Returns `None` when `ln L` is not
/// finite at `theta`.
pub fn refine_statistic_max(
    lik: &Likelihood,
    theta: &[f64],
    free: &[usize],
    sigma: &[f64],
    max_iter: usize,
) -> Option<(Vec<f64>, f64, DMatrix<f64>)> {
    let kinds = lik.prior().kinds().to_vec();
    let d = free.len();
    let steps: Vec<f64> = sigma.iter().map(|s| 0.2 * s).collect();
    let lnl = |th: &[f64]| lik.ln_likelihood_full(th);
    let lpost = |th: &[f64]| lik.ln_posterior(th);
    let mut th = theta.to_vec();
    let mut lp = lpost(&th);
    if !lp.is_finite() {
        return None;
    }
    for _ in 0..max_iter {
        let (g, h) = super::fisher::gradient_hessian_numeric(&lnl, &th, free, &steps);
        let mut gi = DVector::from_vec(g);
        let mut info = -h;
        for (i, &a) in free.iter().enumerate() {
            let (dg, df) = prior_terms(&kinds[a], th[a]);
            gi[i] += dg;
            info[(i, i)] += df;
        }
        let Ok(chol) = SpdOptions::lower().factor(&info) else {
            break;
        };
        let step = chol.solve(&gi);
        let mut t = 1.0;
        let mut moved = false;
        for _ in 0..30 {
            let mut cand = th.clone();
            for (i, &a) in free.iter().enumerate() {
                let (lo, hi) = kinds[a].bounds();
                cand[a] = (th[a] + t * step[i]).clamp(lo, hi);
            }
            let lc = lpost(&cand);
            if lc.is_finite() && lc > lp {
                th = cand;
                lp = lc;
                moved = true;
                break;
            }
            t *= 0.5;
        }
        let small = (0..d).all(|i| (t * step[i]).abs() <= 1e-3 * sigma[i]);
        if !moved || small {
            break;
        }
    }
    let (_, h) = super::fisher::gradient_hessian_numeric(&lnl, &th, free, &steps);
    let l = lnl(&th);
    Some((th, l, -h))
}

/// Gradient and curvature (`−∂²`) of `ln π` of one parameter: the Gaussian's quadratic, the
/// log-uniform's `−ln x` (its negative curvature is left out so the scoring matrix stays
/// positive definite), nothing for a uniform box.
fn prior_terms(k: &PriorKind, x: f64) -> (f64, f64) {
    match *k {
        PriorKind::Uniform { .. } => (0.0, 0.0),
        PriorKind::Gaussian { mu, sigma } => (-(x - mu) / (sigma * sigma), 1.0 / (sigma * sigma)),
        PriorKind::LogUniform { .. } => (-1.0 / x, 0.0),
    }
}

/// Where the unbounded search may go: the box widened by [`RUNAWAY_WIDTHS`] widths on each
/// side, or [`RUNAWAY_WIDTHS`] prior σ around a Gaussian prior's mean.
fn runaway_window(k: &PriorKind) -> (f64, f64) {
    match *k {
        PriorKind::Uniform { lo, hi } | PriorKind::LogUniform { lo, hi } => {
            let w = RUNAWAY_WIDTHS * (hi - lo);
            (lo - w, hi + w)
        }
        PriorKind::Gaussian { mu, sigma } => {
            (mu - RUNAWAY_WIDTHS * sigma, mu + RUNAWAY_WIDTHS * sigma)
        }
    }
}

/// Gradient of `ln L + ln π` and the scoring matrix at a point of the free parameters.
type GradFisher<'a> = dyn Fn(&[f64]) -> (Vec<f64>, DMatrix<f64>) + 'a;

/// The optimisation problem over the free parameters, independent of the likelihood (so the
/// algorithm can be tested on analytic objectives).
struct Problem {
    names: Vec<String>,
    /// Prior supports (infinite for a Gaussian prior).
    bounds: Vec<(f64, f64)>,
    /// Runaway window per parameter ([`runaway_window`]).
    window: Vec<(f64, f64)>,
    bounded: bool,
    tol: f64,
    max_iter: usize,
    /// Whether `ln L` has kinks (module docs, convergence).
    kinked: bool,
}

#[derive(Debug)]
struct Solution {
    x: Vec<f64>,
    lp: f64,
    iterations: usize,
    converged: bool,
    at_bound: Vec<bool>,
}

impl Problem {
    fn clamp(&self, i: usize, v: f64) -> f64 {
        if self.bounded {
            v.clamp(self.bounds[i].0, self.bounds[i].1)
        } else {
            v
        }
    }

    fn on_lower(&self, i: usize, v: f64) -> bool {
        self.bounded && v <= self.bounds[i].0
    }

    fn on_upper(&self, i: usize, v: f64) -> bool {
        self.bounded && v >= self.bounds[i].1
    }

    /// The parameters outside the runaway window of the box.
    fn runaways(&self, x: &[f64]) -> Vec<usize> {
        (0..x.len())
            .filter(|&i| !(self.window[i].0..=self.window[i].1).contains(&x[i]))
            .collect()
    }

    fn diverged(&self, idx: &[usize], detail: String, iterations: usize) -> MapError {
        MapError::Diverged {
            params: idx.iter().map(|&i| self.names[i].clone()).collect(),
            detail,
            iterations,
        }
    }

    fn solve(
        &self,
        x0: &[f64],
        post: &dyn Fn(&[f64]) -> f64,
        grad_fisher: &GradFisher<'_>,
    ) -> Result<Solution, MapError> {
        let d = x0.len();
        let mut x = x0.to_vec();
        let mut lp = post(&x);
        if !lp.is_finite() {
            return Err(MapError::NonFinite {
                what: "ln L + ln π at the start".into(),
                params: self.names.clone(),
                theta: x,
            });
        }
        let mut converged = false;
        let mut it = 0;
        // the previous move, when its line search had to shorten the step
        let mut last_backtracked: Option<Vec<f64>> = None;
        while it < self.max_iter {
            it += 1;
            let (g, f) = grad_fisher(&x);
            let bad: Vec<usize> = (0..d)
                .filter(|&i| !g[i].is_finite() || (0..d).any(|j| !f[(i, j)].is_finite()))
                .collect();
            if !bad.is_empty() {
                return Err(MapError::NonFinite {
                    what: "the gradient or Fisher matrix of ln L".into(),
                    params: bad.iter().map(|&i| self.names[i].clone()).collect(),
                    theta: x,
                });
            }
            // active set: on a bound with the gradient pointing out of the box
            let inactive: Vec<usize> = (0..d)
                .filter(|&i| {
                    !((self.on_lower(i, x[i]) && g[i] <= 0.0)
                        || (self.on_upper(i, x[i]) && g[i] >= 0.0))
                })
                .collect();
            if inactive.is_empty() {
                converged = true;
                break;
            }
            let m = inactive.len();
            let fi = DMatrix::from_fn(m, m, |a, b| f[(inactive[a], inactive[b])]);
            let gi = DVector::from_fn(m, |a, _| g[inactive[a]]);
            let chol = SpdOptions::lower().factor(&fi).map_err(|_| {
                let names: Vec<String> = inactive.iter().map(|&i| self.names[i].clone()).collect();
                let (detail, unconstrained) = super::fisher::describe_unconstrained(&fi, &names);
                MapError::Singular {
                    unconstrained,
                    detail,
                }
            })?;
            let step = chol.solve(&gi);
            let cov = chol.inverse();
            let small = (0..m).all(|a| step[a].abs() <= self.tol * cov[(a, a)].sqrt());
            // Newton direction, then the scaled gradient as a fallback
            let newton: Vec<f64> = {
                let mut s = vec![0.0; d];
                for (a, &i) in inactive.iter().enumerate() {
                    s[i] = step[a];
                }
                s
            };
            let gradient: Vec<f64> = {
                let mut s = vec![0.0; d];
                for &i in &inactive {
                    s[i] = g[i] / f[(i, i)];
                }
                s
            };
            let mut accepted = None;
            for dir in [&newton, &gradient] {
                if let Some(r) = self.line_search(&x, lp, dir, post) {
                    accepted = Some((r, dir));
                    break;
                }
            }
            match accepted {
                Some((step, dir)) if !(self.kinked && step.lp <= lp) => {
                    let moved: Vec<f64> = (0..d).map(|i| step.x[i] - x[i]).collect();
                    // a shortened step that undoes the previous shortened one (their product
                    // in the scoring metric, diagonal part, is negative): the alternation of
                    // [`Problem::vertex`]
                    let reversed = step.t < 1.0
                        && last_backtracked.as_ref().is_some_and(|m| {
                            (0..d).map(|i| f[(i, i)] * m[i] * moved[i]).sum::<f64>() < 0.0
                        });
                    let (cand, lc) = match reversed.then(|| self.vertex(&x, lp, dir, &step, post)) {
                        Some(Some(v)) => v,
                        _ => (step.x.clone(), step.lp),
                    };
                    last_backtracked =
                        (step.t < 1.0).then(|| (0..d).map(|i| cand[i] - x[i]).collect());
                    x = cand;
                    lp = lc;
                }
                _ => {
                    // no ascent along either direction (with kinks, or only a step that leaves
                    // ln L + ln π as it was): stationary to working precision. Where ln L has a
                    // kink no Newton step need be small (module docs), so within NONSMOOTH × tol
                    converged = small
                        || (self.kinked
                            && (0..m).all(|a| {
                                step[a].abs() <= NONSMOOTH * self.tol * cov[(a, a)].sqrt()
                            }));
                    if !converged && !self.bounded {
                        return Err(self.diverged(
                            &inactive,
                            "no step increases ln L although the Newton step is not small (the Fisher matrix is a poor model of ln L there)".into(),
                            it,
                        ));
                    }
                    break;
                }
            }
            if !self.bounded {
                let run = self.runaways(&x);
                if !run.is_empty() {
                    let detail = run
                        .iter()
                        .map(|&i| {
                            format!(
                                "{} = {:.4e} left [{:.4e}, {:.4e}] ({RUNAWAY_WIDTHS} prior widths beyond the box)",
                                self.names[i], x[i], self.window[i].0, self.window[i].1
                            )
                        })
                        .collect::<Vec<_>>()
                        .join("; ");
                    return Err(self.diverged(&run, detail, it));
                }
            }
            if small {
                converged = true;
                break;
            }
        }
        if !converged && !self.bounded {
            return Err(self.diverged(
                &(0..d).collect::<Vec<_>>(),
                format!("not converged within {} iterations", self.max_iter),
                it,
            ));
        }
        let at_bound = (0..d)
            .map(|i| self.on_lower(i, x[i]) || self.on_upper(i, x[i]))
            .collect();
        Ok(Solution {
            x,
            lp,
            iterations: it,
            converged,
            at_bound,
        })
    }

    /// Backtracking along the projected path `clamp(x + t·dir)`: the first `t = 2⁻ᵏ` whose
    /// `ln L + ln π` is finite and not below `lp`.
    fn line_search(
        &self,
        x: &[f64],
        lp: f64,
        dir: &[f64],
        post: &dyn Fn(&[f64]) -> f64,
    ) -> Option<LineStep> {
        if dir.iter().any(|v| !v.is_finite()) || dir.iter().all(|&v| v == 0.0) {
            return None;
        }
        let mut t = 1.0;
        let mut rejected = None;
        for _ in 0..50 {
            let cand = self.along(x, dir, t);
            if cand == x {
                return None;
            }
            let lc = post(&cand);
            if lc.is_finite() && lc >= lp {
                return Some(LineStep {
                    x: cand,
                    lp: lc,
                    t,
                    rejected,
                });
            }
            rejected = lc.is_finite().then_some(lc);
            t *= 0.5;
        }
        None
    }

    fn along(&self, x: &[f64], dir: &[f64], t: f64) -> Vec<f64> {
        (0..x.len())
            .map(|i| self.clamp(i, x[i] + t * dir[i]))
            .collect()
    }

    /// The vertex of the parabola through `ln L + ln π` at `0`, `t` and `2t` along `dir`
    /// (the accepted point of a shortened step and the one rejected before it), when that is
    /// higher than the accepted point. Where the scoring matrix badly underestimates the
    /// curvature along a direction (a nearly flat, non-quadratic `ln L`: a poorly measured
    /// parameter, measured on the design-frequency sweep), every Newton step overshoots, the
    /// halving lands just past the maximum, and the next step comes back: 120 iterations of
    /// alternating moves each gaining 10⁻⁵ nats. The vertex ends the alternation.
    fn vertex(
        &self,
        x: &[f64],
        lp: f64,
        dir: &[f64],
        step: &LineStep,
        post: &dyn Fn(&[f64]) -> f64,
    ) -> Option<(Vec<f64>, f64)> {
        let (f0, f1, f2) = (lp, step.lp, step.rejected?);
        let curv = f0 - 2.0 * f1 + f2;
        if !(curv < 0.0) {
            return None;
        }
        // in units of t: p(s) through (0, f0), (1, f1), (2, f2)
        let s = 1.0 - (f2 - f0) / (2.0 * curv);
        if !(s > 0.0 && s < 2.0) || s == 1.0 {
            return None;
        }
        let cand = self.along(x, dir, s * step.t);
        let lc = post(&cand);
        (lc.is_finite() && lc > step.lp).then_some((cand, lc))
    }
}

/// The point a line search accepted.
struct LineStep {
    x: Vec<f64>,
    lp: f64,
    /// The fraction of the direction taken.
    t: f64,
    /// `ln L + ln π` at `2t`, the point rejected just before (when one was, and finite).
    rejected: Option<f64>,
}

#[cfg(test)]
mod tests {
    /// A bound at the parameter's physical limit is said to be one, with no remedy; any other
    /// bound (the other side, or a limit elsewhere) keeps the remedy.
    #[test]
    fn a_bound_at_a_physical_limit_is_named_as_one() {
        use super::describe_bound;
        use crate::prior::PriorKind;
        let k = PriorKind::Uniform { lo: 0.0, hi: 1.0 };
        let (t, physical) = describe_bound("dt1", &k, 0.0, [Some(0.0), None]);
        assert!(physical);
        assert!(
            t.contains("is at its physical limit, the lower bound (lo = 0"),
            "{t}"
        );
        assert!(!t.contains("lower lo"), "{t}");
        for (v, limit) in [
            (1.0, [Some(0.0), None]),
            (0.0, [None, None]),
            (0.0, [Some(-1.0), None]),
        ] {
            let (t, physical) = describe_bound("dt1", &k, v, limit);
            assert!(!physical, "{t}");
            assert!(t.contains("if the bound is not physical"), "{t}");
        }
        let (_, physical) = describe_bound("x", &k, 1.0, [None, Some(1.0)]);
        assert!(physical);
    }

    use super::*;

    type Objective = (Box<dyn Fn(&[f64]) -> f64>, Box<GradFisher<'static>>);

    fn problem(bounds: &[(f64, f64)], bounded: bool) -> Problem {
        Problem {
            names: (0..bounds.len()).map(|i| format!("p{i}")).collect(),
            bounds: bounds.to_vec(),
            window: bounds
                .iter()
                .map(|b| runaway_window(&PriorKind::Uniform { lo: b.0, hi: b.1 }))
                .collect(),
            bounded,
            tol: 1e-6,
            max_iter: 200,
            kinked: false,
        }
    }

    /// A correlated Gaussian `ln L = −½ (x − μ)ᵀ F (x − μ)` (Fisher scoring is exact Newton).
    fn gaussian(mu: [f64; 2], f: [[f64; 2]; 2]) -> Objective {
        let post = move |x: &[f64]| {
            let d = [x[0] - mu[0], x[1] - mu[1]];
            -0.5 * (f[0][0] * d[0] * d[0] + 2.0 * f[0][1] * d[0] * d[1] + f[1][1] * d[1] * d[1])
        };
        let gf = move |x: &[f64]| {
            let d = [x[0] - mu[0], x[1] - mu[1]];
            let g = vec![
                -(f[0][0] * d[0] + f[0][1] * d[1]),
                -(f[0][1] * d[0] + f[1][1] * d[1]),
            ];
            (g, DMatrix::from_fn(2, 2, |i, j| f[i][j]))
        };
        (Box::new(post), Box::new(gf))
    }

    /// Brute-force maximum of `post` over a grid of the box.
    fn grid_max(post: &dyn Fn(&[f64]) -> f64, b: &[(f64, f64)], n: usize) -> (Vec<f64>, f64) {
        let mut best = (vec![], f64::NEG_INFINITY);
        for i in 0..=n {
            for j in 0..=n {
                let x = [
                    b[0].0 + (b[0].1 - b[0].0) * i as f64 / n as f64,
                    b[1].0 + (b[1].1 - b[1].0) * j as f64 / n as f64,
                ];
                let l = post(&x);
                if l > best.1 {
                    best = (x.to_vec(), l);
                }
            }
        }
        best
    }

    #[test]
    fn maximum_outside_the_box_lands_on_the_corner() {
        // maximum at (3, 4), box [0, 1]²; correlation 0.6: the constrained maximum is the
        // corner (1, 1) (KKT: the gradient there, F·(μ − x), points out of both faces)
        let bounds = [(0.0, 1.0), (0.0, 1.0)];
        let (post, gf) = gaussian([3.0, 4.0], [[1.0, 0.6], [0.6, 1.0]]);
        let r = problem(&bounds, true)
            .solve(&[0.5, 0.5], &post, &gf)
            .unwrap();
        assert!(r.converged);
        assert_eq!(r.x, vec![1.0, 1.0]);
        assert_eq!(r.at_bound, vec![true, true]);
        let (gx, gl) = grid_max(&post, &bounds, 200);
        assert_eq!(gx, vec![1.0, 1.0]);
        assert_eq!(r.lp, gl);
    }

    #[test]
    fn maximum_on_a_face_is_found_with_the_other_parameter_free() {
        // maximum at (2, 0.3) beyond the face x0 = 1; the constrained maximum is on that face
        // with x1 from the KKT condition, inside its range
        let f = [[1.0, -0.5], [-0.5, 1.0]];
        let mu = [2.0, 0.3];
        let bounds = [(0.0, 1.0), (-2.0, 2.0)];
        let (post, gf) = gaussian(mu, f);
        let r = problem(&bounds, true)
            .solve(&[0.2, 0.0], &post, &gf)
            .unwrap();
        // on x0 = 1: ∂/∂x1 = 0 → x1 = μ1 − F01/F11 (1 − μ0)
        let x1 = mu[1] - f[0][1] / f[1][1] * (1.0 - mu[0]);
        assert!(r.converged);
        assert_eq!(r.at_bound, vec![true, false]);
        assert_eq!(r.x[0], 1.0);
        assert!((r.x[1] - x1).abs() < 1e-8, "{} vs {x1}", r.x[1]);
        let (_, gl) = grid_max(&post, &bounds, 400);
        assert!(r.lp >= gl - 1e-12);
    }

    #[test]
    fn interior_maximum_is_unaffected_by_the_box() {
        let (post, gf) = gaussian([0.3, 0.6], [[1.0, 0.6], [0.6, 1.0]]);
        for bounded in [true, false] {
            let r = problem(&[(0.0, 1.0), (0.0, 1.0)], bounded)
                .solve(&[0.9, 0.1], &post, &gf)
                .unwrap();
            assert!(r.converged);
            assert_eq!(r.at_bound, vec![false, false]);
            assert!((r.x[0] - 0.3).abs() < 1e-12 && (r.x[1] - 0.6).abs() < 1e-12);
        }
    }

    #[test]
    fn a_scoring_matrix_far_below_the_curvature_does_not_make_the_search_alternate() {
        // ln L = −(x − 0.3)², scoring matrix 2/r: every Newton step is r times too long. The
        // halving accepts t = 2⁻¹⁰ (r t = 1.95), which lands 0.95 of the distance beyond the
        // maximum, and the next step comes back: without the vertex the distance shrinks by
        // 5 % per iteration and 200 iterations do not converge
        let r = 1.95 * 1024.0;
        let post = |x: &[f64]| -(x[0] - 0.3).powi(2);
        let gf = move |x: &[f64]| {
            (
                vec![-2.0 * (x[0] - 0.3)],
                DMatrix::from_element(1, 1, 2.0 / r),
            )
        };
        let mut p = problem(&[(-1.0, 1.0)], true);
        p.tol = 1e-4;
        let s = p.solve(&[-0.7], &post, &gf).unwrap();
        assert!(s.converged, "{s:?}");
        assert!(s.iterations <= 5, "{s:?}");
        assert!((s.x[0] - 0.3).abs() < 1e-12, "{s:?}");
    }

    /// `ln L = −(y − tanh x)²` with `y = 1.5` outside the range of `tanh`: `ln L` rises
    /// monotonically towards a plateau, there is no maximum, Gauss–Newton runs away.
    fn plateau() -> Objective {
        let y = 1.5;
        let post = move |x: &[f64]| -(y - x[0].tanh()).powi(2) - 0.5 * (x[1] - 0.5).powi(2);
        let gf = move |x: &[f64]| {
            let t = x[0].tanh();
            let dt = 1.0 - t * t;
            let g = vec![2.0 * (y - t) * dt, -(x[1] - 0.5)];
            (
                g,
                DMatrix::from_row_slice(2, 2, &[2.0 * dt * dt, 0.0, 0.0, 1.0]),
            )
        };
        (Box::new(post), Box::new(gf))
    }

    #[test]
    fn flat_direction_unbounded_search_reports_divergence() {
        let (post, gf) = plateau();
        let bounds = [(-1.0, 1.0), (0.0, 1.0)];
        let err = problem(&bounds, false)
            .solve(&[0.0, 0.2], &post, &gf)
            .unwrap_err();
        match &err {
            MapError::Diverged { params, .. } => assert_eq!(params, &vec!["p0".to_string()]),
            e => panic!("expected divergence, got {e:?}"),
        }
        let msg = err.to_string();
        assert!(
            msg.contains("p0") && msg.contains("does not apply"),
            "{msg}"
        );
        // the bounded search stops on the face the likelihood rises towards
        let r = problem(&bounds, true)
            .solve(&[0.0, 0.2], &post, &gf)
            .unwrap();
        assert!(r.converged);
        assert_eq!(r.x[0], 1.0);
        assert!((r.x[1] - 0.5).abs() < 1e-9);
        assert_eq!(r.at_bound, vec![true, false]);
    }

    #[test]
    fn non_finite_objective_is_an_error_not_nan() {
        let post = |x: &[f64]| -x[0] * x[0];
        let gf = |_: &[f64]| (vec![f64::NAN], DMatrix::from_element(1, 1, 1.0));
        let err = problem(&[(-1.0, 1.0)], false)
            .solve(&[0.5], &post, &gf)
            .unwrap_err();
        assert!(matches!(err, MapError::NonFinite { .. }), "{err:?}");
    }

    /// A maximum on a kink: `−(x − 0.2)²/2 − |x|/2` peaks at `x = 0`, where the one-sided
    /// gradient (−0.3 at and right of it, as the gradient code takes it; 0.7 left of it) never
    /// vanishes, so no Newton step gets below `tol` = 0.1. With kinks the search converges
    /// there (no step ascends, every Newton step within `NONSMOOTH × tol`); without, it does
    /// not, as before.
    #[test]
    fn a_maximum_on_a_kink_converges_where_ln_l_has_kinks() {
        let post = |x: &[f64]| -0.5 * (x[0] - 0.2).powi(2) - 0.5 * x[0].abs();
        let gf = |x: &[f64]| {
            let side = if x[0] < 0.0 { -1.0 } else { 1.0 };
            (
                vec![-(x[0] - 0.2) - 0.5 * side],
                DMatrix::from_element(1, 1, 1.0),
            )
        };
        let bounds = [(-3.0, 3.0)];
        let kinked = Problem {
            tol: 0.1,
            kinked: true,
            ..problem(&bounds, true)
        };
        let r = kinked.solve(&[1.0], &post, &gf).unwrap();
        assert!(r.converged, "{r:?}");
        assert!(r.x[0].abs() < 1e-6, "{r:?}");
        assert!(r.iterations < 200, "{r:?}");
        let smooth = Problem {
            tol: 0.1,
            ..problem(&bounds, true)
        };
        let r = smooth.solve(&[1.0], &post, &gf).unwrap();
        assert!(!r.converged, "{r:?}");
        // the kink on the box's lower bound: the gradient there points out of the box, so
        // the bound holds it (the KKT rule), with kinks or without
        for kinked in [true, false] {
            let p = Problem {
                tol: 0.1,
                kinked,
                ..problem(&[(0.0, 3.0)], true)
            };
            let r = p.solve(&[1.0], &post, &gf).unwrap();
            assert!(
                r.converged && r.x[0] == 0.0 && r.at_bound[0],
                "{kinked}: {r:?}"
            );
        }
        // the unbounded search (the Laplace expansion point) on a kinked model ends at the
        // kink as converged rather than as divergent
        let p = Problem {
            tol: 0.1,
            kinked: true,
            ..problem(&bounds, false)
        };
        let r = p.solve(&[1.0], &post, &gf).unwrap();
        assert!(r.converged && r.x[0].abs() < 1e-6, "{r:?}");
    }

    #[test]
    fn ln_posterior_never_decreases_along_the_iterations() {
        // a non-quadratic objective where full Gauss–Newton steps overshoot
        let post = |x: &[f64]| -(x[0].powi(4)) - (x[0] - 2.0 * x[1]).powi(2);
        let gf = |x: &[f64]| {
            let g = vec![
                -4.0 * x[0].powi(3) - 2.0 * (x[0] - 2.0 * x[1]),
                4.0 * (x[0] - 2.0 * x[1]),
            ];
            let f = DMatrix::from_row_slice(2, 2, &[2.0 + 1e-3, -4.0, -4.0, 8.0 + 1e-3]);
            (g, f)
        };
        let bounds = [(-3.0, 3.0), (-3.0, 3.0)];
        let mut last = post(&[2.5, -2.0]);
        for n in 1..40 {
            let p = Problem {
                max_iter: n,
                ..problem(&bounds, true)
            };
            let r = p.solve(&[2.5, -2.0], &post, &gf).unwrap();
            assert!(r.lp >= last, "iteration {n}: {} < {last}", r.lp);
            last = r.lp;
        }
        let r = problem(&bounds, true)
            .solve(&[2.5, -2.0], &post, &gf)
            .unwrap();
        assert!(r.x[0].abs() < 0.2, "{:?}", r.x);
    }

    /// The LTP likelihood of the small study with the boxes of `w1sq` and `w2sq` moved to
    /// `[truth + 3σ, truth + 8σ]`: the unconstrained maximum lies below both boxes.
    fn ltp_shifted_box() -> (Likelihood, Vec<usize>, Vec<f64>) {
        use crate::likelihood::tests::{likelihood_of, small_study};
        use crate::likelihood::{NoiseSource, SpectraOptions, cramer_rao, fisher_exact};
        use crate::prior::Prior;
        let opts = SpectraOptions {
            noise: NoiseSource::Model,
            band: [1e-3, 0.3],
            ..Default::default()
        };
        let study = small_study(21, 1e-6, "circular");
        let lik = likelihood_of(&study, &opts);
        let truth = study.truth.to_array().to_vec();
        let free = vec![0, 1];
        let sig = cramer_rao(&fisher_exact(&lik, &truth, &free)).unwrap();
        let mut kinds = lik.prior().kinds().to_vec();
        for (i, &a) in free.iter().enumerate() {
            kinds[a] = PriorKind::Uniform {
                lo: truth[a] + 3.0 * sig[i],
                hi: truth[a] + 8.0 * sig[i],
            };
        }
        let prior = Prior::new(lik.prior().names().to_vec(), kinds).unwrap();
        let lik = Likelihood::new(lik.model().clone(), lik.spectra().to_vec(), prior).unwrap();
        (lik, free, truth)
    }

    #[test]
    fn ltp_maximum_below_the_box_is_the_grid_maximum() {
        let (lik, free, truth) = ltp_shifted_box();
        let b: Vec<(f64, f64)> = free.iter().map(|&a| lik.prior().bounds()[a]).collect();
        let mut start = truth.clone();
        for (i, &a) in free.iter().enumerate() {
            start[a] = 0.5 * (b[i].0 + b[i].1);
        }
        let r = fisher_scoring(&lik, &start, &free, 1e-4, 100).unwrap();
        assert!(r.converged, "{r:?}");
        let post = |x: &[f64]| {
            let mut th = truth.clone();
            th[0] = x[0];
            th[1] = x[1];
            lik.ln_posterior(&th)
        };
        let n = 40;
        let (gx, gl) = grid_max(&post, &b, n);
        // the search is at least as high as every grid point, and in the grid maximum's cell
        assert!(
            r.ln_posterior >= gl - 1e-9,
            "{} < grid {gl}",
            r.ln_posterior
        );
        for i in 0..2 {
            let cell = (b[i].1 - b[i].0) / n as f64;
            assert!(
                (r.theta[free[i]] - gx[i]).abs() <= cell,
                "parameter {i}: {} vs grid {}",
                r.theta[free[i]],
                gx[i]
            );
        }
        // the grid maximum is on the lower bound of at least one parameter; the search says so
        let on_lo: Vec<bool> = (0..2).map(|i| gx[i] == b[i].0).collect();
        assert!(on_lo.iter().any(|&x| x), "{gx:?}");
        for i in 0..2 {
            if on_lo[i] {
                assert!(r.at_bound[i] && r.theta[free[i]] == b[i].0, "{r:?}");
            }
        }
        eprintln!(
            "LTP MAP below the box: {:?} at bound {:?}; grid {gx:?}",
            &r.theta[..2],
            r.at_bound
        );
    }
}
