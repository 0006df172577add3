use super::estimate::Sojourns;
use super::*;
use crate::density::LogDensity;
use crate::evidence::EvidenceError;
use crate::evidence::coverage_check::assert_nominal_coverage;
use crate::evidence::linear_gaussian::{LinearGaussian, RandomPrior, RandomSpec};
use crate::evidence::mvn::MvnOptions;
use crate::nested::SubModel;
use nalgebra::DMatrix;
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;

fn exact(lg: &LinearGaussian, a: &[usize], b: &[usize]) -> f64 {
    let o = MvnOptions::default();
    lg.exact_ln_evidence(a, &o).unwrap().ln_z - lg.exact_ln_evidence(b, &o).unwrap().ln_z
}

fn rj_model<'a>(
    lg: &LinearGaussian,
    name: &str,
    t: &'a dyn LogDensity,
    cols: &[usize],
) -> RjModel<'a> {
    let post = lg.gaussian_posterior(cols).unwrap();
    RjModel {
        name: name.into(),
        target: t,
        center: post.mean.as_slice().to_vec(),
        cov: post.cov,
    }
}

fn problem(snr: f64, n_absent: usize, seed: u64, half: f64) -> LinearGaussian {
    LinearGaussian::random(&RandomSpec {
        n_data: 30,
        dim: 2,
        snr,
        n_absent,
        sigma: 1.0,
        prior: RandomPrior::Uniform {
            lo: -half,
            hi: half,
        },
        seed,
    })
    .unwrap()
    .model
}

/// How many problems a coverage test runs: `RJ_COVERAGE_N` or `default`.
fn coverage_problems(default: u64) -> u64 {
    std::env::var("RJ_COVERAGE_N")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// Over 600 independent problems and seeds, the 1σ intervals of all three estimators cover
/// the exact ln B at the nominal rate, and would not with errors 20 % off.
#[test]
fn error_bars_cover_the_exact_bayes_factor() {
    let n = coverage_problems(600);
    let mut z = [vec![], vec![], vec![]];
    for seed in 0..n {
        let opts = RjOptions {
            n_iter: 20_000,
            burn_in: 500,
            seed,
            ..RjOptions::default()
        };
        let (p, truth) = nested_pair(&problem(5.0, 1, 100 + seed, 3.0), &opts);
        for (i, e) in [p.visits, p.rao_blackwell, p.bridge].iter().enumerate() {
            let e = e.expect("both models are visited");
            z[i].push((e.ln_b - truth) / e.std_err.unwrap());
        }
    }
    for (name, z) in ["visits", "Rao-Blackwell", "bridge"].iter().zip(&z) {
        assert_nominal_coverage(name, z);
    }
}

/// Signal in the extra parameter at SNR 40: ln B ≈ +170, the small model is never visited,
/// the visit ratio is undefined, yet the bridge stays finite and accurate.
#[test]
fn bridge_is_finite_when_a_model_is_never_visited() {
    let lg = problem(40.0, 0, 7, 20.0);
    let full = SubModel::new(&lg, vec![0, 1], vec![0.0; 2]).unwrap();
    let small = SubModel::new(&lg, vec![0], vec![0.0; 2]).unwrap();
    let models = [
        rj_model(&lg, "full", &full, &[0, 1]),
        rj_model(&lg, "small", &small, &[0]),
    ];
    let mut calls = 0;
    let mut cb = |p: &RjProgress<'_>| {
        calls += 1;
        assert!(p.iteration <= p.n_iter);
    };
    let opts = RjOptions {
        n_iter: 20_000,
        ..RjOptions::default()
    };
    let res = run_rjmcmc(&models, &opts, Some(&mut cb)).unwrap();
    assert_eq!(calls, 100);
    let truth = exact(&lg, &[0, 1], &[0]);
    assert!(truth > 50.0, "{truth}");
    assert_eq!(res.visits[1], 0);
    let p = res.pair(0, 1).unwrap();
    assert!(p.visits.is_none());
    // one-sided Rao-Blackwell: model 1 is never entered, its mean acceptance takes its
    // bound 1, which is exact here (jumps 1 → 0 would always be accepted)
    let rb = p.rao_blackwell.unwrap();
    assert!(
        (rb.ln_b - truth).abs() < 5.0 * rb.std_err.unwrap(),
        "{rb:?} vs {truth}"
    );
    let b = p.bridge.unwrap();
    // 5σ of its own error.
    assert!(
        (b.ln_b - truth).abs() < 5.0 * b.std_err.unwrap(),
        "{b:?} vs {truth}"
    );
    assert!(b.std_err.unwrap() < 0.1);
    // Orientation.
    let q = res.pair(1, 0).unwrap();
    assert_eq!(q.bridge.unwrap().ln_b, -b.ln_b);
}

#[test]
fn deterministic_with_trace_and_three_models() {
    let lg = LinearGaussian::random(&RandomSpec {
        n_data: 30,
        dim: 3,
        snr: 4.0,
        n_absent: 1,
        sigma: 1.0,
        prior: RandomPrior::Uniform { lo: -3.0, hi: 3.0 },
        seed: 2,
    })
    .unwrap()
    .model;
    let m3 = SubModel::new(&lg, vec![0, 1, 2], vec![0.0; 3]).unwrap();
    let m2 = SubModel::new(&lg, vec![0, 1], vec![0.0; 3]).unwrap();
    let m1 = SubModel::new(&lg, vec![0], vec![0.0; 3]).unwrap();
    let models = [
        rj_model(&lg, "3", &m3, &[0, 1, 2]),
        rj_model(&lg, "2", &m2, &[0, 1]),
        rj_model(&lg, "1", &m1, &[0]),
    ];
    let opts = RjOptions {
        n_iter: 5_000,
        burn_in: 100,
        seed: 9,
        trace_every: 100,
        proposal: ProposalShape::StudentT { nu: 4.0 },
        prior_model_probs: Some(vec![1.0, 2.0, 1.0]),
        ..RjOptions::default()
    };
    let a = run_rjmcmc(&models, &opts, None).unwrap();
    let b = run_rjmcmc(&models, &opts, None).unwrap();
    assert_eq!(a, b);
    assert_eq!(a.pairs.len(), 3);
    // two chains of 2 500 iterations, 2 400 after burn-in each
    assert_eq!(a.trace.len(), 24);
    assert_eq!(a.visits.iter().sum::<u64>(), 4_800);
    assert_eq!(a.trace.last().unwrap().iteration, 5_000);
    assert_eq!(a.prior_model_probs, vec![0.25, 0.5, 0.25]);
    let tr = a.ln_b_trace(0, 1);
    let last = tr.last().unwrap().1.unwrap();
    assert!((last - a.pair(0, 1).unwrap().visits.unwrap().ln_b).abs() < 1e-12);
}

#[test]
fn rejects_bad_options() {
    let lg = problem(5.0, 1, 1, 3.0);
    let full = SubModel::new(&lg, vec![0, 1], vec![0.0; 2]).unwrap();
    let small = SubModel::new(&lg, vec![0], vec![0.0; 2]).unwrap();
    let models = [
        rj_model(&lg, "full", &full, &[0, 1]),
        rj_model(&lg, "small", &small, &[0]),
    ];
    let base = RjOptions {
        n_iter: 1000,
        burn_in: 10,
        ..RjOptions::default()
    };
    let bad = [
        RjOptions {
            n_iter: 50,
            ..base.clone()
        },
        RjOptions {
            jump_scale: 0.0,
            ..base.clone()
        },
        RjOptions {
            prior_model_probs: Some(vec![1.0, -1.0]),
            ..base.clone()
        },
        RjOptions {
            jump: JumpRule::Matrix(vec![vec![1.0, 0.0], vec![0.5, 0.5]]),
            ..base.clone()
        },
        RjOptions {
            proposal: ProposalShape::StudentT { nu: 0.0 },
            ..base.clone()
        },
        RjOptions {
            start_model: 2,
            ..base.clone()
        },
        RjOptions {
            batch_size: Some(10_000),
            ..base.clone()
        },
        RjOptions {
            defensive: 1.0,
            ..base.clone()
        },
        RjOptions {
            defensive: -0.1,
            ..base.clone()
        },
        RjOptions {
            n_chains: 0,
            ..base.clone()
        },
        RjOptions {
            n_chains: 10,
            ..base.clone()
        },
    ];
    for o in &bad {
        assert!(run_rjmcmc(&models, o, None).is_err(), "{o:?}");
    }
    let mut wrong = rj_model(&lg, "x", &small, &[0]);
    wrong.center = vec![0.0, 0.0];
    assert!(matches!(
        run_rjmcmc(&[wrong], &base, None),
        Err(EvidenceError::Dimension { .. })
    ));
    let mut outside = rj_model(&lg, "x", &small, &[0]);
    outside.center = vec![10.0];
    assert!(matches!(
        run_rjmcmc(&[outside], &base, None),
        Err(EvidenceError::NonFinite { .. })
    ));
}

fn two_models<'a>(
    lg: &LinearGaussian,
    full: &'a dyn LogDensity,
    small: &'a dyn LogDensity,
) -> [RjModel<'a>; 2] {
    [
        rj_model(lg, "full", full, &[0, 1]),
        rj_model(lg, "small", small, &[0]),
    ]
}

/// Runs the reversible jump between the full model of `lg` and the model without its second
/// parameter; returns the pair's estimates and the exact ln B.
fn nested_pair(lg: &LinearGaussian, opts: &RjOptions) -> (RjPair, f64) {
    let full = SubModel::new(lg, vec![0, 1], vec![0.0; 2]).unwrap();
    let small = SubModel::new(lg, vec![0], vec![0.0; 2]).unwrap();
    let res = run_rjmcmc(&two_models(lg, &full, &small), opts, None).unwrap();
    (res.pair(0, 1).unwrap().clone(), exact(lg, &[0, 1], &[0]))
}

/// Jumps rarely accepted (jump proposals 14× narrower than the posterior, c = 0.07: about
/// 36 accepted jumps per run on average, half the runs below the warning threshold, about 17
/// regeneration units). Before the jackknife the 1σ intervals of visits / Rao-Blackwell /
/// bridge covered 0.60 / 0.575 / 0.57 over 400 problems (the delta-method variance of a ratio
/// of sums over so few units is short, and the α's and bridge terms of so narrow a proposal
/// are skewed); with it they cover at the nominal rate.
#[test]
fn error_bars_cover_when_jumps_are_rare() {
    let n = coverage_problems(800);
    let mut z = [vec![], vec![], vec![]];
    let mut jumps = 0;
    let mut warned = 0;
    for seed in 0..n {
        let opts = RjOptions {
            n_iter: 6_000,
            burn_in: 500,
            seed,
            jump_scale: 0.07,
            defensive: 0.0,
            ..RjOptions::default()
        };
        let (p, truth) = nested_pair(&problem(5.0, 1, 300 + seed, 3.0), &opts);
        jumps += p.effective_jumps;
        warned += p.warning.is_some() as usize;
        for (i, e) in [p.visits, p.rao_blackwell, p.bridge].iter().enumerate() {
            let e = e.expect("both models are visited");
            z[i].push((e.ln_b - truth) / e.std_err.unwrap());
        }
    }
    let mean_jumps = jumps as f64 / n as f64;
    println!("rare jumps: mean effective jumps {mean_jumps}, warned {warned}");
    assert!(mean_jumps < 40.0, "{mean_jumps}");
    assert!(warned > n as usize / 4, "{warned}");
    for (name, z) in ["visits", "Rao-Blackwell", "bridge"].iter().zip(&z) {
        assert_nominal_coverage(name, z);
    }
}

/// With defensive weight 0 and one chain the run is the one before the defensive mixture and
/// the parallel chains existed: same random stream, same counts, same point estimates (numbers
/// printed by the previous implementation, commit 925d7e6). The pilot covers the whole run, so
/// the bridge is the full optimal bridge. Errors can only have grown (max with the
/// regenerative estimate and the sojourn floor); the batch-means part is the old formula.
#[test]
fn defensive_zero_single_chain_reproduces_previous_numbers() {
    let lg = problem(5.0, 1, 11, 3.0);
    let full = SubModel::new(&lg, vec![0, 1], vec![0.0; 2]).unwrap();
    let small = SubModel::new(&lg, vec![0], vec![0.0; 2]).unwrap();
    let models = two_models(&lg, &full, &small);
    let opts = RjOptions {
        n_iter: 20_000,
        burn_in: 500,
        seed: 3,
        n_chains: 1,
        defensive: 0.0,
        ..RjOptions::default()
    };
    let r = run_rjmcmc(&models, &opts, None).unwrap();
    assert_eq!(r.visits, vec![2319, 17181]);
    assert_eq!(r.jumps_proposed, vec![vec![0, 2373], vec![17627, 0]]);
    assert_eq!(r.jumps_accepted, vec![vec![0, 2371], vec![2370, 0]]);
    assert_eq!(
        r.in_model_acceptance,
        vec![Some(0.35440370838600926), Some(0.44777897543541156)]
    );
    let p = &r.pairs[0];
    assert_eq!((p.proposals_k_to_l, p.proposals_l_to_k), (2319, 17181));
    let v = p.visits.unwrap();
    assert!((v.ln_b - -2.0026680638064347).abs() < 1e-12);
    assert!(v.std_err.unwrap() >= 0.02066732453932796 * (1.0 - 1e-9));
    let rb = p.rao_blackwell.unwrap();
    assert!((rb.ln_b - -2.013781063445487).abs() < 1e-9, "{rb:?}");
    assert!(rb.std_err.unwrap() >= 0.004825169025952668 * (1.0 - 1e-9));
    let b = p.bridge.unwrap();
    assert!((b.ln_b - -2.012960200168078).abs() < 1e-8, "{b:?}");
    assert!(b.std_err.unwrap() >= 0.00463142179878529 * (1.0 - 1e-9));
    // per-pair acceptance
    assert_eq!(r.jump_acceptance(0, 1), (2371, 2373, Some(2371.0 / 2373.0)));
    assert_eq!(r.jump_acceptance(0, 0).2, None);
    let rates = r.jump_acceptance_rates();
    assert_eq!(rates[1][0], Some(2370.0 / 17627.0));
    assert!(p.effective_jumps <= 2371 + 2370 && p.effective_jumps > 4000);
    assert!(p.warning.is_none());
}

/// Same seed, same result, whether the chains run on one thread or two.
#[test]
fn chains_are_independent_of_the_thread_count() {
    let lg = problem(5.0, 1, 5, 3.0);
    let full = SubModel::new(&lg, vec![0, 1], vec![0.0; 2]).unwrap();
    let small = SubModel::new(&lg, vec![0], vec![0.0; 2]).unwrap();
    let models = two_models(&lg, &full, &small);
    let opts = RjOptions {
        n_iter: 9_000,
        burn_in: 200,
        n_chains: 3,
        seed: 17,
        ..RjOptions::default()
    };
    let run = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| run_rjmcmc(&models, &opts, None).unwrap())
    };
    let (a, b) = (run(1), run(2));
    assert_eq!(a, b);
    assert_eq!(a.n_chains, 3);
    assert_eq!(a.n_iter, 9_000);
    // the chains differ: three chains are not one chain three times
    let one = run_rjmcmc(
        &models,
        &RjOptions {
            n_iter: 3_000,
            n_chains: 1,
            ..opts.clone()
        },
        None,
    )
    .unwrap();
    assert_ne!(
        a.visits,
        one.visits.iter().map(|v| 3 * v).collect::<Vec<_>>()
    );
}

/// The low-SNR failure mode: the posterior fills its prior box but the jump proposal is a
/// narrow Gaussian centred on a corner of the box (a Fisher matrix at a MAP on the boundary).
/// Without the defensive prior component almost no jump lands where the posterior is; with
/// w = 0.1 every estimator agrees with the exact answer within 4σ.
#[test]
fn defensive_mixture_rescues_a_misplaced_proposal() {
    let lg = problem(0.3, 1, 21, 1.0);
    let full = SubModel::new(&lg, vec![0, 1], vec![0.0; 2]).unwrap();
    let small = SubModel::new(&lg, vec![0], vec![0.0; 2]).unwrap();
    let corner = |name: &str, t, d: usize| RjModel {
        name: name.to_string(),
        target: t,
        center: vec![0.99; d],
        cov: DMatrix::identity(d, d) * 1e-4,
    };
    let models = [corner("full", &full, 2), corner("small", &small, 1)];
    let truth = exact(&lg, &[0, 1], &[0]);
    let run = |w| {
        run_rjmcmc(
            &models,
            &RjOptions {
                n_iter: 40_000,
                burn_in: 1_000,
                defensive: w,
                ..RjOptions::default()
            },
            None,
        )
        .unwrap()
    };
    let bad = run(0.0).pair(0, 1).unwrap();
    let good = run(0.1).pair(0, 1).unwrap();
    println!("w = 0: {bad:?}\nw = 0.1: {good:?}\ntruth {truth}");
    assert!(bad.effective_jumps < good.effective_jumps / 10);
    assert!(good.effective_jumps >= MIN_EFFECTIVE_JUMPS && good.warning.is_none());
    for e in [good.visits, good.rao_blackwell, good.bridge] {
        let e = e.unwrap();
        assert!(
            (e.ln_b - truth).abs() < 4.0 * e.std_err.unwrap(),
            "{e:?} vs {truth}"
        );
        assert!(e.std_err.unwrap() < 0.2);
    }
}

/// A run longer than the pilot (2¹⁷ post-burn-in iterations per chain) with frequent jumps:
/// the bridge streams on the pilot's grid, more than 1024 regeneration units per chain are
/// merged, and all estimators still agree with the exact answer.
#[test]
fn streaming_beyond_the_pilot_agrees_with_the_exact_answer() {
    let lg = problem(5.0, 1, 8, 3.0);
    let full = SubModel::new(&lg, vec![0, 1], vec![0.0; 2]).unwrap();
    let small = SubModel::new(&lg, vec![0], vec![0.0; 2]).unwrap();
    let models = two_models(&lg, &full, &small);
    let opts = RjOptions {
        n_iter: 2 * 200_000,
        burn_in: 1_000,
        ..RjOptions::default()
    };
    let r = run_rjmcmc(&models, &opts, None).unwrap();
    let truth = exact(&lg, &[0, 1], &[0]);
    let p = r.pair(0, 1).unwrap();
    assert!(r.regeneration_units <= 2 * 1024 && p.effective_jumps > 4 * 1024);
    for e in [p.visits, p.rao_blackwell, p.bridge] {
        let e = e.unwrap();
        assert!(
            (e.ln_b - truth).abs() < 4.0 * e.std_err.unwrap(),
            "{e:?} vs {truth}"
        );
        assert!(e.std_err.unwrap() < 0.02, "{e:?}");
    }
}

/// The sojourn floor is the two-state Markov chain's asymptotic variance of ln(N_k/N_l):
/// simulated chains with leave probabilities a = 0.01, β = 0.02 reproduce it.
#[test]
fn sojourn_floor_matches_a_two_state_markov_chain() {
    use rand::RngExt;
    let (a, b, n, reps) = (0.01, 0.02, 20_000usize, 400);
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(5);
    let mut lr = Vec::new();
    let mut floors = Vec::new();
    for _ in 0..reps {
        let mut s = 0usize;
        let mut visits = [0u64; 2];
        let mut soj = [0u64; 2];
        let mut last = None;
        for _ in 0..n {
            let p = if s == 0 { a } else { b };
            if rng.random::<f64>() < p {
                s = 1 - s;
            }
            if last != Some(s) {
                soj[s] += 1;
                last = Some(s);
            }
            visits[s] += 1;
        }
        lr.push((visits[0] as f64 / visits[1] as f64).ln());
        floors.push(estimate::markov_floor(
            0,
            1,
            &Sojourns {
                sojourns: &soj,
                visits: &visits,
            },
        ));
    }
    let m = lr.iter().sum::<f64>() / reps as f64;
    let var = lr.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (reps - 1) as f64;
    let floor = floors.iter().sum::<f64>() / reps as f64;
    // sampling error of a variance from 400 draws: ~7 %
    assert!((var / floor - 1.0).abs() < 0.25, "var {var} floor {floor}");
}

/// The running estimates end at the final numbers (the same pooled sums), their iterations
/// grow to the run's end, and the kept draws agree with the visit counts, the models' columns
/// and `ln L`; keeping them changes no number.
#[test]
fn running_estimates_and_draws_of_three_models() {
    let lg = LinearGaussian::random(&RandomSpec {
        n_data: 30,
        dim: 3,
        snr: 4.0,
        n_absent: 1,
        sigma: 1.0,
        prior: RandomPrior::Uniform { lo: -3.0, hi: 3.0 },
        seed: 2,
    })
    .unwrap()
    .model;
    let m3 = SubModel::new(&lg, vec![0, 1, 2], vec![0.0; 3]).unwrap();
    let m2 = SubModel::new(&lg, vec![0, 1], vec![0.0; 3]).unwrap();
    let m1 = SubModel::new(&lg, vec![0], vec![0.0; 3]).unwrap();
    let models = [
        rj_model(&lg, "3", &m3, &[0, 1, 2]),
        rj_model(&lg, "2", &m2, &[0, 1]),
        rj_model(&lg, "1", &m1, &[0]),
    ];
    let opts = RjOptions {
        n_iter: 8_000,
        burn_in: 100,
        seed: 9,
        keep_draws: true,
        ..RjOptions::default()
    };
    let a = run_rjmcmc(&models, &opts, None).unwrap();
    let last = a.running.last().unwrap();
    assert_eq!(last.iteration, 8_000);
    assert_eq!(last.pairs.len(), 3);
    for (q, p) in last.pairs.iter().zip(&a.pairs) {
        assert_eq!((q.k, q.l), (p.k, p.l));
        assert_eq!(q.visits, p.visits);
        assert_eq!(q.rao_blackwell, p.rao_blackwell);
        assert_eq!(q.bridge, p.bridge);
    }
    // 3 900 post-burn-in iterations per chain: 62 batches of 62, so 62 points
    assert_eq!(a.running.len(), 62);
    assert!(
        a.running
            .windows(2)
            .all(|w| w[0].iteration < w[1].iteration)
    );
    let first = &a.running[0].pairs[0];
    assert!(
        first.visits.unwrap().std_err.unwrap() > last.pairs[0].visits.unwrap().std_err.unwrap()
    );
    // the draws
    let d = a.draws.as_ref().unwrap();
    assert_eq!((d.n_chains, d.n_draws, d.thin), (2, 3_900, 1));
    assert_eq!(
        d.param_names,
        ["theta0", "theta1", "theta2"].map(String::from)
    );
    let mut counts = [0u64; 3];
    for (i, &m) in d.model_index.iter().enumerate() {
        counts[m as usize] += 1;
        let row = &d.samples[3 * i..3 * i + 3];
        let dim = 3 - m as usize;
        assert!(row[..dim].iter().all(|x| x.is_finite()), "{row:?}");
        assert!(row[dim..].iter().all(|x| x.is_nan()), "{row:?}");
        let target = [&m3, &m2, &m1][m as usize];
        assert_eq!(d.ln_likelihood[i], target.ln_likelihood(&row[..dim]));
    }
    assert_eq!(counts.to_vec(), a.visits);
    let b = run_rjmcmc(
        &models,
        &RjOptions {
            keep_draws: false,
            ..opts
        },
        None,
    )
    .unwrap();
    assert!(b.draws.is_none());
    assert_eq!(RjResult { draws: None, ..a }, b);
}

/// A model never visited: every running visit ratio is absent (null in JSON, not NaN), while
/// Rao-Blackwell and the bridge have values; one chain still gives running errors.
#[test]
fn running_estimates_when_a_model_is_never_visited_with_one_chain() {
    let lg = problem(40.0, 0, 7, 20.0);
    let full = SubModel::new(&lg, vec![0, 1], vec![0.0; 2]).unwrap();
    let small = SubModel::new(&lg, vec![0], vec![0.0; 2]).unwrap();
    let models = [
        rj_model(&lg, "full", &full, &[0, 1]),
        rj_model(&lg, "small", &small, &[0]),
    ];
    let opts = RjOptions {
        n_iter: 10_000,
        n_chains: 1,
        ..RjOptions::default()
    };
    let res = run_rjmcmc(&models, &opts, None).unwrap();
    assert_eq!(res.visits[1], 0);
    assert!(res.running.len() > 10);
    for pt in &res.running {
        let p = &pt.pairs[0];
        assert!(p.visits.is_none());
        let (rb, br) = (p.rao_blackwell.unwrap(), p.bridge.unwrap());
        assert!(
            rb.ln_b.is_finite() && rb.std_err.unwrap().is_finite(),
            "{pt:?}"
        );
        assert!(
            br.ln_b.is_finite() && br.std_err.unwrap().is_finite(),
            "{pt:?}"
        );
    }
    let json = serde_json::to_string(&res.running[0]).unwrap();
    assert!(
        json.contains("\"visits\":null") && !json.contains("NaN"),
        "{json}"
    );
    assert_eq!(
        res.running.last().unwrap().pairs[0].bridge,
        res.pairs[0].bridge
    );
}

#[test]
fn union_of_parameter_names_in_first_seen_order() {
    let s = |v: &[&str]| v.iter().map(|x| x.to_string()).collect::<Vec<_>>();
    let (a, b, c) = (s(&["a", "b"]), s(&["c", "b"]), s(&[]));
    let (names, cols) = union_columns(&[&a, &b, &c]);
    assert_eq!(names, s(&["a", "b", "c"]));
    assert_eq!(cols, vec![vec![0, 1], vec![2, 1], vec![]]);
}

/// Stopped on the driver before the pilot fixes the bridge grid and again after it, and resumed
/// from its checkpoint each time, a run ends with the result and the draws of an
/// uninterrupted run, bit for bit; a checkpoint of other options or models is refused.
#[test]
fn a_stopped_run_resumed_from_its_checkpoint_equals_an_uninterrupted_one() {
    let lg = problem(5.0, 1, 21, 3.0);
    let full = SubModel::new(&lg, vec![0, 1], vec![0.0; 2]).unwrap();
    let small = SubModel::new(&lg, vec![0], vec![0.0; 2]).unwrap();
    let models = [
        rj_model(&lg, "full", &full, &[0, 1]),
        rj_model(&lg, "small", &small, &[0]),
    ];
    // 140 000 per chain: the pilot (131 072 after a burn-in of 500) ends in the 94th block
    let opts = RjOptions {
        n_iter: 280_000,
        burn_in: 500,
        seed: 8,
        keep_draws: true,
        ..RjOptions::default()
    };
    let whole = run_rjmcmc(&models, &opts, None).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("rj.cbor");
    let every = std::time::Duration::ZERO;
    let rj = || {
        ReversibleJump::new(&models, &opts)
            .unwrap()
            .checkpoint(&path, "run-1", every)
    };
    let before = |n: usize| n >= 50_000;
    let out = rj().stop_when(&before).run().unwrap();
    assert_eq!(out, RjOutcome::Stopped { iterations: 50_400 });
    let after = |n: usize| n >= 131_600;
    let out = rj().stop_when(&after).resume(&path).unwrap();
    assert_eq!(
        out,
        RjOutcome::Stopped {
            iterations: 131_600
        }
    );
    let RjOutcome::Finished(resumed) = rj().resume(&path).unwrap() else {
        panic!("the resumed run must finish")
    };
    let json = |r: &RjResult| serde_json::to_string(r).unwrap();
    assert_eq!(json(&resumed), json(&whole));
    let bits = |r: &RjResult| {
        let d = r.draws.as_ref().unwrap();
        let b = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        (d.model_index.clone(), b(&d.samples), b(&d.ln_likelihood))
    };
    assert!(bits(&resumed) == bits(&whole), "the draws differ");

    let seed9 = RjOptions {
        seed: 9,
        ..opts.clone()
    };
    let e = ReversibleJump::new(&models, &seed9)
        .unwrap()
        .checkpoint(&path, "run-1", every)
        .resume(&path)
        .unwrap_err()
        .to_string();
    assert!(e.contains("different options"), "{e}");
    let swapped = [
        rj_model(&lg, "small", &small, &[0]),
        rj_model(&lg, "full", &full, &[0, 1]),
    ];
    let e = ReversibleJump::new(&swapped, &opts)
        .unwrap()
        .checkpoint(&path, "run-1", every)
        .resume(&path)
        .unwrap_err()
        .to_string();
    assert!(e.contains("different set of models"), "{e}");
}

/// A disfavoured model entered in one sojourn (ln B ≈ +9, 1–2 accepted jumps in 20 000
/// iterations): the two-sided Rao-Blackwell and bridge estimates rest on that sojourn's few
/// proposals. Their linearised errors and a jackknife restricted to the two-sided form said
/// ± 0.01 while missing the exact ln B by 4–62 σ (these five seeds: 7.0, 12.5, −62.0, 11.9,
/// −50.3); the jackknife in the form each leave-one-out pool calls for (one-sided once the
/// sojourn's unit is left out) states errors of 0.07–0.39, and the misses are 1.2–1.6 σ.
/// Several sojourns, every jump back accepted: the next test.
#[test]
fn a_model_entered_once_does_not_make_the_error_small() {
    for seed in [11u64, 56, 81, 82, 150] {
        let (p, z) = disfavoured_model_entered_rarely(seed);
        assert!(
            p.effective_jumps <= 2 && p.warning.is_some(),
            "{seed}: {p:?}"
        );
        assert!(z.iter().all(|z| z.abs() < 2.0), "seed {seed}: {z:?} σ");
    }
}

/// The family of the two tests below (ln B ≈ +9: the small model is rarely entered): the
/// pair, and the Rao-Blackwell and bridge misses of the exact ln B in their stated σ.
fn disfavoured_model_entered_rarely(seed: u64) -> (RjPair, [f64; 2]) {
    let opts = RjOptions {
        n_iter: 20_000,
        burn_in: 500,
        seed,
        ..RjOptions::default()
    };
    let (p, truth) = nested_pair(&problem(7.0, 0, 500 + seed, 20.0), &opts);
    let z = [p.rao_blackwell, p.bridge].map(|e| {
        let e = e.unwrap();
        (e.ln_b - truth) / e.std_err.unwrap()
    });
    (p, z)
}

/// A model entered in a few sojourns whose every jump back was accepted (3–36 proposals out
/// of it, all with α = 1): the sample cannot show the tenth of proposals (the defensive
/// mixture's prior draws) that would be rejected, so every variance estimate from it said
/// ± 0.01 on a 0.1-nat miss (these six seeds: 8.4, 9.7, 8.9, 13.1, 12.2, 9.8 σ). The floor of
/// one unseen zero term per direction puts them within 1.3 σ, and an error is still not
/// inflated beyond what so few proposals can tell (< 0.25 nat). Over 1 600 seeds of this
/// family the RB/bridge 1σ coverage by accepted jumps, 3–10 / 10–30 / 30–100, went from
/// 0.18 / 0.47 / 0.69 to 0.95 / 0.82 / 0.69 (`docs/src/reference/estimators.md`).
#[test]
fn a_model_entered_in_a_few_sojourns_with_every_jump_back_accepted() {
    for seed in [29u64, 61, 135, 160, 487, 855] {
        let (p, z) = disfavoured_model_entered_rarely(seed);
        assert!(
            (3..=30).contains(&p.effective_jumps) && p.proposals_l_to_k == p.accepted_l_to_k,
            "{seed}: {p:?}"
        );
        let se = [p.rao_blackwell, p.bridge].map(|e| e.unwrap().std_err.unwrap());
        assert!(
            z.iter().all(|z| z.abs() < 2.0) && se.iter().all(|&s| s < 0.25),
            "seed {seed}: {z:?} σ, errors {se:?}"
        );
    }
}
