//! A model whose residual noise depends on θ (`noise = "model"` through the model's own
//! dynamics; ltp-model.md §8.4): `examples/two-mass-damper.toml`, springs against springs
//! and a coupling damper whose width sets the force noise's resonances.
//!
//! The Bayes factor must not depend on a point nobody chose (`[fit] start`, the prior centre),
//! and must agree with an independent evidence of the exact θ-dependent Whittle likelihood
//! (importance sampling, below).

use nalgebra::{DMatrix, DVector};
use occam::config::Study;
use occam::density::LogDensity;
use occam::jobs::own_noise::own_noise_likelihood;
use occam::jobs::prepare::{default_start, likelihood_at, prepare_select, reference_point};
use occam::jobs::select::run;
use occam::likelihood::theta_noise::{
    ThetaNoiseDensity, ln_likelihood_theta_noise, ln_likelihood_theta_noise_per_bin,
    noise_parameters,
};
use occam::likelihood::{cramer_rao, fisher_exact};
use occam::nested::SubModel;
use rand::SeedableRng;
use rand_distr::{ChiSquared, Distribution, StandardNormal};
use statrs::function::gamma::ln_gamma;
use std::path::Path;

const EXAMPLE: &str = "examples/two-mass-damper.toml";

fn study(start_bc: Option<f64>) -> Study {
    let mut s = Study::load(Path::new(EXAMPLE)).unwrap();
    if let Some(v) = start_bc {
        s.fit.start = Some([("bc".to_string(), v)].into_iter().collect());
    }
    s
}

/// At the point its spectra were prepared at, the exact θ-dependent `ln L` is the fixed-noise
/// one; elsewhere it differs, by the noise's own `ln det` among others; every parameter of the
/// damper model moves the noise (the resonances), the springs model's three too.
#[test]
fn the_exact_likelihood_is_the_fixed_one_at_its_point_and_moves_elsewhere() {
    let s = study(None);
    let prep = prepare_select(&s).unwrap();
    let mi = s.models.index("damper").unwrap();
    let th = reference_point(&s, mi);
    let lik = likelihood_at(&s, mi, &prep.dataset, &th).unwrap();
    let fixed = lik.ln_likelihood_whittle(&th);
    let exact = ln_likelihood_theta_noise(&lik, &th);
    assert!(
        (fixed - exact).abs() < 1e-9 * fixed.abs(),
        "{fixed} vs {exact}"
    );
    let mut other = th.clone();
    other[3] = 0.005; // bc
    let d = ln_likelihood_theta_noise(&lik, &other) - lik.ln_likelihood_whittle(&other);
    assert!(d.abs() > 1.0, "the noise at bc = 0.005 differs: {d}");
    assert_eq!(noise_parameters(&lik, &th, &[0, 1, 2, 3]), vec![0, 1, 2, 3]);
    // bin by bin (what the Python package's ln_likelihood_per_bin gives): the same sum, and
    // at the prepared point the fixed-noise terms
    let per_bin: f64 = ln_likelihood_theta_noise_per_bin(&lik, &other)
        .iter()
        .flatten()
        .sum();
    let total = ln_likelihood_theta_noise(&lik, &other);
    assert!(
        (per_bin - total).abs() < 1e-9 * total.abs(),
        "{per_bin} vs {total}"
    );
    assert_fixed_at_its_point(&lik, &th);
}

/// With gaps, each run's bins take their exact noise covariance (the taper's leakage), so the
/// θ-dependent `ln L` applies the same leakage to the noise it evaluates at θ
/// ([`occam::likelihood::NoiseLeak`]): at the spectra's point the two are again equal to
/// rounding, bin by bin. Before it they differed wherever a run's low bins leak (the test
/// checks that some bin's leakage moves its noise by more than 5 %, so it would tell).
#[test]
fn with_gaps_the_exact_likelihood_is_still_the_fixed_one_at_its_point() {
    let s = study(None);
    let mut prep = prepare_select(&s).unwrap();
    for e in &mut prep.dataset.experiments {
        let n = e.n_samples();
        e.add_gaps(&[
            [n / 5, n / 5 + 150],
            [n / 2, n / 2 + 400],
            [4 * n / 5, 4 * n / 5 + 60],
        ]);
    }
    let mi = s.models.index("damper").unwrap();
    let th = reference_point(&s, mi);
    let lik = likelihood_at(&s, mi, &prep.dataset, &th).unwrap();
    assert!(lik.spectra().len() > 2, "the gaps make runs");
    let leaks = lik
        .spectra()
        .iter()
        .filter_map(|e| e.noise_leak.as_ref())
        .flat_map(|l| {
            let n = l.channels.len();
            l.transforms.chunks(n * n).map(move |t| {
                (0..n)
                    .map(|i| (t[i * n + i].norm() - 1.0).abs())
                    .fold(0.0, f64::max)
            })
        })
        .fold(0.0, f64::max);
    eprintln!("largest leakage factor on a diagonal: {leaks:.3}");
    assert!(
        leaks > 0.05,
        "no bin leaks: the test has no power ({leaks})"
    );
    assert_fixed_at_its_point(&lik, &th);
}

/// The θ-dependent `ln L` at the spectra's point `th` equals the fixed one, bin by bin, to
/// rounding.
fn assert_fixed_at_its_point(lik: &occam::likelihood::Likelihood, th: &[f64]) {
    let fixed_bins = lik.ln_likelihood_per_bin(th).unwrap();
    for (a, b) in ln_likelihood_theta_noise_per_bin(lik, th)
        .iter()
        .flatten()
        .zip(fixed_bins.iter().flatten())
    {
        assert!((a - b).abs() < 1e-9 * b.abs().max(1.0), "{a} vs {b}");
    }
}

/// The own-noise likelihood of `spec` on `data`, from the study's start and reference point.
fn own_noise(
    s: &Study,
    spec: &occam::config::ModelSpec,
    data: &occam::data::dataset::Dataset,
) -> Option<(
    occam::likelihood::Likelihood,
    occam::jobs::own_noise::NoisePoint,
)> {
    own_noise_likelihood(
        s,
        spec,
        &default_start(s, spec),
        reference_point(s, spec.model),
        &|at: &[f64]| likelihood_at(s, spec.model, data, at),
    )
    .unwrap()
}

/// The iterated noise point lands on the MAP whatever the first point, so the likelihood the
/// samplers run on does not depend on `[fit] start`.
#[test]
fn the_noise_point_converges_to_the_same_map_from_any_start() {
    let mut points = Vec::new();
    for bc in [0.0, 0.025, 0.045] {
        let s = study(Some(bc));
        let prep = prepare_select(&s).unwrap();
        let spec = &s.select_models[0].spec;
        let (lik, p) = own_noise(&s, spec, &prep.dataset).expect("the noise moves with bc");
        eprintln!("start bc = {bc}: {p:?}");
        assert!(p.converged, "{p:?}");
        let sd = cramer_rao(&fisher_exact(&lik, &p.theta, &spec.free)).unwrap();
        points.push((p.theta, sd));
    }
    for (th, sd) in &points[1..] {
        for i in 0..4 {
            let z = (th[i] - points[0].0[i]) / sd[i];
            assert!(z.abs() < 0.05, "parameter {i}: {z}σ apart");
        }
    }
}

/// `ln Z` of `d` by importance sampling from a multivariate Student-t (ν = 5) at `centre`
/// with covariance `2 cov` (heavier than the posterior in every direction): i.i.d. draws, so
/// the error is the weights' own scatter. Draws outside the prior have weight 0.
fn importance_ln_z(
    d: &dyn LogDensity,
    centre: &[f64],
    cov: &DMatrix<f64>,
    n: usize,
    seed: u64,
) -> (f64, f64) {
    let dim = centre.len();
    let l = (cov * 2.0).cholesky().unwrap().l();
    let nu = 5.0;
    let chi = ChiSquared::new(nu).unwrap();
    let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed);
    let ln_det_l: f64 = l.diagonal().iter().map(|v| v.ln()).sum();
    let ln_c = ln_gamma((nu + dim as f64) / 2.0)
        - ln_gamma(nu / 2.0)
        - dim as f64 / 2.0 * (nu * std::f64::consts::PI).ln()
        - ln_det_l;
    let mut lw = Vec::with_capacity(n);
    for _ in 0..n {
        let z = DVector::from_iterator(dim, (0..dim).map(|_| StandardNormal.sample(&mut rng)));
        let u: f64 = chi.sample(&mut rng);
        let x = &l * &z * (nu / u).sqrt();
        let th: Vec<f64> = centre.iter().zip(x.iter()).map(|(c, v)| c + v).collect();
        // ln q: (x Σ⁻¹ x) = |z|² ν/u
        let m = z.norm_squared() * nu / u;
        let ln_q = ln_c - (nu + dim as f64) / 2.0 * (1.0 + m / nu).ln();
        let lp = d.ln_posterior(&th);
        lw.push(if lp.is_finite() {
            lp - ln_q
        } else {
            f64::NEG_INFINITY
        });
    }
    let top = lw.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let w: Vec<f64> = lw.iter().map(|v| (v - top).exp()).collect();
    let mean = w.iter().sum::<f64>() / n as f64;
    let var = w.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
    (top + mean.ln(), (var / n as f64).sqrt() / mean)
}

/// `ln B` of the exact θ-dependent likelihood by importance sampling of each model, around
/// its own-noise MAP with its Fisher covariance (an estimator `select` does not use).
fn exact_reference(s: &Study) -> (f64, f64) {
    let prep = prepare_select(s).unwrap();
    let mut z = Vec::new();
    for (k, m) in s.select_models.iter().enumerate() {
        let spec = &m.spec;
        let (lik, p) = own_noise(s, spec, &prep.dataset).unwrap();
        let f = fisher_exact(&lik, &p.theta, &spec.free);
        let cov = f.try_inverse().unwrap();
        let sub =
            SubModel::new(ThetaNoiseDensity(&lik), spec.free.clone(), p.theta.clone()).unwrap();
        let centre: Vec<f64> = spec.free.iter().map(|&a| p.theta[a]).collect();
        let r = importance_ln_z(&sub, &centre, &cov, 20_000, 100 + k as u64);
        eprintln!("model {}: exact ln Z = {:.4} ± {:.4}", m.name, r.0, r.1);
        z.push(r);
    }
    (z[0].0 - z[1].0, z[0].1.hypot(z[1].1))
}

/// The headline: `ln B` (damper vs springs) from the `[fit] start` of `bc` farthest from its
/// MAP (before the fix, each start gave its own `ln B`: bridge −5.55 ± 0.07, −10.42 ± 0.50
/// and −11.29 ± 0.13 from `bc` = 0, 0.025 and 0.045 on this study) agrees with the exact
/// θ-dependent evidence within 3 combined σ on every statistical row (that the noise point, hence every row, does not
/// depend on the start is the test above).
#[test]
fn the_bayes_factor_agrees_with_the_exact_evidence() {
    let reference = exact_reference(&study(None));
    eprintln!(
        "exact θ-dependent ln B = {:.4} ± {:.4}",
        reference.0, reference.1
    );
    let s = study(Some(0.045));
    let prep = prepare_select(&s).unwrap();
    let out = run(&s, &prep, None).unwrap();
    let p = &out.pairs[0];
    for m in &out.models {
        eprintln!("{}: correction {:?}", m.name, m.noise_correction);
        let c = m
            .noise_correction
            .expect("the noise moves with the parameters");
        assert!(!c.unreliable(), "{c:?}");
    }
    for e in &p.estimates {
        eprintln!("{:28} {:?} ± {:?}", e.method, e.ln_b, e.std_err);
    }
    for m in [
        "RJMCMC Rao-Blackwell",
        "RJMCMC bridge",
        "Thermodynamic integration",
        "Stepping-stone",
    ] {
        let e = p.estimates.iter().find(|e| e.method == m).unwrap();
        let (b, se) = (e.ln_b.unwrap(), e.std_err.unwrap());
        let z = (b - reference.0) / se.hypot(reference.1);
        assert!(
            z.abs() < 3.0,
            "{m}: {b} ± {se} vs exact {reference:?}: {z}σ"
        );
    }
}
