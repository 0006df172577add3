//! MAP search: Nelder–Mead with restarts, bounded by rejection.
//!
//! * **Bounds by rejection.** A trial point outside the prior support gets `f = +∞` (and so
//!   does any point with a non-finite objective): it is the worst vertex and the simplex
//!   contracts away from it. `−ln posterior` is `+∞` outside the support anyway, so this
//!   leaves the objective and Nelder–Mead's geometry untouched; clamping would flatten the
//!   simplex onto the boundary. An optimum on the boundary is approached by contractions.
//! * **Coefficients** of Gao & Han (2012), which keep the method effective in higher
//!   dimension: reflection 1, expansion `1 + 2/n`, contraction `0.75 − 1/(2n)`, shrink
//!   `1 − 1/n` (the classic 1, 2, ½, ½ for `n = 2`).
//! * **Convergence** needs both: the simplex is small, `|x_ik − x_bk| ≤ x_rtol · max(|x_bk|,
//!   |step_k|)` for every vertex `i` and coordinate `k` (`x_b` the best vertex, `step` the
//!   initial steps, which set each parameter's scale), and the values agree,
//!   `f_worst − f_best ≤ f_atol`.
//! * **Restarts.** Nelder–Mead can stall at a non-stationary point. After convergence it
//!   restarts from the best point with a fresh simplex of the initial steps; it stops when a
//!   restart improves `f` by no more than `f_atol`, after `max_restarts` restarts, or when
//!   `max_evals` is used up.

use super::error::SamplerError;
use crate::density::LogDensity;

/// Nelder–Mead settings.
#[derive(Debug, Clone, PartialEq)]
pub struct NelderMeadSettings {
    /// Largest number of objective evaluations, all restarts included.
    pub max_evals: usize,
    /// Relative simplex size for convergence (see the module docs).
    pub x_rtol: f64,
    /// Spread of `f` over the simplex for convergence (for `−ln posterior`, natural-log
    /// units).
    pub f_atol: f64,
    /// Largest number of restarts after the first convergence.
    pub max_restarts: usize,
}

impl Default for NelderMeadSettings {
    fn default() -> Self {
        Self {
            max_evals: 50_000,
            x_rtol: 1e-8,
            f_atol: 1e-10,
            max_restarts: 10,
        }
    }
}

impl NelderMeadSettings {
    fn validate(&self) -> Result<(), SamplerError> {
        let bad = |problem: String| Err(SamplerError::Optimizer { problem });
        if self.max_evals == 0 {
            return bad("max_evals must be ≥ 1".into());
        }
        if !(self.x_rtol.is_finite() && self.x_rtol > 0.0) {
            return bad(format!(
                "x_rtol must be finite and > 0 (got {})",
                self.x_rtol
            ));
        }
        if !(self.f_atol.is_finite() && self.f_atol >= 0.0) {
            return bad(format!(
                "f_atol must be finite and ≥ 0 (got {})",
                self.f_atol
            ));
        }
        Ok(())
    }
}

/// Result of [`nelder_mead`].
#[derive(Debug, Clone, PartialEq)]
pub struct Minimum {
    /// Best point found.
    pub x: Vec<f64>,
    /// Objective there.
    pub f: f64,
    /// Objective evaluations used.
    pub evals: usize,
    /// Restarts performed.
    pub restarts: usize,
    /// Whether the last simplex met both tolerances and the last restart did not improve
    /// `f` by more than `f_atol`. `false` means `max_evals` ran out first.
    pub converged: bool,
}

struct Objective<F> {
    f: F,
    evals: usize,
    max_evals: usize,
}

impl<F: FnMut(&[f64]) -> f64> Objective<F> {
    fn eval(&mut self, x: &[f64]) -> f64 {
        self.evals += 1;
        let v = (self.f)(x);
        if v.is_nan() { f64::INFINITY } else { v }
    }

    fn exhausted(&self) -> bool {
        self.evals >= self.max_evals
    }
}

/// One Nelder–Mead descent from `x0` with steps `step`. Returns (best x, best f, converged).
fn descend<F: FnMut(&[f64]) -> f64>(
    obj: &mut Objective<F>,
    x0: &[f64],
    f0: f64,
    step: &[f64],
    s: &NelderMeadSettings,
) -> Result<(Vec<f64>, f64, bool), SamplerError> {
    let n = x0.len();
    let nn = n.max(2) as f64;
    let (alpha, chi, rho, sigma) = (1.0, 1.0 + 2.0 / nn, 0.75 - 0.5 / nn, 1.0 - 1.0 / nn);
    let mut xs: Vec<Vec<f64>> = vec![x0.to_vec()];
    let mut fs: Vec<f64> = vec![f0];
    for k in 0..n {
        // Find a finite vertex along ±step_k, halving if both directions are infeasible.
        let mut h = step[k];
        let mut found = None;
        for _ in 0..60 {
            for sign in [1.0, -1.0] {
                let mut v = x0.to_vec();
                v[k] += sign * h;
                let fv = obj.eval(&v);
                if fv < f64::INFINITY {
                    found = Some((v, fv));
                    break;
                }
            }
            if found.is_some() {
                break;
            }
            h *= 0.5;
        }
        let (v, fv) = found.ok_or_else(|| SamplerError::Optimizer {
            problem: format!(
                "no point with a finite objective along coordinate {k} within ±{} of the start; the start sits on the edge of the support",
                step[k]
            ),
        })?;
        xs.push(v);
        fs.push(fv);
    }
    let mut centroid = vec![0.0; n];
    let mut xr = vec![0.0; n];
    let mut xe = vec![0.0; n];
    let mut xc = vec![0.0; n];
    loop {
        // Insertion sort by f; swapping rows moves pointers, not coordinates.
        for i in 1..=n {
            let mut j = i;
            while j > 0 && fs[j - 1].total_cmp(&fs[j]).is_gt() {
                fs.swap(j - 1, j);
                xs.swap(j - 1, j);
                j -= 1;
            }
        }
        let best = &xs[0];
        let small = xs[1..].iter().all(|v| {
            v.iter()
                .zip(best)
                .zip(step)
                .all(|((a, b), h)| (a - b).abs() <= s.x_rtol * b.abs().max(h.abs()))
        });
        if small && fs[n] - fs[0] <= s.f_atol {
            return Ok((xs[0].clone(), fs[0], true));
        }
        if obj.exhausted() {
            return Ok((xs[0].clone(), fs[0], false));
        }
        centroid.iter_mut().for_each(|c| *c = 0.0);
        for v in &xs[..n] {
            for (c, x) in centroid.iter_mut().zip(v) {
                *c += x / n as f64;
            }
        }
        let worst = &xs[n];
        for k in 0..n {
            xr[k] = centroid[k] + alpha * (centroid[k] - worst[k]);
        }
        let fr = obj.eval(&xr);
        if fr < fs[0] {
            for k in 0..n {
                xe[k] = centroid[k] + chi * (xr[k] - centroid[k]);
            }
            let fe = obj.eval(&xe);
            if fe < fr {
                xs[n].copy_from_slice(&xe);
                fs[n] = fe;
            } else {
                xs[n].copy_from_slice(&xr);
                fs[n] = fr;
            }
            continue;
        }
        if fr < fs[n - 1] {
            xs[n].copy_from_slice(&xr);
            fs[n] = fr;
            continue;
        }
        let (outside, target_f) = if fr < fs[n] {
            (true, fr)
        } else {
            (false, fs[n])
        };
        for k in 0..n {
            xc[k] = if outside {
                centroid[k] + rho * (xr[k] - centroid[k])
            } else {
                centroid[k] + rho * (worst[k] - centroid[k])
            };
        }
        let fc = obj.eval(&xc);
        if fc < target_f || (outside && fc <= target_f) {
            xs[n].copy_from_slice(&xc);
            fs[n] = fc;
            continue;
        }
        // Shrink towards the best vertex.
        let (head, rest) = xs.split_at_mut(1);
        let b = &head[0];
        for (v, fv) in rest.iter_mut().zip(&mut fs[1..]) {
            for (x, bk) in v.iter_mut().zip(b) {
                *x = bk + sigma * (*x - bk);
            }
            *fv = obj.eval(v);
        }
    }
}

/// Minimises `f` from `x0` with initial steps `step` (one per coordinate, non-zero: they set
/// each parameter's scale). `f` returning `+∞` or NaN marks an infeasible point (see the
/// module docs). Errors if the inputs are inconsistent or `f(x0)` is not finite.
///
/// ```
/// use occam::sampler::{NelderMeadSettings, nelder_mead};
/// let rosenbrock = |x: &[f64]| (1.0 - x[0]).powi(2) + 100.0 * (x[1] - x[0] * x[0]).powi(2);
/// let m = nelder_mead(rosenbrock, &[-1.2, 1.0], &[0.5, 0.5], &NelderMeadSettings::default()).unwrap();
/// assert!(m.converged);
/// assert!((m.x[0] - 1.0).abs() < 1e-4 && (m.x[1] - 1.0).abs() < 1e-4);
/// ```
pub fn nelder_mead<F: FnMut(&[f64]) -> f64>(
    f: F,
    x0: &[f64],
    step: &[f64],
    settings: &NelderMeadSettings,
) -> Result<Minimum, SamplerError> {
    settings.validate()?;
    let bad = |problem: String| Err(SamplerError::Optimizer { problem });
    if x0.is_empty() {
        return bad("the start point is empty".into());
    }
    if step.len() != x0.len() {
        return bad(format!(
            "{} steps for {} coordinates; give one step per coordinate",
            step.len(),
            x0.len()
        ));
    }
    if let Some((k, h)) = step
        .iter()
        .enumerate()
        .find(|(_, h)| !(h.is_finite() && **h != 0.0))
    {
        return bad(format!(
            "step {k} = {h} must be finite and non-zero (e.g. a prior or Fisher standard deviation)"
        ));
    }
    let mut obj = Objective {
        f,
        evals: 0,
        max_evals: settings.max_evals,
    };
    let f0 = obj.eval(x0);
    if !f0.is_finite() {
        return bad(format!(
            "the objective is {f0} at the start point; start inside the support"
        ));
    }
    let (mut x, mut fx, mut converged) = descend(&mut obj, x0, f0, step, settings)?;
    let mut restarts = 0;
    while converged && restarts < settings.max_restarts && !obj.exhausted() {
        restarts += 1;
        let (x2, f2, c2) = descend(&mut obj, &x, fx, step, settings)?;
        let improved = fx - f2 > settings.f_atol;
        if f2 < fx {
            x = x2;
            fx = f2;
        }
        converged = c2;
        if !improved {
            break;
        }
    }
    Ok(Minimum {
        x,
        f: fx,
        evals: obj.evals,
        restarts,
        converged,
    })
}

/// Result of [`find_map`].
#[derive(Debug, Clone, PartialEq)]
pub struct MapEstimate {
    /// The maximum a-posteriori point.
    pub theta: Vec<f64>,
    /// `ln L + ln π` there.
    pub ln_posterior: f64,
    /// `ln L` there.
    pub ln_likelihood: f64,
    /// Evaluations, restarts and convergence as in [`Minimum`].
    pub evals: usize,
    /// Restarts performed.
    pub restarts: usize,
    /// See [`Minimum::converged`].
    pub converged: bool,
}

/// Maximises `ln L + ln π` of `target` by [`nelder_mead`] on `−ln posterior` from `start`,
/// with initial steps `step` (e.g. √diag of the inverse Fisher matrix). Points outside the
/// prior support are rejected (objective `+∞`).
pub fn find_map<D: LogDensity>(
    target: &D,
    start: &[f64],
    step: &[f64],
    settings: &NelderMeadSettings,
) -> Result<MapEstimate, SamplerError> {
    if start.len() != target.dim() {
        return Err(SamplerError::Optimizer {
            problem: format!(
                "the start point has {} entries but the target has {} parameters",
                start.len(),
                target.dim()
            ),
        });
    }
    let m = nelder_mead(
        |x| {
            let lp = target.ln_posterior(x);
            if lp.is_finite() { -lp } else { f64::INFINITY }
        },
        start,
        step,
        settings,
    )?;
    Ok(MapEstimate {
        ln_likelihood: target.ln_likelihood(&m.x),
        ln_posterior: -m.f,
        theta: m.x,
        evals: m.evals,
        restarts: m.restarts,
        converged: m.converged,
    })
}
