//! The multi-start MAP search: [`fisher_scoring`] from several starts, the distinct maxima it
//! ends in, and the highest of them.
//!
//! A single search from the prior centre finds the maximum of the basin it starts in. Where
//! `ln L` has several (a thruster pole placed above the loop bandwidth, where `ln L` is flat
//! in it; a delay aliased by a period), that can be far below the global one: on
//! `examples/thruster-response.toml` without its `start`, 12 905 nats below, at a spurious
//! peak where the loop is unstable (refused now: [`crate::likelihood::stability`]). The starts are, in
//! order of priority:
//! 1. the given start (the prior centre, or `[fit] start`),
//! 2. `n` quasi-random points of the prior ([`quasi_random_starts`]: a Halton sequence mapped
//!    through each free parameter's quantile function),
//! 3. later, a chain's best sample ([`MultiStartMap::search_from_chains`]), when the chains climbed above
//!    the maximum found.
//!
//! Two ends are the **same maximum** when every free parameter differs by less than one
//! Cramér–Rao σ of the earlier one (the Fisher matrix there; `10⁻³` prior widths where it is
//! singular): the searches stop within `10⁻³`–`10⁻²` σ of a maximum, so ends of one basin are
//! far closer than that, and distinct maxima far apart. Of a maximum reached from several
//! starts the end from the start of highest priority is kept, so a study whose given start
//! already reaches the global maximum gets exactly the numbers of a single search — unless a
//! later end is higher by more than [`CHAIN_MARGIN`] (the kept search stopped short on a flat
//! or bounded direction: measured on `examples/design-frequency.toml`, a quasi-random start
//! ended 2 nats below the others, within 1 σ of them).
//! The maxima are ranked by `ln L + ln π` (the Whittle `ln L` of the search).

use super::exact::Likelihood;
use super::fisher::fisher_exact;
use super::map::{MapError, ScoringResult, fisher_scoring};
use crate::density::LogDensity;
use crate::linalg::SpdOptions;
use crate::numfmt::{fmt_fixed, fmt_short_sig};
use crate::prior::Prior;
use rayon::prelude::*;
use std::fmt;

/// How far (nats of `ln L + ln π`) a chain's best sample must lie above the highest maximum
/// before a search starts from it. A converged search stops within `½ d tol²` nats of its
/// maximum (`10⁻³`–`10⁻²` σ: below `10⁻³` nats for `d` up to 20), and a chain's best sample
/// lies about `d/2` nats below the maximum of its own basin, so a sample above the maximum
/// by more than this is in a higher basin.
pub const CHAIN_MARGIN: f64 = 0.01;

/// Where a start of the multi-start search came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case", tag = "kind", content = "index")]
pub enum StartFrom {
    /// The given start (the prior centre, or `[fit] start`).
    Given,
    /// Quasi-random point `k` (from 1) of the prior.
    QuasiRandom(usize),
    /// The highest-posterior sample of the chains.
    ChainOptimum,
}

impl fmt::Display for StartFrom {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            StartFrom::Given => write!(f, "the start point"),
            StartFrom::QuasiRandom(k) => write!(f, "quasi-random start {k}"),
            StartFrom::ChainOptimum => write!(f, "the chains' best sample"),
        }
    }
}

/// One start: where it came from and the full parameter vector.
#[derive(Debug, Clone, PartialEq)]
pub struct MapStart {
    pub from: StartFrom,
    pub theta: Vec<f64>,
}

/// A distinct maximum: the search that reached it from the start of highest priority, and how
/// many starts ended there.
#[derive(Debug, Clone, PartialEq)]
pub struct Maximum {
    pub from: StartFrom,
    pub result: ScoringResult,
    /// Starts that ended at this maximum.
    pub reached_by: usize,
    /// Cramér–Rao σ of the free parameters there (the scale of "the same maximum").
    scale: Vec<f64>,
}

/// How far below the highest maximum, in `ln` of its Laplace mass, another maximum holds no
/// posterior mass worth a word: `e^−20 ≈ 2·10⁻⁹` of the highest's, which neither the chains
/// nor any evidence estimate can see.
pub const NEGLIGIBLE_LN_MASS: f64 = 20.0;

/// What [`MultiStartMap::describe`] says when every other maximum is negligible: the line is
/// then a fact for a run's notes, not a warning ([`MultiStartMap::is_fact`]).
pub const NO_MASS: &str = "the others hold no posterior mass";

/// What the multi-start search found.
#[derive(Debug, Clone, PartialEq)]
pub struct MultiStartMap {
    /// The distinct maxima, highest `ln L + ln π` first.
    pub maxima: Vec<Maximum>,
    /// Starts whose search failed, with why.
    pub failed: Vec<(StartFrom, String)>,
    /// Starts tried, failed ones included.
    pub n_starts: usize,
    /// The free parameters (indices into the full vector).
    free: Vec<usize>,
}

/// `n` quasi-random starts: points 1..=n of the Halton sequence over the free parameters
/// (bases 2, 3, 5, … in their order), each coordinate mapped through its prior's
/// [`crate::prior::PriorKind::quantile`]; the fixed parameters keep their values in `base`.
/// Deterministic: the same prior gives the same starts.
pub fn quasi_random_starts(prior: &Prior, base: &[f64], free: &[usize], n: usize) -> Vec<MapStart> {
    let primes = first_primes(free.len());
    (1..=n)
        .map(|k| {
            let mut th = base.to_vec();
            for (j, &i) in free.iter().enumerate() {
                th[i] = prior.kinds()[i].quantile(radical_inverse(k as u64, primes[j]));
            }
            MapStart {
                from: StartFrom::QuasiRandom(k),
                theta: th,
            }
        })
        .collect()
}

/// The van der Corput radical inverse of `k` in base `b`: the digits of `k` mirrored about
/// the point.
fn radical_inverse(mut k: u64, b: u64) -> f64 {
    let (mut x, mut f) = (0.0, 1.0 / b as f64);
    while k > 0 {
        x += (k % b) as f64 * f;
        k /= b;
        f /= b as f64;
    }
    x
}

fn first_primes(n: usize) -> Vec<u64> {
    let mut p: Vec<u64> = Vec::with_capacity(n);
    let mut c = 2u64;
    while p.len() < n {
        if p.iter()
            .take_while(|&&q| q * q <= c)
            .all(|&q| !c.is_multiple_of(q))
        {
            p.push(c);
        }
        c += 1;
    }
    p
}

/// [`fisher_scoring`] on `lik` from every start (in parallel; the result does not depend on
/// the number of threads), the ends grouped into distinct maxima (module docs). Fails, with
/// the first start's error, only when every search fails.
pub fn multi_start_map(
    lik: &Likelihood,
    starts: &[MapStart],
    free: &[usize],
    tol: f64,
    max_iter: usize,
) -> Result<MultiStartMap, MapError> {
    multi_start(
        starts,
        free,
        |th| fisher_scoring(lik, th, free, tol, max_iter),
        |th| cramer_rao_scale(lik, th, free),
    )
}

/// Cramér–Rao σ of the free parameters at `th`; `10⁻³` prior widths where the Fisher matrix
/// is singular.
fn cramer_rao_scale(lik: &Likelihood, th: &[f64], free: &[usize]) -> Vec<f64> {
    let inv = SpdOptions::lower()
        .jacobi()
        .factor(&fisher_exact(lik, th, free))
        .ok()
        .map(|c| c.inverse());
    free.iter()
        .enumerate()
        .map(|(k, &i)| {
            let s = inv.as_ref().map_or(f64::NAN, |m| m[(k, k)].sqrt());
            if s.is_finite() && s > 0.0 {
                s
            } else {
                1e-3 * lik.prior().kinds()[i].sd() * 12f64.sqrt()
            }
        })
        .collect()
}

/// The search behind [`multi_start_map`], over any local search and scale (so the grouping
/// can be tested on analytic objectives).
pub(crate) fn multi_start<S, F>(
    starts: &[MapStart],
    free: &[usize],
    search: S,
    scale: F,
) -> Result<MultiStartMap, MapError>
where
    S: Fn(&[f64]) -> Result<ScoringResult, MapError> + Sync,
    F: Fn(&[f64]) -> Vec<f64>,
{
    let ends: Vec<Result<ScoringResult, MapError>> =
        starts.par_iter().map(|s| search(&s.theta)).collect();
    let mut out = MultiStartMap {
        maxima: Vec::new(),
        failed: Vec::new(),
        n_starts: 0,
        free: free.to_vec(),
    };
    let mut first_err = None;
    for (s, end) in starts.iter().zip(ends) {
        match end {
            Ok(r) => out.add(s.from, r, &scale),
            // a given start outside the prior is the study's mistake, not a basin to skip
            Err(e @ MapError::StartOutsidePrior(_)) if s.from == StartFrom::Given => {
                return Err(e);
            }
            Err(e) => {
                out.n_starts += 1;
                out.failed.push((s.from, e.to_string()));
                first_err.get_or_insert(e);
            }
        }
    }
    match (out.maxima.is_empty(), first_err) {
        (true, Some(e)) => Err(e),
        _ => Ok(out),
    }
}

impl MultiStartMap {
    /// The highest maximum.
    pub fn best(&self) -> &Maximum {
        &self.maxima[0]
    }

    /// After the chains ran: when their best sample `theta` (a full vector) lies higher on
    /// the search's surface (the Whittle `ln L + ln π`) than the highest maximum by more than
    /// [`CHAIN_MARGIN`] nats, the chains found a basin the starts missed: searches from there
    /// and adds the end. Returns `None` when no search was needed, else whether the highest
    /// maximum changed.
    pub fn search_from_chains(
        &mut self,
        lik: &Likelihood,
        theta: &[f64],
        tol: f64,
        max_iter: usize,
    ) -> Option<bool> {
        let lp = lik.prior().ln_pdf(theta) + lik.ln_likelihood_whittle(theta);
        let free = self.free.clone();
        self.climb(
            lp,
            theta,
            |th| fisher_scoring(lik, th, &free, tol, max_iter),
            &|th: &[f64]| cramer_rao_scale(lik, th, &free),
        )
    }

    /// [`Self::search_from_chains`] over any local search and scale; `lp` is the search's
    /// objective at `theta`.
    pub(crate) fn climb<S>(
        &mut self,
        lp: f64,
        theta: &[f64],
        search: S,
        scale: &dyn Fn(&[f64]) -> Vec<f64>,
    ) -> Option<bool>
    where
        S: Fn(&[f64]) -> Result<ScoringResult, MapError>,
    {
        if !(lp > self.best().result.ln_posterior + CHAIN_MARGIN) {
            return None;
        }
        let before = self.best().result.theta.clone();
        match search(theta) {
            Ok(r) => self.add(StartFrom::ChainOptimum, r, scale),
            Err(e) => {
                self.n_starts += 1;
                self.failed.push((StartFrom::ChainOptimum, e.to_string()));
            }
        }
        Some(self.best().result.theta != before)
    }

    fn add(&mut self, from: StartFrom, r: ScoringResult, scale: &dyn Fn(&[f64]) -> Vec<f64>) {
        self.n_starts += 1;
        let free = &self.free;
        let same = self.maxima.iter_mut().find(|m| {
            free.iter()
                .zip(&m.scale)
                .all(|(&i, s)| (m.result.theta[i] - r.theta[i]).abs() < *s)
        });
        match same {
            // a start that ends higher in the same basin by more than the margin (a search
            // that stopped short, on a flat or bounded direction) replaces the kept end
            Some(m) if r.ln_posterior > m.result.ln_posterior + CHAIN_MARGIN => {
                m.reached_by += 1;
                m.from = from;
                m.scale = scale(&r.theta);
                m.result = r;
                self.sort();
            }
            Some(m) => m.reached_by += 1,
            None => {
                let sc = scale(&r.theta);
                self.maxima.push(Maximum {
                    from,
                    result: r,
                    reached_by: 1,
                    scale: sc,
                });
                self.sort();
            }
        }
    }

    /// Highest `ln π` first; stable, so among equal ones the earlier start stays first.
    fn sort(&mut self) {
        self.maxima.sort_by(|a, b| {
            b.result
                .ln_posterior
                .partial_cmp(&a.result.ln_posterior)
                .unwrap_or(std::cmp::Ordering::Equal)
        });
    }

    /// `ln` of maximum `m`'s Laplace mass relative to the highest's: the height difference
    /// plus the ratio of their volumes, from the Cramér–Rao σ of the free parameters
    /// (correlations left out: the volumes' ratio is an order of magnitude, and the margin of
    /// [`NEGLIGIBLE_LN_MASS`] is many of those).
    fn ln_mass_ratio(&self, m: &Maximum) -> f64 {
        let top = self.best();
        let ln_volume: f64 = m
            .scale
            .iter()
            .zip(&top.scale)
            .map(|(a, b)| (a / b).ln())
            .sum();
        m.result.ln_posterior - top.result.ln_posterior + ln_volume
    }

    /// Whether [`MultiStartMap::describe`]'s line states a fact, not a problem: no start
    /// failed and every maximum but the highest is more than [`NEGLIGIBLE_LN_MASS`] below it
    /// in Laplace mass, so the MAP the run uses is the posterior's and nothing else counts.
    pub fn is_fact(&self) -> bool {
        self.failed.is_empty()
            && self.maxima[1..].iter().all(|m| {
                let r = self.ln_mass_ratio(m);
                r.is_finite() && r < -NEGLIGIBLE_LN_MASS
            })
    }

    /// One line for a run's notes: the starts, the distinct maxima with their `ln L + ln π`,
    /// where each came from and the parameters (of `names`, the full vector's) that set it
    /// apart from the highest, and the failures; `None` when every start ended at one maximum.
    pub fn describe(&self, names: &[String]) -> Option<String> {
        if self.maxima.len() < 2 && self.failed.is_empty() {
            return None;
        }
        let top = self.best();
        let best = top.result.ln_posterior;
        let maxima: Vec<String> = self
            .maxima
            .iter()
            .map(|m| {
                let lp = m.result.ln_posterior;
                let mut apart: Vec<(f64, usize)> = self
                    .free
                    .iter()
                    .zip(&top.scale)
                    .map(|(&i, s)| ((m.result.theta[i] - top.result.theta[i]).abs() / s, i))
                    .filter(|(z, _)| *z >= 1.0)
                    .collect();
                apart.sort_by(|a, b| b.0.total_cmp(&a.0));
                let at: Vec<String> = apart
                    .iter()
                    .take(3)
                    .map(|&(_, i)| {
                        format!("{} = {}", names[i], fmt_short_sig(m.result.theta[i], 4))
                    })
                    .collect();
                let rank = if std::ptr::eq(m, top) {
                    "the highest".to_string()
                } else {
                    format!(
                        "{} nats below, at {}",
                        fmt_fixed(best - lp, 2),
                        at.join(", ")
                    )
                };
                format!(
                    "ln π = {lp:.2} ({rank}; from {}, reached by {} of the starts)",
                    m.from, m.reached_by
                )
            })
            .collect();
        let mut s = format!(
            "MAP search from {} starts: {} distinct {}: {}",
            self.n_starts,
            self.maxima.len(),
            if self.maxima.len() == 1 {
                "maximum"
            } else {
                "maxima"
            },
            maxima.join("; ")
        );
        if !self.failed.is_empty() {
            let f: Vec<String> = self
                .failed
                .iter()
                .map(|(from, e)| format!("{from}: {e}"))
                .collect();
            s.push_str(&format!("; failed: {}", f.join("; ")));
        }
        if self.is_fact() {
            s.push_str(&format!(
                "; {NO_MASS} (each less than e^−{NEGLIGIBLE_LN_MASS:.0} of the highest's by its Laplace mass), so the chains and the evidence do not see them"
            ));
        }
        Some(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::prior::PriorKind;

    /// A 1-D objective with two maxima: `ln π = 0` at `x = −1` (basin `x < 0.5`) and `5` at
    /// `x = 2` (a search from `[0.5, 0.6)` stops short at 2.05, `ln π = 3`); the "search" jumps to the maximum of the basin it starts in, landing `1e−9`
    /// off when it starts right of the maximum (two ends of one basin differ slightly, as
    /// real searches do). Parameter 0 is fixed at 7; parameter 1 is free.
    fn search(th: &[f64]) -> Result<ScoringResult, MapError> {
        let x = th[1];
        if x.is_nan() {
            return Err(MapError::StartOutsidePrior("x".into()));
        }
        if x.is_infinite() {
            return Err(MapError::NonFinite {
                what: "ln L".into(),
                params: vec!["x".into()],
                theta: th.to_vec(),
            });
        }
        let (at, lp) = if x < 0.5 {
            (-1.0, 0.0)
        } else if x < 0.6 {
            // a search that stops short of the maximum, within its σ, 2 nats below
            (2.05, 3.0)
        } else {
            (2.0, 5.0)
        };
        let off = if x > at { 1e-9 } else { 0.0 };
        Ok(ScoringResult {
            theta: vec![th[0], at + off],
            ln_posterior: lp + off,
            iterations: 3,
            converged: true,
            at_bound: vec![false],
        })
    }

    fn scale(_: &[f64]) -> Vec<f64> {
        vec![0.1]
    }

    fn start(from: StartFrom, x: f64) -> MapStart {
        MapStart {
            from,
            theta: vec![7.0, x],
        }
    }

    fn names() -> Vec<String> {
        vec!["fixed".into(), "x".into()]
    }

    #[test]
    fn radical_inverse_mirrors_the_digits() {
        assert_eq!(radical_inverse(1, 2), 0.5);
        assert_eq!(radical_inverse(2, 2), 0.25);
        assert_eq!(radical_inverse(3, 2), 0.75);
        assert!((radical_inverse(5, 3) - (2.0 / 3.0 + 1.0 / 9.0)).abs() < 1e-15);
        assert_eq!(first_primes(6), vec![2, 3, 5, 7, 11, 13]);
    }

    #[test]
    fn quasi_random_starts_fill_the_box_and_keep_fixed_values() {
        let prior = Prior::new(
            vec!["a".into(), "b".into(), "c".into()],
            vec![
                PriorKind::Uniform { lo: 0.0, hi: 4.0 },
                PriorKind::Uniform { lo: -1.0, hi: 1.0 },
                PriorKind::LogUniform { lo: 1.0, hi: 1e4 },
            ],
        )
        .unwrap();
        let s = quasi_random_starts(&prior, &[1.0, 0.5, 10.0], &[0, 2], 8);
        assert_eq!(s.len(), 8);
        assert_eq!(s[0].from, StartFrom::QuasiRandom(1));
        // a: base 2 on [0, 4]; c: base 3 in log10 on [0, 4]
        assert_eq!(s[0].theta[0], 2.0);
        assert!((s[0].theta[2].log10() - 4.0 / 3.0).abs() < 1e-12);
        assert_eq!(s[2].theta[0], 3.0);
        assert!(s.iter().all(|p| p.theta[1] == 0.5));
        assert!(s.iter().all(|p| prior.contains(&p.theta)));
        // every quarter of a's range is visited
        for q in 0..4 {
            assert!(s.iter().any(|p| (p.theta[0] / 1.0).floor() as i32 == q));
        }
        assert_eq!(
            s,
            quasi_random_starts(&prior, &[1.0, 0.5, 10.0], &[0, 2], 8)
        );
    }

    #[test]
    fn the_highest_maximum_wins_and_every_distinct_one_is_listed() {
        let starts = [
            start(StartFrom::Given, -0.5),
            start(StartFrom::QuasiRandom(1), 0.0),
            start(StartFrom::QuasiRandom(2), 3.0),
        ];
        let ms = multi_start(&starts, &[1], search, scale).unwrap();
        assert_eq!(ms.n_starts, 3);
        assert_eq!(ms.maxima.len(), 2);
        assert_eq!(ms.best().from, StartFrom::QuasiRandom(2));
        assert_eq!(ms.best().result.theta[1], 2.0 + 1e-9);
        assert_eq!(ms.best().result.theta[0], 7.0);
        assert_eq!(ms.maxima[1].from, StartFrom::Given);
        assert_eq!(ms.maxima[1].reached_by, 2);
        let d = ms.describe(&names()).unwrap();
        assert!(d.contains("3 starts: 2 distinct maxima"), "{d}");
        assert!(d.contains("5.00 nats below, at x = -1.000"), "{d}");
        assert!(d.contains("from quasi-random start 2"), "{d}");
        // 5 nats below, as wide: e^−5 of the mass, which the chains may see — a warning
        assert!(!ms.is_fact() && !d.contains(NO_MASS), "{d}");
    }

    /// A maximum far below the highest holds no posterior mass: the line says so and is a fact
    /// (issue 52's walk: `two-mass-damper` warned of one 144 nats below); a wider one counts
    /// its volume, and a failed start keeps the line a warning.
    #[test]
    fn a_maximum_far_below_the_highest_is_a_fact() {
        let deep = |th: &[f64]| {
            search(th).map(|mut r| {
                if r.ln_posterior < 1.0 {
                    r.ln_posterior -= 30.0;
                }
                r
            })
        };
        let starts = [
            start(StartFrom::Given, 3.0),
            start(StartFrom::QuasiRandom(1), 0.0),
        ];
        let ms = multi_start(&starts, &[1], deep, scale).unwrap();
        assert_eq!(ms.maxima.len(), 2);
        assert!(ms.is_fact());
        let d = ms.describe(&names()).unwrap();
        assert!(d.contains("35.00 nats below") && d.contains(NO_MASS), "{d}");
        // 35 nats below but e^20 times as wide: e^−15 of the mass, not negligible
        let wide = |th: &[f64]| vec![if th[1] < 0.5 { 0.1 * 20f64.exp() } else { 0.1 }];
        let ms = multi_start(&starts, &[1], deep, wide).unwrap();
        assert!(!ms.is_fact());
        let failing = [
            starts[0].clone(),
            starts[1].clone(),
            start(StartFrom::QuasiRandom(2), f64::INFINITY),
        ];
        let ms = multi_start(&failing, &[1], deep, scale).unwrap();
        assert!(!ms.is_fact());
    }

    #[test]
    fn ends_of_one_basin_keep_the_start_of_highest_priority_exactly() {
        // the later start ends 1e-9 higher in the same basin: the given start's result stays,
        // bit for bit, so a study whose start reaches the global maximum keeps its numbers
        let starts = [
            start(StartFrom::Given, 1.0),
            start(StartFrom::QuasiRandom(1), 2.5),
        ];
        let ms = multi_start(&starts, &[1], search, scale).unwrap();
        assert_eq!(ms.maxima.len(), 1);
        assert_eq!(ms.best().from, StartFrom::Given);
        assert_eq!(ms.best().result, search(&starts[0].theta).unwrap());
        assert_eq!(ms.best().reached_by, 2);
        assert!(ms.describe(&names()).is_none());
    }

    #[test]
    fn an_end_that_stopped_short_is_replaced_by_a_higher_one_of_its_basin() {
        let starts = [
            start(StartFrom::Given, 0.55),
            start(StartFrom::QuasiRandom(1), 1.0),
        ];
        let ms = multi_start(&starts, &[1], search, scale).unwrap();
        assert_eq!(ms.maxima.len(), 1);
        assert_eq!(ms.best().from, StartFrom::QuasiRandom(1));
        assert_eq!(ms.best().result.ln_posterior, 5.0);
        assert_eq!(ms.best().reached_by, 2);
    }

    #[test]
    fn failed_starts_are_listed_and_only_all_failing_is_an_error() {
        let starts = [
            start(StartFrom::Given, f64::INFINITY),
            start(StartFrom::QuasiRandom(1), -3.0),
        ];
        let ms = multi_start(&starts, &[1], search, scale).unwrap();
        assert_eq!(ms.best().from, StartFrom::QuasiRandom(1));
        assert_eq!(ms.failed.len(), 1);
        let d = ms.describe(&names()).unwrap();
        assert!(
            d.contains("failed: the start point: MAP search: ln L is not finite"),
            "{d}"
        );
        let all_bad = [
            start(StartFrom::Given, f64::INFINITY),
            start(StartFrom::QuasiRandom(1), f64::NAN),
        ];
        let e = multi_start(&all_bad, &[1], search, scale).unwrap_err();
        assert!(matches!(e, MapError::NonFinite { .. }), "{e}");
        // the given start outside the prior is refused whatever the others find
        let given_outside = [
            start(StartFrom::Given, f64::NAN),
            start(StartFrom::QuasiRandom(1), 3.0),
        ];
        assert!(multi_start(&given_outside, &[1], search, scale).is_err());
    }

    #[test]
    fn a_chain_sample_above_the_maximum_starts_a_search_one_below_does_not() {
        let mut ms = multi_start(&[start(StartFrom::Given, 0.0)], &[1], search, scale).unwrap();
        // below or within the margin of the maximum: nothing to do
        assert_eq!(ms.climb(-0.3, &[7.0, -0.9], search, &scale), None);
        assert_eq!(
            ms.climb(CHAIN_MARGIN / 2.0, &[7.0, 1.0], search, &scale),
            None
        );
        // above it: the search from there finds the higher basin
        assert_eq!(ms.climb(3.0, &[7.0, 1.5], search, &scale), Some(true));
        assert_eq!(ms.best().from, StartFrom::ChainOptimum);
        assert_eq!(ms.maxima.len(), 2);
        // above the (new) maximum yet in its basin: searched, the maximum unchanged
        assert_eq!(ms.climb(6.0, &[7.0, 2.5], search, &scale), Some(false));
        assert_eq!(ms.best().reached_by, 2);
    }
}
