//! Known-answer, determinism, checkpoint and allocation tests of the sampler.
//!
//! Statistical tolerances come from the Monte-Carlo error measured on the chains themselves:
//! a mean is within `4 √(Σ_ii / ESS_i)`, a covariance entry within
//! `4 √((Σ_ii Σ_jj + Σ_ij²) / ESS_ij)` (the variance of a Gaussian product moment, with
//! `ESS_ij` the ESS of the product series). Seeds are fixed.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicUsize, Ordering};

use nalgebra::DMatrix;

use super::chain::ChainState;
use super::test_targets::GaussianTarget;
use super::*;
use crate::density::LogDensity;
use crate::prior::{Prior, PriorKind};

// Counts allocations per thread, so the hot-loop test sees only its own thread.
struct CountingAlloc;
thread_local! {
    static ALLOCS: Cell<u64> = const { Cell::new(0) };
}
fn bump() {
    let _ = ALLOCS.try_with(|c| c.set(c.get() + 1));
}
// SAFETY: forwards every call unchanged to the system allocator.
unsafe impl GlobalAlloc for CountingAlloc {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        bump();
        unsafe { System.alloc(l) }
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        unsafe { System.dealloc(p, l) }
    }
    unsafe fn alloc_zeroed(&self, l: Layout) -> *mut u8 {
        bump();
        unsafe { System.alloc_zeroed(l) }
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, n: usize) -> *mut u8 {
        bump();
        unsafe { System.realloc(p, l, n) }
    }
}
#[global_allocator]
static GLOBAL: CountingAlloc = CountingAlloc;

/// Proposal covariance `2.38²/D · Σ`: what the scaled inverse Fisher matrix is for a Gaussian.
fn optimal_cov(t: &GaussianTarget) -> DMatrix<f64> {
    &t.cov * (2.38f64.powi(2) / t.mu.len() as f64)
}

fn run(t: &GaussianTarget, cov: &DMatrix<f64>, s: MhSettings, start: &Start) -> Chains {
    MetropolisHastings::new(t, cov, s)
        .unwrap()
        .run(start)
        .unwrap()
        .into_chains()
        .unwrap()
}

/// Means and covariances against the truth within 4 Monte-Carlo standard errors.
fn check_moments(t: &GaussianTarget, ch: &Chains) {
    let d = t.mu.len();
    let diag = ch.diagnostics().unwrap();
    let mean = ch.mean();
    let cov = ch.covariance();
    for (i, (m, e)) in mean.iter().zip(&diag.ess).enumerate() {
        let tol = 4.0 * (t.cov[(i, i)] / e).sqrt();
        assert!(
            (m - t.mu[i]).abs() < tol,
            "D = {d}: mean {i} = {m} vs {} (tol {tol}, ESS {e})",
            t.mu[i]
        );
    }
    for i in 0..d {
        for j in 0..=i {
            let prods: Vec<Vec<f64>> = (0..ch.chains().len())
                .map(|c| {
                    (0..ch.n_kept())
                        .map(|k| {
                            let s = ch.sample(c, k);
                            (s[i] - mean[i]) * (s[j] - mean[j])
                        })
                        .collect()
                })
                .collect();
            let refs: Vec<&[f64]> = prods.iter().map(Vec::as_slice).collect();
            let e = ess(&refs).unwrap();
            let sij = t.cov[(i, j)];
            let se = ((t.cov[(i, i)] * t.cov[(j, j)] + sij * sij) / e).sqrt();
            assert!(
                (cov[i * d + j] - sij).abs() < 4.0 * se,
                "D = {d}: cov ({i},{j}) = {} vs {sij} (se {se}, ESS {e})",
                cov[i * d + j]
            );
        }
    }
}

#[test]
fn recovers_correlated_gaussians_in_2_5_10_dimensions() {
    for (d, seed) in [(2usize, 11u64), (5, 12), (10, 13)] {
        let t = GaussianTarget::correlated(d, 1e3, seed);
        let s = MhSettings {
            n_iter: 1_000 + 2_500 * d,
            burn_in: 1_000,
            n_chains: 4,
            seed,
            ..MhSettings::default()
        };
        let ch = run(
            &t,
            &optimal_cov(&t),
            s,
            &Start::Around {
                centre: t.mu.clone(),
                spread: 2.0,
            },
        );
        check_moments(&t, &ch);
        let diag = ch.diagnostics().unwrap();
        assert!(diag.warnings().is_empty(), "D = {d}: {:?}", diag.warnings());
        // Optimally scaled random walk: acceptance 0.44 in 1-D falling to 0.234 as D → ∞
        // (Roberts, Gelman & Gilks 1997).
        for a in &diag.acceptance {
            assert!((0.2..0.45).contains(a), "D = {d}: acceptance {a}");
        }
        // The maximum-posterior kept sample is a posterior draw near the mode: its squared
        // Mahalanobis distance is the minimum of ≥ 100 (ESS) roughly independent χ²_D draws.
        let mp = ch.max_posterior();
        assert!(t.mahalanobis2(mp.theta) < d as f64, "D = {d}");
        assert_eq!(mp.ln_posterior, t.ln_posterior(mp.theta));
    }
}

#[test]
fn adaptation_repairs_a_badly_shaped_proposal() {
    let d = 5;
    let t = GaussianTarget::correlated(d, 1e3, 21);
    // Diagonal proposal with tiny steps: ignores every correlation.
    let bad = DMatrix::from_fn(d, d, |i, j| if i == j { 1e-3 * t.cov[(i, i)] } else { 0.0 });
    let base = MhSettings {
        n_iter: 10_000,
        burn_in: 5_000,
        n_chains: 4,
        seed: 5,
        ..MhSettings::default()
    };
    let start = Start::Around {
        centre: t.mu.clone(),
        spread: 30.0,
    };
    let fixed = run(&t, &bad, base.clone(), &start);
    let adapted = run(
        &t,
        &bad,
        MhSettings {
            adapt: Some(Adapt {
                interval: 250,
                ..Adapt::default()
            }),
            ..base
        },
        &start,
    );
    check_moments(&t, &adapted);
    let (ef, ea) = (fixed.diagnostics().unwrap(), adapted.diagnostics().unwrap());
    let min = |v: &[f64]| v.iter().cloned().fold(f64::INFINITY, f64::min);
    // Same cost, far better mixing: the adapted chain's worst ESS beats the fixed one's by
    // more than 5×.
    assert!(
        min(&ea.ess) > 5.0 * min(&ef.ess),
        "{:?} vs {:?}",
        ea.ess,
        ef.ess
    );
    assert!(ea.warnings().is_empty(), "{:?}", ea.warnings());
}

#[test]
fn annealed_search_finds_the_mode_from_far_away() {
    let d = 5;
    let t = GaussianTarget::correlated(d, 1e3, 31);
    let far: Vec<f64> = (0..d).map(|k| t.mu[k] + 15.0 * t.sd(k)).collect();
    let s = MhSettings {
        n_iter: 14_000,
        burn_in: 4_000,
        n_chains: 2,
        seed: 9,
        anneal: Some(Anneal::new(1_000, 3_000)),
        ..MhSettings::default()
    };
    let ch = run(&t, &optimal_cov(&t), s, &Start::Point(far.clone()));
    assert!(t.mahalanobis2(&far) > 1e4);
    // The best point visited has the smallest Mahalanobis distance of thousands of draws;
    // P(χ²_5 < 1) = 0.037, so among ≥ 200 effectively independent draws one is below 1
    // except with probability 0.963²⁰⁰ ≈ 5e-4.
    let best = ch.best_visited();
    assert!(
        t.mahalanobis2(&best.theta) < 1.0,
        "{}",
        t.mahalanobis2(&best.theta)
    );
    for c in ch.chains() {
        // The 1e3× and 1e4× jumps leave the ±20σ box.
        assert!(c.counts.burn_in.prior_rejected > 0);
        assert_eq!(c.counts.sampling.proposed, 10_000);
    }
    check_moments(&t, &ch);
}

fn bits(ch: &Chains) -> Vec<u64> {
    let mut v = Vec::new();
    for c in ch.chains() {
        v.extend(c.samples.iter().map(|x| x.to_bits()));
        v.extend(c.ln_posterior.iter().map(|x| x.to_bits()));
        v.extend(c.ln_likelihood.iter().map(|x| x.to_bits()));
        v.extend(c.accepted.iter().map(|&a| a as u64));
        v.extend(c.best.theta.iter().map(|x| x.to_bits()));
        v.extend(c.proposal_covariance.iter().map(|x| x.to_bits()));
        v.push(c.best.ln_posterior.to_bits());
        let k = c.counts;
        for p in [k.burn_in, k.sampling, k.independent] {
            v.extend([p.proposed, p.accepted, p.prior_rejected, p.non_finite]);
        }
    }
    v
}

/// Settings that exercise every piece of state: annealing, adaptation, thinning.
fn full_settings() -> MhSettings {
    MhSettings {
        n_iter: 3_000,
        burn_in: 1_500,
        thin: 3,
        n_chains: 3,
        seed: 77,
        anneal: Some(Anneal::new(300, 600)),
        adapt: Some(Adapt {
            start: 600,
            interval: 100,
            ..Adapt::default()
        }),
        checkpoint_every: 250,
        ..MhSettings::default()
    }
}

#[test]
fn numbers_do_not_depend_on_the_thread_count() {
    let t = GaussianTarget::correlated(3, 1e3, 41);
    let cov = optimal_cov(&t);
    let start = Start::Around {
        centre: t.mu.clone(),
        spread: 3.0,
    };
    let with_threads = |n: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .unwrap()
            .install(|| run(&t, &cov, full_settings(), &start))
    };
    let one = with_threads(1);
    let three = with_threads(3);
    assert_eq!(bits(&one), bits(&three));
    assert_eq!(one, three);
}

#[test]
fn resume_ends_with_exactly_the_uninterrupted_chains() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("mh.cbor");
    let t = GaussianTarget::correlated(3, 1e3, 51);
    let cov = optimal_cov(&t);
    let start = Start::Around {
        centre: t.mu.clone(),
        spread: 3.0,
    };
    let reference = run(&t, &cov, full_settings(), &start);

    // Killed after 3 blocks of 250 iterations (inside the adaptation window).
    let stop = |done: usize| done >= 750;
    let outcome = MetropolisHastings::new(&t, &cov, full_settings())
        .unwrap()
        .checkpoint(&path)
        .stop_when(&stop)
        .run(&start)
        .unwrap();
    assert_eq!(outcome, RunOutcome::Stopped { iterations: 750 });
    assert!(path.exists());
    let leftovers: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert_eq!(leftovers.len(), 1, "temporary file left behind");

    // A new driver, as a new process would build, with a different block length.
    let resumed = MetropolisHastings::new(
        &t,
        &cov,
        MhSettings {
            checkpoint_every: 400,
            ..full_settings()
        },
    )
    .unwrap()
    .checkpoint(&path)
    .resume(&path)
    .unwrap()
    .into_chains()
    .unwrap();
    assert_eq!(bits(&resumed), bits(&reference));

    // The final checkpoint of a finished run can be extended to a longer run.
    let longer = MhSettings {
        n_iter: 4_500,
        ..full_settings()
    };
    let extended = MetropolisHastings::new(&t, &cov, longer.clone())
        .unwrap()
        .resume(&path)
        .unwrap()
        .into_chains()
        .unwrap();
    assert_eq!(bits(&extended), bits(&run(&t, &cov, longer, &start)));
}

/// Stopping once converged ([`MetropolisHastings::until`]): the run ends early, at the same
/// iteration with the same numbers whatever the threads or where it was stopped and resumed,
/// and its chains meet the rule and recover the target.
#[test]
fn a_run_until_converged_ends_early_at_one_place_and_resumes_there() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("mh.cbor");
    let t = GaussianTarget::correlated(3, 1e2, 61);
    let cov = optimal_cov(&t);
    let start = Start::Around {
        centre: t.mu.clone(),
        spread: 2.0,
    };
    let settings = MhSettings {
        n_iter: 50_000,
        burn_in: 500,
        n_chains: 4,
        seed: 5,
        checkpoint_every: 1_000,
        ..MhSettings::default()
    };
    let rule = Until::new(400.0, 1.01, 100).unwrap();
    let go = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                MetropolisHastings::new(&t, &cov, settings.clone())
                    .unwrap()
                    .until(rule)
                    .run(&start)
                    .unwrap()
            })
    };
    let one = go(1);
    let RunOutcome::Converged { chains, iterations } = &one else {
        panic!("did not converge before n_iter: {one:?}");
    };
    assert_eq!(*iterations % 100, 0);
    assert!(*iterations < 10_000, "{iterations}");
    assert_eq!(go(3), one);
    let diag = chains.diagnostics().unwrap();
    assert!(diag.ess.iter().all(|&e| e >= 400.0), "{:?}", diag.ess);
    assert!(diag.rhat.iter().all(|&r| r <= 1.01), "{:?}", diag.rhat);
    // ... and not before: 100 iterations less do not meet it
    let short = run(
        &t,
        &cov,
        MhSettings {
            n_iter: iterations - 100,
            ..settings.clone()
        },
        &start,
    );
    let d = short.diagnostics().unwrap();
    assert!(
        d.ess.iter().any(|&e| e < 400.0) || d.rhat.iter().any(|&r| r > 1.01),
        "met at {} already",
        iterations - 100
    );
    check_moments(&t, chains);

    // killed after 750 (blocks of 250 end at the rule's multiples of 100 too: at 800),
    // resumed with other blocks
    let stop = |done: usize| done >= 750;
    let stopped = MetropolisHastings::new(
        &t,
        &cov,
        MhSettings {
            checkpoint_every: 250,
            ..settings.clone()
        },
    )
    .unwrap()
    .until(rule)
    .checkpoint(&path)
    .stop_when(&stop)
    .run(&start)
    .unwrap();
    assert_eq!(stopped, RunOutcome::Stopped { iterations: 800 });
    let resumed = MetropolisHastings::new(&t, &cov, settings.clone())
        .unwrap()
        .until(rule)
        .checkpoint(&path)
        .resume(&path)
        .unwrap();
    assert_eq!(resumed, one);
    // resumed once more from the converged checkpoint: nothing more runs
    let again = MetropolisHastings::new(&t, &cov, settings.clone())
        .unwrap()
        .until(rule)
        .resume(&path)
        .unwrap();
    assert_eq!(again, one);

    // a walk that barely moves never meets it and runs its n_iter
    let tiny = &cov * 1e-6;
    let stuck = MetropolisHastings::new(
        &t,
        &tiny,
        MhSettings {
            n_iter: 3_000,
            ..settings.clone()
        },
    )
    .unwrap()
    .until(rule)
    .run(&start)
    .unwrap();
    assert!(matches!(stuck, RunOutcome::Finished(_)), "{stuck:?}");
}

/// A rule asked first at `n` ([`Until::at_least`], `select`'s in-model chains): chains that
/// meet it by `n` are those of a fixed run of `n`, bit for bit, however long the most is;
/// chains that do not go on, ending at `n` plus a multiple of `every` where they meet it.
#[test]
fn a_rule_asked_first_at_n_keeps_a_converged_run_of_n_and_extends_the_rest() {
    let t = GaussianTarget::correlated(3, 1e2, 61);
    let cov = optimal_cov(&t);
    let start = Start::Around {
        centre: t.mu.clone(),
        spread: 2.0,
    };
    let settings = |n_iter: usize| MhSettings {
        n_iter,
        burn_in: 500,
        n_chains: 4,
        seed: 5,
        checkpoint_every: 700,
        ..MhSettings::default()
    };
    let rule = Until::new(400.0, 1.01, 100).unwrap();
    let extended = |n: usize| {
        MetropolisHastings::new(&t, &cov, settings(40_000))
            .unwrap()
            .until(rule.at_least(n))
            .run(&start)
            .unwrap()
    };
    // met by 20 000 (the rule alone ends far earlier): exactly the fixed run of 20 000
    let long = extended(20_000);
    let fixed = run(&t, &cov, settings(20_000), &start);
    assert_eq!(
        long,
        RunOutcome::Converged {
            chains: fixed,
            iterations: 20_000
        }
    );
    // not met by 1 050 (the rule alone ends later, at a multiple of 100): on to the first
    // 1 050 + k·100 that meets it
    let RunOutcome::Converged {
        iterations: alone, ..
    } = MetropolisHastings::new(&t, &cov, settings(40_000))
        .unwrap()
        .until(rule)
        .run(&start)
        .unwrap()
    else {
        panic!("the rule alone never met")
    };
    assert!(alone > 1_100, "{alone}");
    let RunOutcome::Converged { chains, iterations } = extended(1_050) else {
        panic!("not met by 40 000")
    };
    assert_eq!((iterations - 1_050) % 100, 0);
    assert!(
        (alone - 50..=alone + 50).contains(&iterations),
        "{iterations} vs {alone}"
    );
    let d = chains.diagnostics().unwrap();
    assert!(d.ess.iter().all(|&e| e >= 400.0) && d.rhat.iter().all(|&r| r <= 1.01));
}

/// Stopping on a diagnostic is optional stopping: a run ends when its ESS happens to look
/// large, which could leave its Monte-Carlo errors short. Over 400 runs of a 2-D Gaussian
/// stopped at ESS ≥ 400 and R̂ ≤ 1.01, the mean's error `(mean − μ)/mcse` has RMS
/// within 1 ± 0.12 per parameter (the RMS of 400 unit normals has sd 0.035; error bars 20 %
/// off give 0.83 or 1.25 and fail).
#[test]
fn stopping_at_convergence_keeps_the_mean_s_error_bar() {
    let t = GaussianTarget::correlated(2, 10.0, 71);
    let cov = optimal_cov(&t);
    let rule = Until::new(400.0, 1.01, 50).unwrap();
    let n = 400;
    let mut z2 = [0.0; 2];
    let mut lengths = Vec::with_capacity(n);
    for seed in 0..n as u64 {
        let settings = MhSettings {
            n_iter: 20_000,
            burn_in: 300,
            n_chains: 4,
            seed: 1_000 + seed,
            ..MhSettings::default()
        };
        let out = MetropolisHastings::new(&t, &cov, settings)
            .unwrap()
            .until(rule)
            .run(&Start::Around {
                centre: t.mu.clone(),
                spread: 2.0,
            })
            .unwrap();
        let RunOutcome::Converged { chains, iterations } = out else {
            panic!("seed {seed} did not converge");
        };
        lengths.push(iterations);
        let diag = chains.diagnostics().unwrap();
        for k in 0..2 {
            let z = (diag.mean[k] - t.mu[k]) / diag.mcse[k];
            z2[k] += z * z;
        }
    }
    lengths.sort_unstable();
    let rms: Vec<f64> = z2.iter().map(|s| (s / n as f64).sqrt()).collect();
    eprintln!(
        "RMS z {rms:?}; iterations per chain: median {}, range {}–{}",
        lengths[n / 2],
        lengths[0],
        lengths[n - 1]
    );
    for r in rms {
        assert!((r - 1.0).abs() < 0.12, "RMS z {r}");
    }
}

/// The walk with an independence kernel mixed in ([`MetropolisHastings::independence`]),
/// half of the iterations drawn from a Student-t: exact where the Student-t is off-centre and
/// too wide (a correlated 10-D Gaussian, the proposal's centre 0.5 off in Mahalanobis
/// distance and its widths 1.3 times the target's), with several times the walk's ESS for the
/// same iterations; and at the edge
/// where a Laplace approximation breaks — the MAP on a corner of the prior box, where seven of
/// every eight draws fall outside it.
#[test]
fn an_independence_kernel_mixed_in_keeps_the_target() {
    let t = GaussianTarget::correlated(10, 1e3, 61);
    let l = t.cov.clone().cholesky().unwrap().l();
    let off = &l * nalgebra::DVector::from_element(10, 0.5 / 10f64.sqrt());
    let centre: Vec<f64> = (0..10).map(|i| t.mu[i] + off[i]).collect();
    let mix = || {
        Independence::new(
            0.5,
            StudentProposal::new(centre.clone(), &(&t.cov * 1.69), DEFAULT_DOF).unwrap(),
        )
        .unwrap()
    };
    let s = MhSettings {
        n_iter: 6_000,
        burn_in: 1_000,
        n_chains: 4,
        seed: 61,
        ..MhSettings::default()
    };
    let start = Start::Around {
        centre: t.mu.clone(),
        spread: 1.0,
    };
    let mixed = MetropolisHastings::new(&t, &optimal_cov(&t), s.clone())
        .unwrap()
        .independence(mix())
        .unwrap()
        .run(&start)
        .unwrap()
        .into_chains()
        .unwrap();
    check_moments(&t, &mixed);
    let walk = run(&t, &optimal_cov(&t), s, &start);
    let ess = |c: &Chains| {
        let d = c.diagnostics().unwrap();
        d.ess.iter().cloned().fold(f64::INFINITY, f64::min)
    };
    assert!(
        ess(&mixed) > 3.0 * ess(&walk),
        "ESS {} mixed, {} walk",
        ess(&mixed),
        ess(&walk)
    );
    for c in mixed.chains() {
        let (all, ind) = (c.counts.sampling, c.counts.independent);
        // a share of 0.5 of 5000 sampling iterations: 2500 ± 35
        assert!(
            (ind.proposed as f64 - 2500.0).abs() < 150.0,
            "{}",
            ind.proposed
        );
        assert!(ind.accepted > 0 && ind.accepted <= all.accepted);
    }
    // every coordinate is the box's top minus a half-Gaussian of sd 0.1: mean 1 − 0.1 √(2/π),
    // variance 0.01 (1 − 2/π)
    let corner = test_targets::CornerTarget {
        sd: 0.1,
        prior: Prior::new(
            vec!["a".into(), "b".into(), "c".into()],
            vec![PriorKind::Uniform { lo: 0.0, hi: 1.0 }; 3],
        )
        .unwrap(),
    };
    let q =
        StudentProposal::new(vec![1.0; 3], &(DMatrix::identity(3, 3) * 0.01), DEFAULT_DOF).unwrap();
    let ch = MetropolisHastings::new(
        &corner,
        &(DMatrix::identity(3, 3) * 0.01),
        MhSettings {
            n_iter: 21_000,
            burn_in: 1_000,
            n_chains: 2,
            seed: 62,
            ..MhSettings::default()
        },
    )
    .unwrap()
    .independence(Independence::new(0.5, q).unwrap())
    .unwrap()
    .run(&Start::Point(vec![0.9; 3]))
    .unwrap()
    .into_chains()
    .unwrap();
    let diag = ch.diagnostics().unwrap();
    let (m, v) = (
        1.0 - 0.1 * (2.0 / std::f64::consts::PI).sqrt(),
        0.01 * (1.0 - 2.0 / std::f64::consts::PI),
    );
    let cov = ch.covariance();
    for i in 0..3 {
        let tol = 4.0 * (v / diag.ess[i]).sqrt();
        assert!((diag.mean[i] - m).abs() < tol, "{} vs {m}", diag.mean[i]);
        // a half-Gaussian's variance of the squared deviation is 2.3 v², not the Gaussian 2 v²
        let tol = 4.0 * (2.3 * v * v / diag.ess[i]).sqrt();
        assert!(
            (cov[i * 3 + i] - v).abs() < tol,
            "{} vs {v}",
            cov[i * 3 + i]
        );
    }
    let ind: u64 = ch
        .chains()
        .iter()
        .map(|c| c.counts.independent.prior_rejected)
        .sum();
    let proposed: u64 = ch
        .chains()
        .iter()
        .map(|c| c.counts.independent.proposed)
        .sum();
    assert!((ind as f64 / proposed as f64 - 0.875).abs() < 0.02);
}

/// A log-normal ridge: `u = (ln τ, ln(−a))` Gaussian with centre `m` and a covariance of
/// widths 0.3 and correlation −0.95 — the shape of a short glitch's decay and amplitude — as a
/// density in `(τ, a)` (the Jacobian `1/(τ|a|)` in the likelihood, under a box holding all
/// but a negligible part of it).
struct Ridge {
    m: [f64; 2],
    prec: DMatrix<f64>,
    prior: Prior,
}

impl Ridge {
    fn cov() -> DMatrix<f64> {
        DMatrix::from_row_slice(2, 2, &[0.09, -0.0855, -0.0855, 0.09])
    }

    fn new() -> Self {
        let m = [3.6, 1.7];
        let kinds = vec![
            PriorKind::Uniform {
                lo: (m[0] - 4.0f64).exp(),
                hi: (m[0] + 4.0f64).exp(),
            },
            PriorKind::Uniform {
                lo: -(m[1] + 4.0f64).exp(),
                hi: -(m[1] - 4.0f64).exp(),
            },
        ];
        Self {
            m,
            prec: Self::cov().try_inverse().unwrap(),
            prior: Prior::new(vec!["tau".into(), "a".into()], kinds).unwrap(),
        }
    }
}

impl LogDensity for Ridge {
    fn ln_likelihood(&self, th: &[f64]) -> f64 {
        let u = nalgebra::Vector2::new(th[0].ln() - self.m[0], (-th[1]).ln() - self.m[1]);
        -0.5 * (u.transpose() * &self.prec * u)[(0, 0)] - th[0].ln() - (-th[1]).ln()
    }
    fn prior(&self) -> &Prior {
        &self.prior
    }
}

/// On the log-normal ridge ([`Ridge`]), an independence kernel drawing the two axes in
/// logarithm from the delta-method Gaussian at `(e^{m₀}, −e^{m₁})` — what `occam fit` makes of
/// a glitch's MAP and inverse Fisher matrix — is the target itself: nearly every draw is
/// accepted, and the chains' means and variances of `ln τ`, `ln |a|` are the target's within
/// four Monte-Carlo errors. The same Gaussian drawn in `(τ, a)` falls off the curved ridge:
/// about half of its draws are accepted (measured 0.52).
#[test]
fn log_axes_follow_a_ridge_in_logarithms() {
    let t = Ridge::new();
    let centre = vec![t.m[0].exp(), -t.m[1].exp()];
    // dx = x du (signed: along the ridge τ and a grow together, a being negative)
    let d = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(centre.clone()));
    let cov = &d * Ridge::cov() * &d;
    let s = MhSettings {
        n_iter: 6_000,
        burn_in: 1_000,
        n_chains: 4,
        seed: 64,
        ..MhSettings::default()
    };
    let chains = |axes: &[usize]| {
        let q = StudentProposal::new(centre.clone(), &cov, DEFAULT_DOF)
            .unwrap()
            .log_axes(axes)
            .unwrap();
        MetropolisHastings::new(&t, &(&cov * 2.38f64.powi(2) / 2.0), s.clone())
            .unwrap()
            .independence(Independence::new(0.8, q).unwrap())
            .unwrap()
            .run(&Start::Point(centre.clone()))
            .unwrap()
            .into_chains()
            .unwrap()
    };
    let accepted = |c: &Chains| {
        let (a, p) = c.chains().iter().fold((0, 0), |(a, p), c| {
            let i = c.counts.independent;
            (a + i.accepted, p + i.proposed)
        });
        a as f64 / p as f64
    };
    let log = chains(&[0, 1]);
    let lin = chains(&[]);
    eprintln!(
        "independence draws accepted: log axes {:.3}, linear {:.3}",
        accepted(&log),
        accepted(&lin)
    );
    assert!(accepted(&log) > 0.95, "{}", accepted(&log));
    assert!(accepted(&lin) < 0.7, "{}", accepted(&lin));
    // the log-coordinates' moments: means m, variances 0.09
    let diag = log.diagnostics().unwrap();
    for (k, f) in [|x: f64| x.ln(), |x: f64| (-x).ln()].iter().enumerate() {
        let u: Vec<f64> = (0..log.chains().len())
            .flat_map(|c| (0..log.n_kept()).map(move |j| (c, j)))
            .map(|(c, j)| f(log.sample(c, j)[k]))
            .collect();
        let n = u.len() as f64;
        let mean = u.iter().sum::<f64>() / n;
        let var = u.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n;
        // the ESS of the parameter itself stands for that of its logarithm
        let e = diag.ess[k];
        assert!(
            (mean - t.m[k]).abs() < 4.0 * (0.09 / e).sqrt(),
            "mean {k}: {mean}"
        );
        assert!(
            (var - 0.09).abs() < 4.0 * (2.0 * 0.09 * 0.09 / e).sqrt(),
            "var {k}: {var}"
        );
    }
}

/// A run with an independence kernel resumes bit for bit, and refuses a checkpoint written
/// without it.
#[test]
fn an_independence_kernel_resumes_and_is_checked() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("mh.cbor");
    let t = GaussianTarget::correlated(3, 1e3, 63);
    let cov = optimal_cov(&t);
    let mix = || {
        Independence::new(
            0.3,
            StudentProposal::new(t.mu.clone(), &t.cov, 8.0).unwrap(),
        )
        .unwrap()
    };
    let start = Start::Point(t.mu.clone());
    let build = || {
        MetropolisHastings::new(&t, &cov, full_settings())
            .unwrap()
            .independence(mix())
            .unwrap()
    };
    let reference = build().run(&start).unwrap().into_chains().unwrap();
    let stop = |done: usize| done >= 750;
    let outcome = build()
        .checkpoint(&path)
        .stop_when(&stop)
        .run(&start)
        .unwrap();
    assert_eq!(outcome, RunOutcome::Stopped { iterations: 750 });
    let resumed = build().resume(&path).unwrap().into_chains().unwrap();
    assert_eq!(bits(&resumed), bits(&reference));
    match MetropolisHastings::new(&t, &cov, full_settings())
        .unwrap()
        .resume(&path)
    {
        Err(SamplerError::CheckpointMismatch { field, .. }) => {
            assert_eq!(field, "independence proposal")
        }
        other => panic!("expected a mismatch, got {other:?}"),
    }
}

/// The acceptance flags: with `thin` = 1 they count exactly the accepted sampling proposals;
/// with thinning a flag says the state moved since the previous kept draw.
#[test]
fn acceptance_flags_match_the_counts_and_the_moves() {
    let t = GaussianTarget::correlated(3, 1e3, 61);
    let cov = optimal_cov(&t);
    let start = Start::Around {
        centre: t.mu.clone(),
        spread: 3.0,
    };
    let plain = run(
        &t,
        &cov,
        MhSettings {
            thin: 1,
            ..full_settings()
        },
        &start,
    );
    for c in plain.chains() {
        let n = c.accepted.iter().filter(|&&a| a).count() as u64;
        assert_eq!(n, c.counts.sampling.accepted);
        assert!(n > 0 && n < c.accepted.len() as u64, "{n}");
    }
    let thinned = run(&t, &cov, full_settings(), &start);
    let d = thinned.dim();
    for c in thinned.chains() {
        assert_eq!(c.accepted.len(), c.ln_posterior.len());
        for i in 1..c.accepted.len() {
            let moved = c.samples[i * d..(i + 1) * d] != c.samples[(i - 1) * d..i * d];
            assert_eq!(c.accepted[i], moved, "draw {i}");
        }
    }
}

/// Killed inside a thinning window of the sampling phase, a run resumes with the same flags;
/// a checkpoint of an older version (no flags) resumes with the flags rebuilt from the moves
/// (the first kept draw's an upper bound with thinning).
#[test]
fn resumed_and_upgraded_checkpoints_keep_the_flags() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("mh.cbor");
    let t = GaussianTarget::correlated(3, 1e3, 52);
    let cov = optimal_cov(&t);
    let start = Start::Around {
        centre: t.mu.clone(),
        spread: 3.0,
    };
    let reference = run(&t, &cov, full_settings(), &start);
    // 2 000 iterations: 500 into sampling, in the middle of a window of 3
    let stop = |done: usize| done >= 2_000;
    let outcome = MetropolisHastings::new(&t, &cov, full_settings())
        .unwrap()
        .checkpoint(&path)
        .stop_when(&stop)
        .run(&start)
        .unwrap();
    assert_eq!(outcome, RunOutcome::Stopped { iterations: 2_000 });
    let resume = |p: &std::path::Path| {
        MetropolisHastings::new(&t, &cov, full_settings())
            .unwrap()
            .resume(p)
            .unwrap()
            .into_chains()
            .unwrap()
    };
    assert_eq!(bits(&resume(&path)), bits(&reference));
    // the chains as an occam before the acceptance flags saved them
    let old = dir.path().join("old.cbor");
    edit_checkpoint(&path, &old, |payload| {
        for ch in entry(payload, "chains").as_array_mut().unwrap() {
            let o = ch.as_map_mut().unwrap();
            let before = o.len();
            o.retain(|(k, _)| !matches!(k.as_text(), Some("kept_accepted" | "moved")));
            assert_eq!(o.len(), before - 2);
        }
    });
    let upgraded = resume(&old);
    for (u, r) in upgraded.chains().iter().zip(reference.chains()) {
        assert_eq!(u.samples, r.samples);
        assert_eq!(u.accepted[1..], r.accepted[1..]);
        assert!(u.accepted[0] >= r.accepted[0]);
    }
}

/// The value under `key` of a CBOR map.
fn entry<'v>(map: &'v mut ciborium::Value, key: &str) -> &'v mut ciborium::Value {
    map.as_map_mut()
        .unwrap()
        .iter_mut()
        .find(|(k, _)| k.as_text() == Some(key))
        .map(|(_, v)| v)
        .unwrap_or_else(|| panic!("no `{key}`"))
}

/// Copies the checkpoint at `src` to `dst` with its payload edited by `f`.
fn edit_checkpoint(
    src: &std::path::Path,
    dst: &std::path::Path,
    f: impl FnOnce(&mut ciborium::Value),
) {
    let mut v: ciborium::Value = ciborium::from_reader(std::fs::File::open(src).unwrap()).unwrap();
    f(entry(&mut v, "payload"));
    ciborium::into_writer(&v, std::fs::File::create(dst).unwrap()).unwrap();
}

#[test]
fn mismatched_checkpoints_name_the_difference() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ck.cbor");
    let t = GaussianTarget::correlated(3, 1e3, 61);
    let cov = optimal_cov(&t);
    let s = MhSettings {
        n_iter: 500,
        burn_in: 100,
        n_chains: 2,
        checkpoint_every: 100,
        ..MhSettings::default()
    };
    MetropolisHastings::new(&t, &cov, s.clone())
        .unwrap()
        .checkpoint(&path)
        .run(&Start::Point(t.mu.clone()))
        .unwrap();
    let field_of =
        |t: &GaussianTarget, cov: &DMatrix<f64>, s: MhSettings| match MetropolisHastings::new(
            t, cov, s,
        )
        .unwrap()
        .resume(&path)
        {
            Err(SamplerError::CheckpointMismatch { field, .. }) => field,
            other => panic!("expected a mismatch, got {other:?}"),
        };
    assert_eq!(
        field_of(
            &t,
            &cov,
            MhSettings {
                seed: 2,
                ..s.clone()
            }
        ),
        "seed"
    );
    assert_eq!(
        field_of(
            &t,
            &cov,
            MhSettings {
                burn_in: 50,
                ..s.clone()
            }
        ),
        "burn_in"
    );
    assert_eq!(
        field_of(
            &t,
            &cov,
            MhSettings {
                n_chains: 3,
                ..s.clone()
            }
        ),
        "n_chains"
    );
    assert_eq!(
        field_of(
            &t,
            &cov,
            MhSettings {
                thin: 2,
                ..s.clone()
            }
        ),
        "thin"
    );
    assert_eq!(
        field_of(
            &t,
            &cov,
            MhSettings {
                n_iter: 400,
                ..s.clone()
            }
        ),
        "n_iter"
    );
    assert_eq!(
        field_of(
            &t,
            &cov,
            MhSettings {
                adapt: Some(Adapt {
                    interval: 10,
                    ..Adapt::default()
                }),
                ..s.clone()
            }
        ),
        "adapt"
    );
    assert_eq!(
        field_of(&t, &(&cov * 2.0), s.clone()),
        "proposal covariance"
    );
    // named by its first differing entry, not printed as two whole matrices
    let e = MetropolisHastings::new(&t, &(&cov * 2.0), s.clone())
        .unwrap()
        .resume(&path)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("proposal covariance is (") && !e.contains('\n') && e.len() < 400,
        "{e}"
    );
    let t4 = GaussianTarget::correlated(4, 1e3, 61);
    assert_eq!(field_of(&t4, &optimal_cov(&t4), s.clone()), "dimension");
    // Same prior box, different mean: only the stored ln posterior can tell.
    let moved = t.shifted(0.1);
    assert!(field_of(&moved, &cov, s.clone()).starts_with("ln posterior"));
    // A state whose kept samples do not match its iteration count.
    let tampered = dir.path().join("tampered.cbor");
    edit_checkpoint(&path, &tampered, |payload| {
        let ch = &mut entry(payload, "chains").as_array_mut().unwrap()[1];
        entry(ch, "kept_ln_post").as_array_mut().unwrap().pop();
    });
    match MetropolisHastings::new(&t, &cov, s.clone())
        .unwrap()
        .resume(&tampered)
    {
        Err(SamplerError::Checkpoint { problem, .. }) => {
            assert!(problem.contains("chain 1"), "{problem}")
        }
        other => panic!("{other:?}"),
    }
    // Unreadable files.
    let missing = MetropolisHastings::new(&t, &cov, s.clone())
        .unwrap()
        .resume(dir.path().join("nope.cbor"));
    assert!(matches!(missing, Err(SamplerError::Checkpoint { .. })));
    std::fs::write(&path, "{\"format\": 1}").unwrap();
    let garbage = MetropolisHastings::new(&t, &cov, s).unwrap().resume(&path);
    assert!(matches!(garbage, Err(SamplerError::Checkpoint { .. })));
}

/// Standard normal likelihood whose `ln L` is NaN above 1, under a uniform prior on
/// [−1.5, 1.5]: the posterior is N(0, 1) truncated to [−1.5, 1].
struct HoleyNormal {
    prior: Prior,
}

impl LogDensity for HoleyNormal {
    fn ln_likelihood(&self, t: &[f64]) -> f64 {
        if t[0] > 1.0 {
            f64::NAN
        } else {
            -0.5 * t[0] * t[0]
        }
    }
    fn prior(&self) -> &Prior {
        &self.prior
    }
}

#[test]
fn prior_rejections_and_non_finite_likelihoods_are_counted_rejections() {
    let target = HoleyNormal {
        prior: Prior::new(
            vec!["x".into()],
            vec![PriorKind::Uniform { lo: -1.5, hi: 1.5 }],
        )
        .unwrap(),
    };
    let s = MhSettings {
        n_iter: 41_000,
        burn_in: 1_000,
        n_chains: 2,
        seed: 3,
        ..MhSettings::default()
    };
    let ch = MetropolisHastings::new(&target, &DMatrix::from_element(1, 1, 1.0), s)
        .unwrap()
        .run(&Start::Point(vec![0.0]))
        .unwrap()
        .into_chains()
        .unwrap();
    for c in ch.chains() {
        let k = c.counts.sampling;
        assert!(k.prior_rejected > 0 && k.non_finite > 0, "{k:?}");
        assert_eq!(k.proposed, 40_000);
        assert!(k.accepted + k.prior_rejected + k.non_finite <= k.proposed);
        assert!(c.samples.iter().all(|&x| (-1.5..=1.0).contains(&x)));
    }
    // Truncated-normal moments on [a, b] = [−1.5, 1]: mean (φ(a) − φ(b)) / (Φ(b) − Φ(a)).
    let phi = |x: f64| (-0.5 * x * x).exp() / (2.0 * std::f64::consts::PI).sqrt();
    let cdf = |x: f64| 0.5 * (1.0 + statrs::function::erf::erf(x / std::f64::consts::SQRT_2));
    let (a, b) = (-1.5, 1.0);
    let z = cdf(b) - cdf(a);
    let mean = (phi(a) - phi(b)) / z;
    let var = 1.0 + (a * phi(a) - b * phi(b)) / z - mean * mean;
    let diag = ch.diagnostics().unwrap();
    let tol = 4.0 * (var / diag.ess[0]).sqrt();
    assert!(
        (ch.mean()[0] - mean).abs() < tol,
        "{} vs {mean} ± {tol}",
        ch.mean()[0]
    );
    let w = diag.warnings();
    assert!(
        w.iter().any(|w| matches!(w, Warning::NonFinite { .. })),
        "{w:?}"
    );
    assert!(
        w.iter().all(|w| matches!(w, Warning::NonFinite { .. })),
        "{w:?}"
    );
}

#[test]
fn bad_starts_and_covariances_are_clear_errors() {
    let t = GaussianTarget::correlated(2, 10.0, 71);
    let cov = optimal_cov(&t);
    let s = MhSettings {
        n_iter: 100,
        burn_in: 10,
        n_chains: 2,
        ..MhSettings::default()
    };
    let mh = MetropolisHastings::new(&t, &cov, s.clone()).unwrap();
    let outside = vec![t.mu[0] + 100.0 * t.sd(0), t.mu[1]];
    match mh.run(&Start::Point(outside)) {
        Err(SamplerError::Start { chain: 0, problem }) => {
            assert!(problem.contains("`p0`"), "{problem}")
        }
        other => panic!("{other:?}"),
    }
    match mh.run(&Start::Point(vec![0.0])) {
        Err(SamplerError::Start { problem, .. }) => {
            assert!(problem.contains("1 entries"), "{problem}")
        }
        other => panic!("{other:?}"),
    }
    match mh.run(&Start::PerChain(vec![t.mu.clone()])) {
        Err(SamplerError::Setting { field: "start", .. }) => {}
        other => panic!("{other:?}"),
    }
    match MetropolisHastings::new(&t, &DMatrix::identity(3, 3), s.clone()) {
        Err(SamplerError::Covariance { problem }) => {
            assert!(problem.contains("2 parameters"), "{problem}")
        }
        Err(e) => panic!("{e}"),
        Ok(_) => panic!("accepted a 3×3 covariance for a 2-D target"),
    }
    assert!(matches!(
        MetropolisHastings::new(&t, &cov, MhSettings { burn_in: 100, ..s }),
        Err(SamplerError::Setting {
            field: "burn_in",
            ..
        })
    ));
    let holey = HoleyNormal {
        prior: Prior::new(
            vec!["x".into()],
            vec![PriorKind::Uniform { lo: -2.0, hi: 2.0 }],
        )
        .unwrap(),
    };
    let mh =
        MetropolisHastings::new(&holey, &DMatrix::identity(1, 1), MhSettings::default()).unwrap();
    match mh.run(&Start::Point(vec![1.5])) {
        Err(SamplerError::Start { problem, .. }) => {
            assert!(problem.contains("not finite"), "{problem}")
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn prior_starts_are_distinct_draws_inside_the_support() {
    let t = GaussianTarget::correlated(3, 10.0, 72);
    let s = MhSettings {
        n_iter: 20,
        burn_in: 10,
        n_chains: 3,
        ..MhSettings::default()
    };
    let q = GaussianProposal::new(&optimal_cov(&t)).unwrap();
    let starts: Vec<Vec<f64>> = (0..3)
        .map(|c| {
            ChainState::new(c, &t, &s, &q, None, &Start::Prior)
                .unwrap()
                .theta()
                .to_vec()
        })
        .collect();
    for p in &starts {
        assert!(t.prior().contains(p));
    }
    assert_ne!(starts[0], starts[1]);
    assert_ne!(starts[1], starts[2]);
}

#[test]
fn observer_sees_every_report() {
    let t = GaussianTarget::correlated(2, 10.0, 81);
    let calls = AtomicUsize::new(0);
    let last_ok = AtomicUsize::new(0);
    let obs = |p: &Progress| {
        calls.fetch_add(1, Ordering::Relaxed);
        if p.iteration == p.n_iter && (0.0..=1.0).contains(&p.acceptance) {
            last_ok.fetch_add(1, Ordering::Relaxed);
        }
    };
    let s = MhSettings {
        n_iter: 1_000,
        burn_in: 100,
        n_chains: 3,
        progress_every: 50,
        checkpoint_every: 300,
        ..MhSettings::default()
    };
    MetropolisHastings::new(&t, &optimal_cov(&t), s)
        .unwrap()
        .observer(&obs)
        .run(&Start::Point(t.mu.clone()))
        .unwrap();
    assert_eq!(calls.load(Ordering::Relaxed), 3 * 20);
    assert_eq!(last_ok.load(Ordering::Relaxed), 3);
}

#[test]
fn hot_loop_does_not_allocate() {
    let t = GaussianTarget::correlated(4, 1e3, 91);
    let s = full_settings();
    let q = GaussianProposal::new(&optimal_cov(&t)).unwrap();
    // the walk alone, and with a Student-t or Gaussian independence kernel mixed in
    let mixes = [None, Some(8.0), Some(DEFAULT_DOF)].map(|dof| {
        dof.map(|dof| {
            let q = StudentProposal::new(t.mu.clone(), &t.cov, dof).unwrap();
            Independence::new(0.5, q).unwrap()
        })
    });
    for mix in &mixes {
        let start = Start::Point(t.mu.clone());
        let mut state = ChainState::new(0, &t, &s, &q, mix.as_ref(), &start).unwrap();
        let obs = |_: &Progress| {};
        let before = ALLOCS.with(Cell::get);
        state.advance(&t, &s, s.n_iter, Some(&obs));
        let after = ALLOCS.with(Cell::get);
        assert_eq!(after - before, 0, "allocations in {} iterations", s.n_iter);
        assert_eq!(state.iter, s.n_iter);
    }
}

#[test]
fn nelder_mead_finds_rosenbrock_minimum_free_and_bounded() {
    let rosen = |x: &[f64]| (1.0 - x[0]).powi(2) + 100.0 * (x[1] - x[0] * x[0]).powi(2);
    let st = NelderMeadSettings::default();
    let m = nelder_mead(rosen, &[-1.2, 1.0], &[0.5, 0.5], &st).unwrap();
    assert!(m.converged);
    // Near (1, 1), f ≈ ½ δᵀHδ with smallest Hessian eigenvalue 0.4: f < 1e-9 puts δ within
    // √(2e-9/0.4) ≈ 7e-5 of the minimum.
    assert!(m.f < 1e-9, "{m:?}");
    assert!(
        (m.x[0] - 1.0).abs() < 1e-4 && (m.x[1] - 1.0).abs() < 1e-4,
        "{m:?}"
    );
    // Box x ≤ 0.5 by rejection: the constrained minimum is (0.5, 0.25) with f = 0.25, since
    // f ≥ (1 − x)² ≥ 0.25 there.
    let boxed = |x: &[f64]| if x[0] > 0.5 { f64::INFINITY } else { rosen(x) };
    let m = nelder_mead(boxed, &[-1.2, 1.0], &[0.5, 0.5], &st).unwrap();
    assert!((m.f - 0.25).abs() < 1e-8, "{m:?}");
    assert!(
        (m.x[0] - 0.5).abs() < 1e-6 && (m.x[1] - 0.25).abs() < 1e-4,
        "{m:?}"
    );
}

#[test]
fn find_map_recovers_the_gaussian_mode() {
    for (d, seed) in [(2usize, 101u64), (5, 102), (10, 103)] {
        let t = GaussianTarget::correlated(d, 1e3, seed);
        let start: Vec<f64> = (0..d).map(|k| t.mu[k] + 2.0 * t.sd(k)).collect();
        let step: Vec<f64> = (0..d).map(|k| t.sd(k)).collect();
        let m = find_map(&t, &start, &step, &NelderMeadSettings::default()).unwrap();
        assert!(m.converged, "D = {d}: {m:?}");
        // −ln posterior − its minimum = ½ Mahalanobis²; ask for 1e-8, i.e. the mode within
        // 1.4e-4 standard deviations along every direction.
        let excess = 0.5 * t.mahalanobis2(&m.theta);
        assert!(excess < 1e-8, "D = {d}: excess {excess}, {} evals", m.evals);
        assert_eq!(m.ln_posterior, t.ln_posterior(&m.theta));
    }
}

#[test]
fn nelder_mead_rejects_bad_input() {
    let f = |x: &[f64]| x[0] * x[0];
    let st = NelderMeadSettings::default();
    assert!(nelder_mead(f, &[1.0], &[0.1, 0.1], &st).is_err());
    assert!(nelder_mead(f, &[1.0], &[0.0], &st).is_err());
    assert!(nelder_mead(|_: &[f64]| f64::INFINITY, &[1.0], &[0.1], &st).is_err());
    assert!(nelder_mead(f, &[1.0], &[0.1], &NelderMeadSettings { x_rtol: 0.0, ..st }).is_err());
}

/// A flat density on a 40-dimensional unit box.
struct Box40(Prior);

impl LogDensity for Box40 {
    fn ln_likelihood(&self, _: &[f64]) -> f64 {
        0.0
    }
    fn prior(&self) -> &Prior {
        &self.0
    }
}

/// With a centre on the box's bound in 16 of 40 coordinates almost no Gaussian draw is inside
/// (2⁻¹⁶ at best, 1000 draws per chain find one with odds 1 in 65); the starts then take the centre's value where a draw leaves the box
/// (modelled glitches: candidates' amplitudes and starts at their boxes' edges), are inside,
/// and still differ between chains.
#[test]
fn starts_around_a_centre_on_many_bounds_are_inside_the_box() {
    let d = 40;
    let names = (0..d).map(|i| format!("p{i}")).collect();
    let t = Box40(Prior::new(names, vec![PriorKind::Uniform { lo: 0.0, hi: 1.0 }; d]).unwrap());
    let centre: Vec<f64> = (0..d).map(|i| if i < 16 { 0.0 } else { 0.5 }).collect();
    let s = MhSettings {
        n_iter: 20,
        burn_in: 10,
        n_chains: 3,
        seed: 4,
        ..MhSettings::default()
    };
    let cov = DMatrix::<f64>::identity(d, d) * 0.01;
    let ch = MetropolisHastings::new(&t, &cov, s)
        .unwrap()
        .run(&Start::Around {
            centre,
            spread: 2.0,
        })
        .unwrap();
    let RunOutcome::Finished(ch) = ch else {
        panic!("not finished")
    };
    let firsts: Vec<&[f64]> = ch.chains().iter().map(|c| &c.samples[..d]).collect();
    for f in &firsts {
        assert!(f.iter().all(|x| (0.0..=1.0).contains(x)), "{f:?}");
    }
    assert_ne!(firsts[0], firsts[1]);
}
