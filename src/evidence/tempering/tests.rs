//! Tests of parallel tempering against closed forms.

use super::integrate::hermite_with_error;
use super::*;
use crate::density::LogDensity;
use crate::evidence::EvidenceError;
use crate::evidence::linear_gaussian::{LinearGaussian, RandomPrior, RandomSpec};
use crate::evidence::mvn::MvnOptions;
use crate::prior::Prior;
use crate::prior::PriorKind;
use nalgebra::{DMatrix, DVector};
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use rand_xoshiro::Xoshiro256PlusPlus;

fn quick(seed: u64) -> TemperingOptions {
    TemperingOptions {
        seed,
        parallel: false,
        ..TemperingOptions::default()
    }
}

fn run_lg(lg: &LinearGaussian, opts: &TemperingOptions) -> (TemperingResult, f64, f64) {
    let d = lg.design().ncols();
    let cols: Vec<usize> = (0..d).collect();
    let post = lg.gaussian_posterior(&cols).unwrap();
    // start at the posterior mean clamped into the prior box
    let start: Vec<f64> = post
        .mean
        .iter()
        .zip(lg.prior().bounds())
        .map(|(&m, (lo, hi))| m.clamp(lo, hi))
        .collect();
    let res = run_tempering(lg, &start, &post.cov, opts).unwrap();
    let ex = lg.exact_ln_evidence(&cols, &MvnOptions::default()).unwrap();
    (res, ex.ln_z, ex.std_err)
}

/// Asserts TI and SS agree with the exact ln Z within `k` of their stated (total) errors.
fn check(res: &TemperingResult, exact: f64, exact_se: f64, k: f64) {
    let ti = res.thermodynamic.clone().unwrap();
    let ss = res.stepping_stone.clone().unwrap();
    eprintln!(
        "exact {exact:.4} | TI {:.4} ± {:.4} (disc {:.4}, trapezoid {:.4}) | SS {:.4} ± {:.4} | betas {:?} | swaps {:?} | acc {:?}",
        ti.ln_z,
        ti.std_err,
        ti.discretisation_err,
        ti.ln_z_trapezoid,
        ss.ln_z,
        ss.std_err,
        res.betas,
        res.swap_acceptance,
        res.in_rung_acceptance
    );
    let ti_err = ti.total_err().hypot(exact_se);
    assert!(
        (ti.ln_z - exact).abs() < k * ti_err,
        "TI {} vs exact {exact}: {}σ",
        ti.ln_z,
        (ti.ln_z - exact) / ti_err
    );
    let ss_err = ss.std_err.hypot(exact_se);
    assert!(
        (ss.ln_z - exact).abs() < k * ss_err,
        "SS {} vs exact {exact}: {}σ",
        ss.ln_z,
        (ss.ln_z - exact) / ss_err
    );
    assert!(ti.std_err > 0.0 && ss.std_err > 0.0);
}

/// The quadrature on the closed-form Gaussian curve `f = c − (D/2)/(β + a)` (isotropic
/// Gaussian likelihood, Gaussian prior of relative precision a): the Hermite rule beats the
/// trapezoid, and the Richardson estimate is within [1, 1.5] times its true error.
#[test]
fn hermite_rule_and_its_error_estimate_on_the_gaussian_curve() {
    for (dim, a, n) in [
        (8.0, 1e-6, 20),
        (8.0, 1e-6, 30),
        (8.0, 1e-3, 20),
        (8.0, 1e-3, 30),
        (1.0, 1e-3, 20),
    ] {
        let f = |b: f64| 2.0 - dim / 2.0 / (b + a);
        let fp = |b: f64| dim / 2.0 / (b + a).powi(2);
        let b1: f64 = a / 10.0;
        let mut betas = vec![0.0];
        for i in 0..n - 1 {
            betas.push((b1.ln() * (1.0 - i as f64 / (n - 2) as f64)).exp());
        }
        let fv: Vec<f64> = betas.iter().map(|&b| f(b)).collect();
        let fpv: Vec<f64> = betas.iter().map(|&b| fp(b)).collect();
        let exact = 2.0 - dim / 2.0 * ((1.0 + a).ln() - a.ln());
        let (h, shift, trap) = hermite_with_error(&betas, &fv, &fpv);
        let (eh, et) = ((h - exact).abs(), (trap - exact).abs());
        assert!(eh < et / 5.0, "D={dim} a={a} n={n}: {eh} vs {et}");
        // the signed estimate is Richardson's correction, opposite to the true error, and its
        // size errs large
        let est = shift.abs();
        assert!(
            shift * (h - exact) < 0.0 && est >= eh && est <= 1.5 * eh,
            "D={dim} a={a} n={n}: estimate {shift}, true {}",
            h - exact
        );
    }
    // Exact for a cubic, and the estimate is then 0 too.
    let betas = [0.0, 0.1, 0.3, 0.7, 1.0];
    let f: Vec<f64> = betas.iter().map(|b| b * b * b - 2.0 * b).collect();
    let fp: Vec<f64> = betas.iter().map(|b| 3.0 * b * b - 2.0).collect();
    let (h, shift, _) = hermite_with_error(&betas, &f, &fp);
    assert!((h - (0.25 - 1.0)).abs() < 1e-14 && shift.abs() < 1e-14);
}

struct Flat {
    prior: Prior,
    ln_l: f64,
}
impl LogDensity for Flat {
    fn ln_likelihood(&self, _: &[f64]) -> f64 {
        self.ln_l
    }
    fn prior(&self) -> &Prior {
        &self.prior
    }
}

/// A flat likelihood: Z = L exactly, every swap is accepted, no error.
#[test]
fn flat_likelihood_gives_ln_l_exactly() {
    let t = Flat {
        prior: Prior::new(
            vec!["x".into()],
            vec![PriorKind::Uniform { lo: 0.0, hi: 2.0 }],
        )
        .unwrap(),
        ln_l: -3.7,
    };
    let opts = TemperingOptions {
        n_temps: 5,
        n_iter: 2_000,
        burn_in: 500,
        ..quick(3)
    };
    let res = run_tempering(&t, &[1.0], &DMatrix::from_element(1, 1, 1.0), &opts).unwrap();
    let ti = res.thermodynamic.unwrap();
    let ss = res.stepping_stone.unwrap();
    assert!((ti.ln_z + 3.7).abs() < 1e-12 && ti.std_err < 1e-12);
    assert!(ti.discretisation_err < 1e-12);
    assert!((ss.ln_z + 3.7).abs() < 1e-12 && ss.std_err < 1e-12);
    assert!(res.swap_acceptance.iter().all(|&a| a == 1.0));
    // steps are capped by the box width, and the walk moves
    assert!(
        res.proposal_scale[1..]
            .iter()
            .all(|&s| s * (1.0f64 / 3.0).sqrt() <= 2.0)
    );
    assert!(res.in_rung_acceptance[1..].iter().all(|&a| a > 0.1));
}

/// Well constrained: D = 3, SNR 20, uniform priors 40 σ_post wide and more (ln Z dominated
/// by the Occam factor).
fn well_constrained() -> LinearGaussian {
    LinearGaussian::random(&RandomSpec {
        n_data: 40,
        dim: 3,
        snr: 20.0,
        n_absent: 1,
        sigma: 1.0,
        prior: RandomPrior::Uniform { lo: -5.0, hi: 5.0 },
        seed: 11,
    })
    .unwrap()
    .model
}

#[test]
fn well_constrained_uniform_prior() {
    let lg = well_constrained();
    let (res, exact, se) = run_lg(&lg, &quick(5));
    check(&res, exact, se, 4.0);
    // an equilibrated run passes its own checks (halves agree, E_β[ln L] rises)
    assert!(res.checks.is_empty(), "{:?}", res.checks);
    assert_eq!(res.swap_acceptance.len(), 31);
    assert!(res.swap_acceptance.iter().all(|&a| a > 0.2 && a < 1.0));
    // the adapted ladder equalises the swap rates
    let (lo, hi) = res
        .swap_acceptance
        .iter()
        .fold((1.0f64, 0.0f64), |(a, b), &x| (a.min(x), b.max(x)));
    assert!(hi - lo < 0.2, "{:?}", res.swap_acceptance);
    assert!(
        res.in_rung_acceptance[1..]
            .iter()
            .all(|&a| a > 0.1 && a < 0.5)
    );
    // every rung keeps SNAPSHOTS states inside the prior; the prior rung roams the box
    // while the posterior rung stays near the mode
    assert!(res.rung_samples.iter().all(|r| r.len() == SNAPSHOTS));
    assert!(
        res.rung_samples
            .iter()
            .flatten()
            .all(|t| lg.prior().contains(t))
    );
    let spread = |r: &[Vec<f64>]| {
        let m = r.iter().map(|t| t[0]).sum::<f64>() / r.len() as f64;
        r.iter().map(|t| (t[0] - m).powi(2)).sum::<f64>().sqrt()
    };
    assert!(spread(&res.rung_samples[0]) > 3.0 * spread(&res.rung_samples[31]));
    let ti = res.thermodynamic.unwrap();
    assert!(ti.total_err() < 0.1, "{ti:?}");
}

/// D = 2, SNR 10, Gaussian priors N(0, 3²): no box term in the exact answer.
fn gaussian_prior_problem() -> LinearGaussian {
    LinearGaussian::random(&RandomSpec {
        n_data: 30,
        dim: 2,
        snr: 10.0,
        n_absent: 0,
        sigma: 1.0,
        prior: RandomPrior::Gaussian {
            mu: 0.0,
            sigma: 3.0,
        },
        seed: 2,
    })
    .unwrap()
    .model
}

/// Gaussian priors (no box term in the exact answer).
#[test]
fn gaussian_prior() {
    let lg = gaussian_prior_problem();
    let (res, exact, se) = run_lg(&lg, &quick(6));
    assert_eq!(se, 0.0);
    check(&res, exact, se, 4.0);
}

/// Prior-dominated: the box is half the likelihood width, the truth sits on its corner and
/// the data push the maximum beyond it, so the MAP is the corner itself.
#[test]
fn prior_dominated_map_on_a_corner() {
    let (n, d) = (30, 2);
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(4);
    let x: DMatrix<f64> = DMatrix::from_fn(n, d, |_, _| StandardNormal.sample(&mut rng));
    let h = 0.5 / (n as f64).sqrt();
    let beyond = DVector::from_vec(vec![h + 2.0 / (n as f64).sqrt(); d]);
    let y: Vec<f64> = (&x * beyond).iter().cloned().collect();
    let box_ = PriorKind::Uniform { lo: -h, hi: h };
    let prior = Prior::new(vec!["a".into(), "b".into()], vec![box_, box_]).unwrap();
    let lg = LinearGaussian::new(x.clone(), y.clone(), 1.0, prior).unwrap();
    // KKT at the corner (h, h): the likelihood gradient points out of the box in both
    // coordinates, so the constrained maximum is the corner.
    let corner = DVector::from_vec(vec![h; d]);
    let grad = x.transpose() * (DVector::from_vec(y) - &x * &corner);
    assert!(grad.iter().all(|&g| g > 0.0), "{grad}");
    let (res, exact, se) = run_lg(&lg, &quick(7));
    check(&res, exact, se, 4.0);
    // The posterior is about as wide as the prior: hot and cold rungs look alike.
    assert!(res.swap_acceptance.iter().all(|&a| a > 0.5));
}

#[test]
fn errors_grow_when_n_iter_shrinks() {
    let lg = LinearGaussian::random(&RandomSpec {
        n_data: 30,
        dim: 2,
        snr: 10.0,
        n_absent: 1,
        sigma: 1.0,
        prior: RandomPrior::Uniform { lo: -4.0, hi: 4.0 },
        seed: 3,
    })
    .unwrap()
    .model;
    let short = TemperingOptions {
        n_iter: 3_000,
        burn_in: 1_000,
        ..quick(8)
    };
    let (a, exact, se) = run_lg(&lg, &short);
    let (b, _, _) = run_lg(&lg, &quick(8));
    check(&a, exact, se, 4.0);
    let (ta, tb) = (a.thermodynamic.unwrap(), b.thermodynamic.unwrap());
    let (sa, sb) = (a.stepping_stone.unwrap(), b.stepping_stone.unwrap());
    // 2 000 vs 24 000 kept sweeps: √12 ≈ 3.5 times smaller errors expected.
    assert!(ta.std_err > 2.0 * tb.std_err, "{ta:?} {tb:?}");
    assert!(sa.std_err > 2.0 * sb.std_err, "{sa:?} {sb:?}");
}

#[test]
fn same_numbers_for_any_thread_count() {
    let lg = LinearGaussian::random(&RandomSpec {
        n_data: 30,
        dim: 3,
        snr: 10.0,
        n_absent: 1,
        sigma: 1.0,
        prior: RandomPrior::Uniform { lo: -4.0, hi: 4.0 },
        seed: 5,
    })
    .unwrap()
    .model;
    let opts = TemperingOptions {
        n_temps: 8,
        n_iter: 3_000,
        burn_in: 1_000,
        parallel: true,
        ..quick(9)
    };
    let pool = |n| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .unwrap()
    };
    let one = pool(1).install(|| run_lg(&lg, &opts).0);
    let three = pool(3).install(|| run_lg(&lg, &opts).0);
    let serial = run_lg(
        &lg,
        &TemperingOptions {
            parallel: false,
            ..opts.clone()
        },
    )
    .0;
    assert_eq!(one, three);
    assert_eq!(one, serial);
    let other = run_lg(&lg, &TemperingOptions { seed: 10, ..opts }).0;
    assert_ne!(one.mean_ln_l, other.mean_ln_l);
}

#[test]
fn bad_inputs_are_errors_not_panics() {
    let lg = LinearGaussian::random(&RandomSpec {
        n_data: 20,
        dim: 2,
        snr: 5.0,
        n_absent: 0,
        sigma: 1.0,
        prior: RandomPrior::Uniform { lo: -2.0, hi: 2.0 },
        seed: 1,
    })
    .unwrap()
    .model;
    let cov = DMatrix::identity(2, 2) * 0.01;
    let base = TemperingOptions {
        n_temps: 4,
        n_iter: 1_000,
        burn_in: 200,
        ..quick(1)
    };
    let bad = [
        TemperingOptions {
            n_temps: 2,
            ..base.clone()
        },
        TemperingOptions {
            n_iter: 250,
            ..base.clone()
        },
        TemperingOptions {
            batch_size: Some(0),
            ..base.clone()
        },
        TemperingOptions {
            batch_size: Some(700),
            ..base.clone()
        },
        TemperingOptions {
            adapt_interval: 0,
            ..base.clone()
        },
        TemperingOptions {
            target_acceptance: 1.0,
            ..base.clone()
        },
        TemperingOptions {
            betas: Some(vec![0.0, 0.5, 0.4, 1.0]),
            ..base.clone()
        },
        TemperingOptions {
            betas: Some(vec![0.1, 0.2, 0.5, 1.0]),
            ..base.clone()
        },
    ];
    for o in &bad {
        let e = run_tempering(&lg, &[0.0, 0.0], &cov, o);
        assert!(
            matches!(e, Err(EvidenceError::InvalidOption { .. })),
            "{o:?}"
        );
    }
    assert!(matches!(
        run_tempering(&lg, &[0.0], &cov, &base),
        Err(EvidenceError::Dimension { .. })
    ));
    assert!(matches!(
        run_tempering(&lg, &[3.0, 0.0], &cov, &base),
        Err(EvidenceError::NonFinite { .. })
    ));
    assert!(matches!(
        run_tempering(&lg, &[0.0, 0.0], &(DMatrix::identity(2, 2) * -1.0), &base),
        Err(EvidenceError::Matrix {
            source: crate::linalg::LinalgError::NotPositiveDefinite { .. },
            ..
        })
    ));
    // A user-given ladder is used as given when not adapted.
    let fixed = TemperingOptions {
        betas: Some(vec![0.0, 0.01, 0.2, 1.0]),
        adapt_ladder: false,
        ..base
    };
    let r = run_tempering(&lg, &[0.0, 0.0], &cov, &fixed).unwrap();
    assert_eq!(r.betas, vec![0.0, 0.01, 0.2, 1.0]);
}

/// A likelihood that is zero on half of the prior (`Z = 1/2` exactly): TI takes the lost
/// mass from the prior rung's draws, `ln Z = ln p̂`, and both estimators agree with `ln ½`.
#[test]
fn zero_likelihood_region_enters_ti_through_the_prior_rung() {
    struct Half {
        prior: Prior,
    }
    impl LogDensity for Half {
        fn ln_likelihood(&self, t: &[f64]) -> f64 {
            if t[0] < 0.0 { f64::NEG_INFINITY } else { 0.0 }
        }
        fn prior(&self) -> &Prior {
            &self.prior
        }
    }
    let t = Half {
        prior: Prior::new(
            vec!["x".into()],
            vec![PriorKind::Uniform { lo: -1.0, hi: 1.0 }],
        )
        .unwrap(),
    };
    let opts = TemperingOptions {
        n_temps: 4,
        n_iter: 20_000,
        burn_in: 1_000,
        ..quick(2)
    };
    let res = run_tempering(&t, &[0.5], &DMatrix::from_element(1, 1, 0.3), &opts).unwrap();
    let ti = res.thermodynamic.unwrap();
    assert_eq!(ti.ln_z, ti.ln_support);
    assert!((ti.ln_z - 0.5f64.ln()).abs() < 4.0 * ti.std_err, "{ti:?}");
    // the binomial error of ln p̂ from 19 000 draws with p = 1/2, to within its batch noise
    let binomial = (0.5f64 / (0.5 * 19_000.0)).sqrt();
    assert!(
        (ti.std_err / binomial - 1.0).abs() < 0.3,
        "{ti:?} vs {binomial}"
    );
    let ss = res.stepping_stone.unwrap();
    assert!((ss.ln_z - 0.5f64.ln()).abs() < 4.0 * ss.std_err, "{ss:?}");
}

/// A Gaussian likelihood cut to zero below θ = 0 on the prior box [−1, 1] (an unstable half of
/// a model's parameter space): `Z = ½ ∫₀¹ N(θ; 0.2, 0.15²) dθ` in closed form. Over 400 seeds
/// TI and SS agree with it at their stated rate: the mean pull is within 3/√400 of zero and
/// the pulls' spread (1.016 and 1.028) within [0.9, 1.11], three of its sampling sd: errors
/// 20 % too small or too large move it out, and so does leaving `ln p̂`'s own error out of TI's.
#[test]
fn a_likelihood_cut_to_zero_keeps_ti_and_ss_calibrated() {
    struct Cut {
        prior: Prior,
    }
    const MU: f64 = 0.2;
    const SD: f64 = 0.15;
    impl LogDensity for Cut {
        fn ln_likelihood(&self, t: &[f64]) -> f64 {
            if t[0] < 0.0 {
                f64::NEG_INFINITY
            } else {
                -0.5 * ((t[0] - MU) / SD).powi(2)
            }
        }
        fn prior(&self) -> &Prior {
            &self.prior
        }
    }
    let t = Cut {
        prior: Prior::new(
            vec!["x".into()],
            vec![PriorKind::Uniform { lo: -1.0, hi: 1.0 }],
        )
        .unwrap(),
    };
    use statrs::distribution::{ContinuousCDF, Normal};
    let n = Normal::new(MU, SD).unwrap();
    let exact = (0.5 * SD * (2.0 * std::f64::consts::PI).sqrt() * (n.cdf(1.0) - n.cdf(0.0))).ln();
    let mut pulls = (Vec::new(), Vec::new());
    for seed in 0..400 {
        let opts = TemperingOptions {
            n_temps: 8,
            n_iter: 6_000,
            burn_in: 1_000,
            ..quick(100 + seed)
        };
        let res = run_tempering(&t, &[MU], &DMatrix::from_element(1, 1, SD * SD), &opts).unwrap();
        let ti = res.thermodynamic.unwrap();
        assert!(ti.ln_support < -0.3 && ti.ln_support > -1.2, "{ti:?}");
        pulls.0.push((ti.ln_z - exact) / ti.total_err());
        let ss = res.stepping_stone.unwrap();
        pulls.1.push((ss.ln_z - exact) / ss.std_err);
    }
    for (name, p) in [("TI", &pulls.0), ("SS", &pulls.1)] {
        let k = p.len() as f64;
        let mean = p.iter().sum::<f64>() / k;
        let sd = (p.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (k - 1.0)).sqrt();
        eprintln!("{name}: mean pull {mean:.3}, spread {sd:.3}");
        assert!(mean.abs() < 3.0 / k.sqrt(), "{name}: mean pull {mean}");
        assert!((0.9..1.11).contains(&sd), "{name}: pull spread {sd}");
    }
}

/// Every rung samples its power posterior: with a Gaussian prior the tempered posterior is
/// Gaussian with precision `βF + Λ`, so `E_β[ln L] = ln L_max − ½[tr(F A_β⁻¹) + (m_β − θ̂)ᵀF(m_β − θ̂)]`
/// in closed form. Each rung's mean lies within 4.5 of its own standard errors.
#[test]
fn rung_means_follow_the_closed_form_power_posterior_curve() {
    let lg = gaussian_prior_problem();
    let cols = [0usize, 1];
    let post = lg.gaussian_posterior(&cols).unwrap();
    let (th, lmax) = lg.max_likelihood(&cols).unwrap();
    let f = lg.fisher(&cols).unwrap();
    let lam = DMatrix::identity(2, 2) / 9.0;
    let thv = DVector::from_vec(th);
    let curve = |b: f64| {
        let ai = (&f * b + &lam).try_inverse().unwrap();
        let dm = &ai * (&f * &thv * b) - &thv;
        lmax - 0.5 * ((&f * &ai).trace() + (dm.transpose() * &f * &dm)[(0, 0)])
    };
    let r = run_tempering(&lg, post.mean.as_slice(), &post.cov, &quick(12)).unwrap();
    for i in 0..r.betas.len() {
        let z = (r.mean_ln_l[i] - curve(r.betas[i])) / r.mean_ln_l_std_err[i];
        assert!(z.abs() < 4.5, "rung {i} (β = {}): z = {z}", r.betas[i]);
    }
    // the curve spans hundreds of nats between the prior and the posterior
    assert!(r.mean_ln_l[r.betas.len() - 1] - r.mean_ln_l[0] > 100.0);
}

/// Cost of the defaults on a D = 6 problem with a prior box ~10³ posterior widths wide per
/// parameter (ln Z ≈ −56, an LTP-like Occam factor): the TI and SS errors and the number of
/// likelihood calls.
#[test]
fn defaults_reach_a_tenth_of_a_nat_at_d6() {
    let lg = LinearGaussian::random(&RandomSpec {
        n_data: 100,
        dim: 6,
        snr: 30.0,
        n_absent: 0,
        sigma: 1.0,
        prior: RandomPrior::Uniform {
            lo: -50.0,
            hi: 50.0,
        },
        seed: 21,
    })
    .unwrap()
    .model;
    let (res, exact, se) = run_lg(&lg, &quick(13));
    eprintln!("evals {}", res.ln_l_evals);
    check(&res, exact, se, 4.0);
    let ti = res.thermodynamic.unwrap();
    let ss = res.stepping_stone.unwrap();
    assert!(ti.total_err() < 0.15 && ss.std_err < 0.15, "{ti:?} {ss:?}");
    assert!(res.ln_l_evals < 1_300_000);
}

/// A run stopped on the driver (during the burn-in's adaptation, then after it) and resumed
/// from its checkpoint twice ends with the result of an uninterrupted run, bit for bit; a
/// checkpoint of another run or of other options is refused, naming why.
#[test]
fn a_stopped_run_resumed_from_its_checkpoint_equals_an_uninterrupted_one() {
    let lg = LinearGaussian::random(&RandomSpec {
        n_data: 20,
        dim: 2,
        snr: 8.0,
        n_absent: 0,
        sigma: 1.0,
        prior: RandomPrior::Uniform { lo: -4.0, hi: 4.0 },
        seed: 3,
    })
    .unwrap()
    .model;
    let post = lg.gaussian_posterior(&[0, 1]).unwrap();
    let start: Vec<f64> = post.mean.iter().map(|m| m.clamp(-4.0, 4.0)).collect();
    let opts = TemperingOptions {
        n_temps: 6,
        n_iter: 2_000,
        burn_in: 700,
        adapt_interval: 50,
        ..quick(4)
    };
    let whole = run_tempering(&lg, &start, &post.cov, &opts).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("pt.cbor");
    let every = std::time::Duration::ZERO;
    let pt = || ParallelTempering::new(&lg, &start, &post.cov, &opts).unwrap();

    let first = |n: usize| n >= 330;
    let out = pt()
        .checkpoint(&path, "run-1", every)
        .stop_when(&first)
        .run()
        .unwrap();
    // blocks of 1 %: the first block end at or after 330 is 340, inside an adaptation window
    assert_eq!(out, TemperingOutcome::Stopped { sweeps: 340 });
    let second = |n: usize| n >= 1_200;
    let out = pt()
        .checkpoint(&path, "run-1", every)
        .stop_when(&second)
        .resume(&path)
        .unwrap();
    assert_eq!(out, TemperingOutcome::Stopped { sweeps: 1_200 });
    let mut seen = Vec::new();
    let out = {
        let mut progress = |n: usize| seen.push(n);
        ParallelTempering::new(&lg, &start, &post.cov, &opts)
            .unwrap()
            .checkpoint(&path, "run-1", every)
            .progress(&mut progress)
            .resume(&path)
            .unwrap()
    };
    assert_eq!(out, TemperingOutcome::Finished(Box::new(whole)));
    assert_eq!((seen[0], seen.len()), (1_220, 40));

    let other_run = pt().checkpoint(&path, "run-2", every).resume(&path);
    let e = other_run.unwrap_err().to_string();
    assert!(e.contains("different run"), "{e}");
    let seed5 = TemperingOptions {
        seed: 5,
        ..opts.clone()
    };
    let e = ParallelTempering::new(&lg, &start, &post.cov, &seed5)
        .unwrap()
        .checkpoint(&path, "run-1", every)
        .resume(&path)
        .unwrap_err()
        .to_string();
    assert!(e.contains("different options"), "{e}");
    let e = pt()
        .checkpoint(&path, "run-1", every)
        .resume(&dir.path().join("none.cbor"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("none.cbor"), "{e}");
}

/// A run that has not equilibrated says so: started in a far corner of the box with steps 100×
/// too small and almost no burn-in, the cold rungs are still walking toward the posterior
/// during the kept sweeps. Its halves disagree (the error is widened to their spread) or its
/// `E_β[ln L]` falls along the ladder — and the same problem run properly passes both checks
/// (`well_constrained_uniform_prior`).
#[test]
fn a_run_still_walking_in_fails_its_own_checks() {
    let lg = well_constrained();
    let cols: Vec<usize> = (0..3).collect();
    let post = lg.gaussian_posterior(&cols).unwrap();
    let opts = TemperingOptions {
        n_iter: 4_000,
        burn_in: 20,
        ..quick(5)
    };
    let res = run_tempering(&lg, &[4.9, -4.9, 4.9], &(&post.cov * 1e-4), &opts).unwrap();
    eprintln!("{:#?}", res.checks);
    let c = &res.checks;
    assert_eq!(
        (c.thermodynamic.len(), c.stepping_stone.len()),
        (1, 1),
        "{c:#?}"
    );
    assert!(c.thermodynamic[0].starts_with("thermodynamic integration: the two halves"));
    assert!(c.stepping_stone[0].starts_with("stepping-stone: the two halves"));
    // each estimate gets its own message and the ladder's, never the other's
    assert!(
        c.for_thermodynamic()
            .iter()
            .all(|m| !m.starts_with("stepping"))
    );
    assert!(
        c.for_stepping_stone()
            .iter()
            .all(|m| !m.starts_with("thermo"))
    );
    // the widened errors cover the exact ln Z, which the batch-means errors alone did not
    let exact = lg
        .exact_ln_evidence(&cols, &MvnOptions::default())
        .unwrap()
        .ln_z;
    let ti = res.thermodynamic.unwrap();
    let ss = res.stepping_stone.unwrap();
    eprintln!(
        "exact {exact}; TI {} ± {}; SS {} ± {}",
        ti.ln_z,
        ti.total_err(),
        ss.ln_z,
        ss.std_err
    );
    assert!((ti.ln_z - exact).abs() < 3.0 * ti.total_err());
    assert!((ss.ln_z - exact).abs() < 3.0 * ss.std_err);
}
