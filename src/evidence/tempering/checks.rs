//! Checks of one tempering run against itself: do the two halves of its post-burn-in sweeps
//! give the same `ln Z`, and does `E_β[ln L]` rise along the ladder as it must
//! (`d E_β[ln L]/dβ = Var_β(ln L) ≥ 0`)? Either failing means a rung has not equilibrated
//! (a mode found late, a ladder whose swaps stalled), which the batch-means error cannot see.

use super::integrate::{SteppingStoneEstimate, ThermodynamicEstimate};
use super::integrate::{rung_moments, stepping_stone, thermodynamic};

/// Halves whose estimates differ by more than this many of their combined errors widen the
/// error of the whole run.
/// What a tempering run's checks against itself found, each message on the estimate it
/// concerns (the module docs, "Checks of a run against itself"). Empty when every check passes.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize)]
pub struct TemperingChecks {
    /// Thermodynamic integration's halves disagree (its error is already widened).
    pub thermodynamic: Vec<String>,
    /// Stepping-stone's halves disagree (its error is already widened).
    pub stepping_stone: Vec<String>,
    /// The ladder itself (`E_β[ln L]` falling from one rung to the next): concerns both.
    pub ladder: Vec<String>,
}

impl TemperingChecks {
    /// Whether every check passed.
    pub fn is_empty(&self) -> bool {
        self.thermodynamic.is_empty() && self.stepping_stone.is_empty() && self.ladder.is_empty()
    }

    /// The messages that concern thermodynamic integration.
    pub fn for_thermodynamic(&self) -> Vec<String> {
        self.thermodynamic
            .iter()
            .chain(&self.ladder)
            .cloned()
            .collect()
    }

    /// The messages that concern stepping-stone.
    pub fn for_stepping_stone(&self) -> Vec<String> {
        self.stepping_stone
            .iter()
            .chain(&self.ladder)
            .cloned()
            .collect()
    }
}

pub(crate) const SPLIT_Z: f64 = 3.0;

/// A rung whose `E_β[ln L]` lies more than this many combined errors below the rung under it
/// is named.
pub(crate) const FALL_Z: f64 = 4.0;

/// The thermodynamic and stepping-stone estimates of the first and the second half of the
/// post-burn-in sweeps (`series` is sweep-major: `series[t·n_t + i]`, rung `i` at sweep `t`);
/// `None` for an estimator that does not apply to a half, or with fewer than 8 sweeps a half.
pub(crate) type Halves = (
    Option<[ThermodynamicEstimate; 2]>,
    Option<[SteppingStoneEstimate; 2]>,
);

pub(crate) fn halves(betas: &[f64], series: &[f64]) -> Halves {
    let n_t = betas.len();
    let half = series.len() / n_t / 2;
    if half < 8 {
        return (None, None);
    }
    let batch = ((half as f64).sqrt() as usize).max(1);
    let parts = [&series[..half * n_t], &series[half * n_t..2 * half * n_t]];
    // batch-means errors, as the threshold was calibrated (`integrate::mean_var`)
    let ti = parts
        .map(|s| thermodynamic(betas, &rung_moments(s, n_t, half, batch), s, batch, false).ok());
    let ss = parts.map(|s| stepping_stone(betas, s, batch, false).ok());
    (
        ti[0].zip(ti[1]).map(|(a, b)| [a, b]),
        ss[0].zip(ss[1]).map(|(a, b)| [a, b]),
    )
}

/// The error of the whole run's estimate given its halves `(value, error)`: unchanged when they
/// agree within [`SPLIT_Z`] combined errors; otherwise `|Δ|/2` (the spread the two halves
/// show, as the error of their mean) when larger, with a note saying so.
pub(crate) fn split_error(name: &str, std_err: f64, h: [(f64, f64); 2]) -> (f64, Option<String>) {
    let d = h[0].0 - h[1].0;
    let z = d.abs() / h[0].1.hypot(h[1].1);
    if !(z > SPLIT_Z) {
        return (std_err, None);
    }
    let widened = std_err.max(d.abs() / 2.0);
    (
        widened,
        Some(format!(
            "{name}: the two halves of the tempering run give ln Z {:.4} ± {:.4} and {:.4} ± {:.4} ({z:.1} σ apart), so its error was widened from {std_err:.3} to {widened:.3}: a rung had not equilibrated (raise pt_burn_in or pt_iterations)",
            h[0].0, h[0].1, h[1].0, h[1].1
        )),
    )
}

/// The rung where `E_β[ln L]` falls most against the rung below it, when by more than
/// [`FALL_Z`] combined errors: `E_β[ln L]` must not decrease with β.
pub(crate) fn falling_mean(betas: &[f64], mean: &[f64], se: &[f64]) -> Option<String> {
    let (i, z) = (0..betas.len().saturating_sub(1))
        .map(|i| (i, (mean[i] - mean[i + 1]) / se[i].hypot(se[i + 1])))
        .filter(|(_, z)| z.is_finite())
        .max_by(|a, b| a.1.total_cmp(&b.1))?;
    (z > FALL_Z).then(|| {
        format!(
            "E_β[ln L] falls from {:.4e} at β = {:.4} to {:.4e} at β = {:.4} ({z:.1} σ), although it cannot decrease with β: the rung at β = {:.4} has not equilibrated (raise pt_burn_in or pt_iterations)",
            mean[i],
            betas[i],
            mean[i + 1],
            betas[i + 1],
            betas[i + 1]
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    use rand_xoshiro::Xoshiro256PlusPlus;

    /// A Gaussian likelihood's tempered `ln L` draws on a 6-rung ladder: `ln L = −χ²_d/2` with
    /// `χ²` of `d = 2` scaled by `1/(1 + β·100)` (posterior 100× narrower than the prior),
    /// drawn independently per sweep; `shift` moves the top rung's second half.
    fn series(n: usize, shift: f64, seed: u64) -> (Vec<f64>, Vec<f64>) {
        let betas = vec![0.0, 0.01, 0.03, 0.1, 0.3, 1.0];
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        let g = Normal::new(0.0, 1.0).unwrap();
        let mut s = Vec::with_capacity(n * betas.len());
        for t in 0..n {
            for (i, b) in betas.iter().enumerate() {
                let chi2: f64 = (0..2)
                    .map(|_| {
                        let x: f64 = g.sample(&mut rng);
                        x * x
                    })
                    .sum();
                let mut l = -0.5 * 100.0 * chi2 / (1.0 + b * 100.0);
                if i == betas.len() - 1 && t >= n / 2 {
                    l += shift;
                }
                s.push(l);
            }
        }
        (betas, s)
    }

    #[test]
    fn agreeing_halves_change_nothing_and_a_late_shift_widens_the_error() {
        let (betas, s) = series(4000, 0.0, 1);
        let (ti, ss) = halves(&betas, &s);
        let ti = ti.unwrap();
        let h = ti.map(|t| (t.ln_z, t.std_err));
        assert_eq!(split_error("TI", 0.01, h), (0.01, None));
        assert!(ss.is_some());
        // the top rung's ln L one nat higher in the second half: its TI differs by ≈ 0.35
        let (betas, s) = series(4000, 1.0, 1);
        let ti = halves(&betas, &s).0.unwrap();
        let h = ti.map(|t| (t.ln_z, t.std_err));
        let (se, note) = split_error("TI", 0.01, h);
        assert!(
            (se - (h[0].0 - h[1].0).abs() / 2.0).abs() < 1e-12 && se > 0.1,
            "{se}"
        );
        assert!(note.unwrap().contains("halves"));
        // too short to split
        assert!(halves(&betas, &s[..10 * 6]).0.is_none());
    }

    #[test]
    fn a_falling_mean_is_named_and_a_rising_one_is_not() {
        let betas = [0.0, 0.1, 1.0];
        let se = [0.1, 0.1, 0.1];
        assert!(falling_mean(&betas, &[-10.0, -5.0, -1.0], &se).is_none());
        // within noise: 0.3 below, 2.1 σ
        assert!(falling_mean(&betas, &[-10.0, -5.0, -5.3], &se).is_none());
        let m = falling_mean(&betas, &[-10.0, -5.0, -6.0], &se).unwrap();
        assert!(m.contains("β = 1.0000") && m.contains("7.1 σ"), "{m}");
        // an undefined error (a rung with no finite ln L) is skipped, not a panic
        assert!(falling_mean(&betas, &[f64::NAN, -5.0, -1.0], &se).is_none());
    }
}
