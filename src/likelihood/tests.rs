//! Oracle and statistical tests of the likelihood.

use super::*;
use crate::config::Study;
use crate::data::dataset::ExperimentData;
use crate::experiment::simulate;
use crate::hermitian::Mat2;
use crate::ltp::{Controllers, LtpParams, N_PARAMS, response};
use crate::prior::Prior;
use crate::signal::dft_naive;
use num_complex::Complex64;
use std::path::Path;

/// The default `[prior]` boxes.
pub(crate) fn wide_prior() -> Prior {
    let m = ltp_model();
    let (names, kinds) = crate::model::LtpModel::new("ltp", Default::default())
        .default_priors()
        .into_iter()
        .unzip();
    assert_eq!(m.param_names(), &names);
    Prior::new(names, kinds).unwrap()
}

/// The built-in closed loop with default options.
pub(crate) fn ltp_model() -> std::sync::Arc<dyn crate::model::Model> {
    std::sync::Arc::new(crate::model::LtpModel::new("ltp", Default::default()))
}

/// A small two-experiment study (1 Hz sampling, short stretches) for fast tests.
pub(crate) fn small_study(seed: u64, amp: f64, noise: &str) -> Study {
    let text = format!(
        r#"seed = {seed}
output = "unused"
[simulation]
noise = "{noise}"
[[experiment]]
name = "a"
fs = 1.0
pre_pad = 200.0
post_pad = 1500.0
noise_duration = 4000.0
x1 = {{ kind = "sine_train", gap = 20.0, segments = [
  {{ freq = 0.002, amplitude = {amp}, duration = 500.0 }},
  {{ freq = 0.02, amplitude = {amp}, duration = 200.0 }},
  {{ freq = 0.1, amplitude = {amp}, duration = 100.0 }} ] }}
[[experiment]]
name = "b"
fs = 1.0
pre_pad = 200.0
post_pad = 1500.0
noise_duration = 4000.0
x12 = {{ kind = "sine_train", gap = 20.0, segments = [
  {{ freq = 0.002, amplitude = {amp}, duration = 500.0 }},
  {{ freq = 0.02, amplitude = {amp}, duration = 200.0 }} ] }}
"#
    );
    Study::from_toml(&text, "small.toml", Path::new(".")).unwrap()
}

/// The spectra of `study`'s simulated experiments for `model`, residual noise at `reference`.
pub(crate) fn spectra_for(
    study: &Study,
    opts: &SpectraOptions,
    model: &dyn crate::model::Model,
    reference: &[f64],
) -> Vec<ExperimentSpectra> {
    let sim = simulate(&study.simulation_plan()).unwrap();
    let sys = study.system();
    let csd = |f: f64| -> Mat2 { sys.noise_csd(f) };
    sim.dataset
        .experiments
        .iter()
        .map(|e| ExperimentSpectra::new(e, opts, model, reference, Some(&csd)).unwrap())
        .collect()
}

pub(crate) fn likelihood_of(study: &Study, opts: &SpectraOptions) -> Likelihood {
    let m = ltp_model();
    let spectra = spectra_for(study, opts, m.as_ref(), &study.truth.to_array());
    Likelihood::new(m, spectra, wide_prior()).unwrap()
}

fn model_opts() -> SpectraOptions {
    SpectraOptions {
        noise: NoiseSource::Model,
        band: [1e-3, 0.3],
        ..Default::default()
    }
}

/// The FFT-based ln L equals a naive direct sum: O(N²) DFT, explicit 2×2 solve per bin.
#[test]
fn fft_likelihood_equals_naive_direct_sum() {
    let study = small_study(11, 1e-7, "circular");
    let opts = model_opts();
    let lik = likelihood_of(&study, &opts);
    let sim = simulate(&study.simulation_plan()).unwrap();
    let sys = study.system();
    let th = LtpParams {
        a_df: 0.83,
        dt1: 0.1,
        ..Default::default()
    }
    .to_array();
    let mut naive = 0.0;
    let mut norm = 0.0;
    for e in &sim.dataset.experiments {
        let ExperimentData { o, i, fs, .. } = e;
        let n = o[0].len();
        let dft = [&o[0], &o[1], &i[0], &i[1]].map(|x| dft_naive(x));
        for k in 1..n / 2 {
            let f = k as f64 * fs / n as f64;
            if f < opts.band[0] || f > opts.band[1] {
                continue;
            }
            let bc = crate::ltp::BinConsts::new(f, &Controllers::default(), 0.0);
            let h = response(&th, &bc, &study.masses, [dft[2][k], dft[3][k]]);
            let r = [dft[0][k] - h[0], dft[1][k] - h[1]];
            let s = sys.noise_csd(f);
            let sc = n as f64 * fs / 2.0;
            let c = [[s[0][0] * sc, s[0][1] * sc], [s[1][0] * sc, s[1][1] * sc]];
            let det = c[0][0] * c[1][1] - c[0][1] * c[1][0];
            let x0 = (c[1][1] * r[0] - c[0][1] * r[1]) / det;
            let x1 = (c[0][0] * r[1] - c[1][0] * r[0]) / det;
            naive += (r[0].conj() * x0 + r[1].conj() * x1).re;
            norm += 2.0 * std::f64::consts::PI.ln() + det.re.ln();
        }
    }
    let fast = lik.ln_likelihood_full(&th);
    let want = -naive - norm;
    // naive DFT sums carry O(N ε) relative rounding on each bin
    assert!(
        ((fast - want) / want).abs() < 1e-9,
        "fft {fast} vs naive {want}"
    );
}

/// On pure noise at the true θ, `Q = Σ RᴴC⁻¹R` over K bins is a sum of K independent
/// Gamma(2, 1) variables (each bin is a circular complex Gaussian 2-vector): mean 2K, variance
/// 2K. Over M seeds the mean of Q/(2K) has standard error 1/√(2K M), and the sample variance
/// of Q/(2K) has relative standard error ≈ √(2/(M−1)); we allow 4 standard errors.
#[test]
fn residual_power_at_truth_is_chi_square_distributed() {
    let m = 120;
    let mut qs = Vec::new();
    let mut k_bins = 0;
    for seed in 0..m {
        let study = small_study(1000 + seed, 1e-7, "circular");
        let lik = likelihood_of(&study, &model_opts());
        k_bins = lik.n_bins();
        qs.push(lik.residual_power(&study.truth.to_array()) / (2 * k_bins) as f64);
    }
    let mean = qs.iter().sum::<f64>() / m as f64;
    let var = qs.iter().map(|q| (q - mean).powi(2)).sum::<f64>() / (m - 1) as f64;
    let k2 = (2 * k_bins) as f64;
    let se_mean = (1.0 / (k2 * m as f64)).sqrt();
    assert!(
        (mean - 1.0).abs() < 4.0 * se_mean,
        "mean {mean}, se {se_mean}"
    );
    let want_var = 1.0 / k2;
    let rel = (2.0 / (m - 1) as f64).sqrt();
    assert!(
        (var / want_var - 1.0).abs() < 4.0 * rel,
        "var {var} vs {want_var} (rel se {rel})"
    );
}

/// Exact (dual-number) and central-difference Fisher matrices agree.
#[test]
fn fisher_exact_matches_central_differences() {
    let study = small_study(5, 1e-6, "none");
    let lik = likelihood_of(&study, &model_opts());
    let th = study.truth.to_array();
    let free: Vec<usize> = (0..N_PARAMS).collect();
    let fe = fisher_exact(&lik, &th, &free);
    let fnum = fisher_numeric(&lik, &th, &free, None);
    for i in 0..N_PARAMS {
        for j in 0..N_PARAMS {
            let scale = (fe[(i, i)] * fe[(j, j)]).sqrt();
            // central differences with an ε^{1/3} step: error ~ ε^{2/3} ≈ 4e−11 relative,
            // amplified by the curvature of h; 1e−6 of the diagonal scale is ample
            assert!(
                (fe[(i, j)] - fnum[(i, j)]).abs() < 1e-6 * scale,
                "F[{i}][{j}]: exact {} numeric {}",
                fe[(i, j)],
                fnum[(i, j)]
            );
        }
    }
    assert!(cramer_rao(&fe).is_some());
}

/// The parts of [`fisher_parts`] sum to the whole matrix; a part holds exactly the bins
/// placed in it (the second experiment's alone is the Fisher matrix of a likelihood of that
/// experiment only); bins placed nowhere are left out.
#[test]
fn fisher_parts_sum_to_the_whole_and_hold_their_own_bins() {
    let study = small_study(5, 1e-6, "none");
    let lik = likelihood_of(&study, &model_opts());
    let th = study.truth.to_array();
    let free: Vec<usize> = (0..N_PARAMS).collect();
    let whole = fisher_exact(&lik, &th, &free);
    let by_band = fisher_parts(&lik, &th, &free, 3, |_, f| {
        Some(if f < 0.01 {
            0
        } else if f < 0.05 {
            1
        } else {
            2
        })
    });
    let sum = &by_band[0] + &by_band[1] + &by_band[2];
    for i in 0..N_PARAMS {
        for j in 0..N_PARAMS {
            let scale = (whole[(i, i)] * whole[(j, j)]).sqrt();
            assert!(
                (sum[(i, j)] - whole[(i, j)]).abs() < 1e-12 * scale,
                "F[{i}][{j}]"
            );
        }
    }
    // every band carries information on the sine at its frequency
    assert!(by_band.iter().all(|p| p[(0, 0)] > 0.0));
    let by_exp = fisher_parts(&lik, &th, &free, 2, |e, _| Some(e));
    let second =
        Likelihood::new(ltp_model(), vec![lik.spectra()[1].clone()], wide_prior()).unwrap();
    let alone = fisher_exact(&second, &th, &free);
    assert_eq!(by_exp[1], alone);
    let only_second = fisher_parts(&lik, &th, &free, 1, |e, _| (e == 1).then_some(0));
    assert_eq!(only_second[0], alone);
    // a part number past n_parts is placed nowhere
    let none = fisher_parts(&lik, &th, &free, 1, |_, _| Some(1));
    assert_eq!(none[0], nalgebra::DMatrix::zeros(N_PARAMS, N_PARAMS));
}

/// The likelihood is exactly quadratic in a parameter that enters h linearly. None of the
/// seven does, but at a noiseless truth ln L(θ0 + δ) − ln L(θ0) = −½ δᵀFδ to second order:
/// check the Fisher curvature against ln L itself along each axis (ltp-model.md §11).
#[test]
fn fisher_is_the_curvature_of_ln_l_at_noiseless_truth() {
    let study = small_study(5, 1e-6, "none");
    let lik = likelihood_of(&study, &model_opts());
    let th = study.truth.to_array();
    let free: Vec<usize> = (0..N_PARAMS).collect();
    let f = fisher_exact(&lik, &th, &free);
    let sig = cramer_rao(&f).unwrap();
    let l0 = lik.ln_likelihood_full(&th);
    for a in 0..N_PARAMS {
        let mut p = th;
        p[a] += 0.1 * sig[a];
        let dl = lik.ln_likelihood_full(&p) - l0;
        let want = -0.5 * f[(a, a)] * (0.1 * sig[a]).powi(2);
        assert!(
            (dl - want).abs() < 0.01 * want.abs() + 1e-9,
            "{a}: {dl} vs {want}"
        );
    }
}

/// Points on the `r`-σ ellipsoid of the Fisher covariance: ± each principal axis and `n`
/// random directions (whitened by the Cholesky factor of F⁻¹).
pub(crate) fn ellipsoid_points(
    f: &nalgebra::DMatrix<f64>,
    center: &[f64; N_PARAMS],
    r: f64,
    n: usize,
    seed: u64,
) -> Vec<[f64; N_PARAMS]> {
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};
    let cov = crate::linalg::Spd::new(f).unwrap().inverse();
    let l = crate::linalg::SpdOptions::lower().factor(&cov).unwrap().l();
    let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed);
    let mut dirs: Vec<Vec<f64>> = Vec::new();
    for i in 0..N_PARAMS {
        for s in [-1.0, 1.0] {
            let mut u = vec![0.0; N_PARAMS];
            u[i] = s;
            dirs.push(u);
        }
    }
    for _ in 0..n {
        let u: Vec<f64> = (0..N_PARAMS)
            .map(|_| StandardNormal.sample(&mut rng))
            .collect();
        let norm = u.iter().map(|x| x * x).sum::<f64>().sqrt();
        dirs.push(u.iter().map(|x| x / norm).collect());
    }
    dirs.iter()
        .map(|u| {
            std::array::from_fn(|i| {
                center[i] + r * (0..N_PARAMS).map(|j| l[(i, j)] * u[j]).sum::<f64>()
            })
        })
        .collect()
}

#[test]
fn relative_binning_matches_exact_in_the_5_sigma_region() {
    let study = small_study(9, 1e-6, "circular");
    let lik = likelihood_of(&study, &model_opts());
    let th = study.truth.to_array();
    let free: Vec<usize> = (0..N_PARAMS).collect();
    let f = fisher_exact(&lik, &th, &free);
    let rb = RelBinLikelihood::new(&lik, &th, &Default::default()).unwrap();
    assert!(
        rb.n_coarse() < lik.n_bins() / 2,
        "{} coarse bins",
        rb.n_coarse()
    );
    assert!((rb.ln_likelihood_full(&th) - lik.ln_likelihood_full(&th)).abs() < 1e-6);
    for p in ellipsoid_points(&f, &th, 5.0, 30, 1) {
        let d = rb.ln_likelihood_full(&p) - lik.ln_likelihood_full(&p);
        assert!(d.abs() < 0.01, "Δ ln L = {d} at {p:?}");
    }
}

#[test]
fn bad_bands_are_reported() {
    let study = small_study(1, 1e-6, "circular");
    let sim = simulate(&study.simulation_plan()).unwrap();
    let e = &sim.dataset.experiments[0];
    for band in [[2.0, 3.0], [0.3, 0.1], [0.0, 0.1]] {
        let opts = SpectraOptions {
            band,
            ..Default::default()
        };
        let err = ExperimentSpectra::new(
            e,
            &opts,
            ltp_model().as_ref(),
            &LtpParams::default().to_array(),
            None,
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains("band"), "{err}");
    }
    let _ = Complex64::new(0.0, 0.0);
}

#[test]
fn fisher_scoring_finds_the_maximum_from_far_away() {
    let study = small_study(21, 1e-6, "circular");
    let lik = likelihood_of(&study, &model_opts());
    let truth = study.truth.to_array();
    let free: Vec<usize> = (0..N_PARAMS).collect();
    let sig = cramer_rao(&fisher_exact(&lik, &truth, &free)).unwrap();
    let mut start = truth;
    start[0] *= 1.2;
    start[4] = 0.9;
    start[2] = 0.5;
    let r = fisher_scoring(&lik, &start, &free, 1e-4, 100).unwrap();
    assert!(r.converged, "{r:?}");
    // at the maximum the gradient vanishes: the Newton step is below 1e-4 σ
    let (g, f) = gradient_and_fisher(&lik, &r.theta, &free);
    let step = crate::linalg::Spd::new(&f)
        .unwrap()
        .solve(&nalgebra::DVector::from_vec(g));
    for i in 0..N_PARAMS {
        assert!(
            step[i].abs() < 1e-3 * sig[i],
            "param {i}: step {} σ {}",
            step[i],
            sig[i]
        );
        // and the estimate is within 5σ of the truth (a noise realisation)
        assert!((r.theta[i] - truth[i]).abs() < 5.0 * sig[i]);
    }
}

/// The first row of the closed loop as a one-residual model: `r = o1 − (H_io i)_1`.
#[derive(Debug)]
struct FirstRow {
    inner: crate::model::LtpModel,
    data: Vec<String>,
    res: Vec<String>,
}

impl crate::model::Model for FirstRow {
    fn name(&self) -> &str {
        "first_row"
    }
    fn param_names(&self) -> &[String] {
        self.inner.param_names()
    }
    fn data_channels(&self) -> &[String] {
        &self.data
    }
    fn residual_channels(&self) -> &[String] {
        &self.res
    }
    fn n_consts(&self) -> usize {
        self.inner.n_consts()
    }
    fn bin_consts(&self, f: f64, fs: f64, out: &mut [Complex64]) {
        self.inner.bin_consts(f, fs, out)
    }
    fn coefficients(&self, th: &[f64], bin: &crate::model::Bin, out: &mut [Complex64]) {
        let mut full = [Complex64::new(0.0, 0.0); 8];
        self.inner.coefficients(th, bin, &mut full);
        out.copy_from_slice(&full[..4]);
    }
    fn coefficients_dual(
        &self,
        th: &[num_dual::Dual64],
        bin: &crate::model::Bin,
        out: &mut [num_complex::Complex<num_dual::Dual64>],
    ) {
        let z = num_complex::Complex::new(num_dual::Dual64::from(0.0), num_dual::Dual64::from(0.0));
        let mut full = [z; 8];
        self.inner.coefficients_dual(th, bin, &mut full);
        out.copy_from_slice(&full[..4]);
    }
}

/// A one-residual model: its ln L is the marginal Gaussian of the o1 residual, `−Σ |R1|²/C11 −
/// Σ ln(π C11)`, built from the two-channel likelihood's own residuals and CSDs, with the
/// model noise and with the one-channel Welch estimate.
#[test]
fn one_residual_model_is_the_marginal_of_the_first_channel() {
    let study = small_study(5, 1e-7, "circular");
    let m = std::sync::Arc::new(FirstRow {
        inner: crate::model::LtpModel::new("ltp", Default::default()),
        data: ["o1", "o12", "i1", "i12"].map(String::from).to_vec(),
        res: vec!["o1".into()],
    });
    let th = LtpParams {
        a_df: 0.85,
        dt1: 0.3,
        ..Default::default()
    }
    .to_array();
    for noise in [NoiseSource::Model, NoiseSource::Welch] {
        let opts = SpectraOptions {
            noise,
            band: [1e-3, 0.3],
            ..Default::default()
        };
        let two = likelihood_of(&study, &opts);
        let spectra = spectra_for(&study, &opts, m.as_ref(), &study.truth.to_array());
        let one = Likelihood::new(m.clone(), spectra, wide_prior()).unwrap();
        let mut want = 0.0;
        for e in two.spectra() {
            let scale = e.fs / 2.0 * e.n as f64;
            two.visit_residuals(e, &th, |k, r, _| {
                let c11 = e.csd_at(k)[0].re * scale;
                want -= r[0].norm_sqr() / c11 + (std::f64::consts::PI * c11).ln();
            });
        }
        let got = one.ln_likelihood_full(&th);
        assert!(
            ((got - want) / want).abs() < 1e-12,
            "{noise:?}: {got} vs {want}"
        );
        assert_eq!(one.n_real_data(), two.n_real_data() / 2);
    }
}

/// Every variant of the built-in loop: the likelihood through prepared kernels equals the
/// generic path, and batched relative binning equals the unbatched evaluation (a fast path
/// that ignored an option would be caught here).
#[test]
fn prepared_and_batched_paths_agree_for_every_ltp_variant() {
    use crate::model::{LoopResponse, LtpModel, LtpModelOptions, ThrusterResponse};
    let study = small_study(9, 1e-7, "circular");
    let opts = model_opts();
    for (thruster, extra) in [
        (ThrusterResponse::None, None),
        (ThrusterResponse::Delay, Some(0.3)),
        (ThrusterResponse::Pole, Some(0.5)),
    ] {
        for response in [LoopResponse::Continuous, LoopResponse::Discrete] {
            let m = LtpModel::new(
                "v",
                LtpModelOptions {
                    thruster,
                    response,
                    ..Default::default()
                },
            );
            let (names, kinds): (Vec<String>, Vec<_>) = m.default_priors().into_iter().unzip();
            let prior = Prior::new(names, kinds).unwrap();
            let m: std::sync::Arc<dyn crate::model::Model> = std::sync::Arc::new(m);
            let mut th = LtpParams {
                dt1: 0.35,
                a_df: 0.9,
                ..Default::default()
            }
            .to_array()
            .to_vec();
            th.extend(extra);
            let spectra = spectra_for(&study, &opts, m.as_ref(), &th);
            let lik = Likelihood::new(m.clone(), spectra, prior).unwrap();
            let a = lik.residual_power(&th);
            let b = lik.residual_power_unprepared(&th);
            let c: f64 = lik
                .spectra()
                .iter()
                .map(|e| crate::model::residual_power_generic(m.as_ref(), &th, &e.block()))
                .sum();
            let tag = format!("{thruster:?}/{response:?}");
            assert!(
                ((a - c) / c).abs() < 1e-11,
                "{tag}: prepared {a} vs generic {c}"
            );
            assert!(
                ((b - c) / c).abs() < 1e-11,
                "{tag}: kernel {b} vs generic {c}"
            );
            let rb = RelBinLikelihood::new(&lik, &th, &Default::default()).unwrap();
            let mut p = th.clone();
            p[4] += 1e-3;
            p[2] += 0.01;
            let x = rb.ln_likelihood_full(&p);
            let y = rb.ln_likelihood_unbatched(&p);
            assert!(
                ((x - y) / y).abs() < 1e-12,
                "{tag}: batched {x} vs unbatched {y}"
            );
        }
    }
}

/// Where the loop is unstable (a thruster pole below ≈ 0.057 Hz at the Table I values) every
/// likelihood — exact, its Whittle form and relative binning — is −∞ and counts the refusal;
/// where it is stable it is the number it always was.
#[test]
fn unstable_parameter_values_get_minus_infinity_and_are_counted() {
    use crate::density::LogDensity;
    use crate::model::{LtpModel, LtpModelOptions, ThrusterResponse};
    let study = small_study(9, 1e-7, "circular");
    let m = LtpModel::new(
        "pole",
        LtpModelOptions {
            thruster: ThrusterResponse::Pole,
            ..Default::default()
        },
    );
    let (names, kinds): (Vec<String>, Vec<_>) = m.default_priors().into_iter().unzip();
    let prior = Prior::new(names, kinds).unwrap();
    let m: std::sync::Arc<dyn crate::model::Model> = std::sync::Arc::new(m);
    let at = |f_df: f64| {
        let mut th = LtpParams::default().to_array().to_vec();
        th.push(f_df);
        th
    };
    let spectra = spectra_for(&study, &model_opts(), m.as_ref(), &at(0.5));
    let lik = Likelihood::new(m.clone(), spectra, prior).unwrap();
    let stable = at(0.5);
    let unstable = at(0.03);
    assert!(m.is_stable(&stable) && !m.is_stable(&unstable));
    // stable: a number, as before (the goldens pin it: no study's number moved but where
    // its samplers went into unstable values)
    assert_eq!(
        lik.ln_likelihood(&stable),
        lik.ln_likelihood_whittle(&stable)
    );
    assert!(lik.ln_likelihood(&stable).is_finite());
    assert_eq!(lik.unstable_evaluations(), 0);
    // unstable: −∞ from every entry point, each counted; the residual power itself is finite
    assert!(lik.residual_power(&unstable).is_finite());
    assert_eq!(lik.ln_likelihood(&unstable), f64::NEG_INFINITY);
    assert_eq!(lik.ln_likelihood_whittle(&unstable), f64::NEG_INFINITY);
    assert_eq!(lik.unstable_evaluations(), 2);
    let rb = RelBinLikelihood::new(&lik, &stable, &Default::default()).unwrap();
    assert!(rb.ln_likelihood(&stable).is_finite());
    assert_eq!(rb.ln_likelihood(&unstable), f64::NEG_INFINITY);
    assert_eq!(rb.unstable_evaluations(), 1);
    // a MAP search started there says the start cannot be evaluated, with the model's reason;
    // it blamed the first parameter's prior ("outside the prior (parameter `w1sq`)")
    let free: Vec<usize> = (0..unstable.len()).collect();
    assert!(lik.prior().ln_pdf(&unstable).is_finite());
    let e = crate::likelihood::fisher_scoring(&lik, &unstable, &free, 1e-3, 20).unwrap_err();
    assert!(
        matches!(e, crate::likelihood::MapError::StartNotEvaluable(_)),
        "{e}"
    );
    let e = e.to_string();
    assert!(
        e.contains("cannot be evaluated at the start point") && !e.contains("outside the prior"),
        "{e}"
    );
}

/// The per-bin terms are each bin's share of `ln L`: one vector per experiment, one term per
/// in-band bin, summing to `ln L` (Whittle, two residual channels, two experiments).
#[test]
fn per_bin_terms_sum_to_ln_l() {
    let study = small_study(13, 1e-7, "circular");
    let lik = likelihood_of(&study, &model_opts());
    let truth = study.truth.to_array().to_vec();
    let mut off = truth.clone();
    off[2] *= 1.01;
    for th in [truth, off] {
        let terms = lik.ln_likelihood_per_bin(&th).unwrap();
        assert_eq!(terms.len(), lik.spectra().len());
        for (t, e) in terms.iter().zip(lik.spectra()) {
            assert_eq!(t.len(), e.len());
        }
        let sum: f64 = terms.iter().flatten().sum();
        let want = lik.ln_likelihood_full(&th);
        assert!((sum - want).abs() <= 1e-12 * want.abs(), "{sum} vs {want}");
    }
    let e = lik.ln_likelihood_per_bin(&[1.0]).unwrap_err().to_string();
    assert!(e.contains("1 parameter values for 7 parameters"), "{e}");
}

/// A window's bins are correlated: Hann's `|R_1| = 2/3`, `|R_2| = 1/6` and nothing beyond;
/// the rectangular window's bins are not.
#[test]
fn window_lags_are_the_window_s_bin_correlation() {
    use crate::signal::Window;
    assert!(
        window_lags(&Window::Rectangular.values(1000))
            .unwrap()
            .is_empty()
    );
    let r = window_lags(&Window::Hann.values(1000)).unwrap();
    assert_eq!(r.len(), 2, "{r:?}");
    assert!((r[0].norm() - 2.0 / 3.0).abs() < 1e-3, "{}", r[0]);
    assert!((r[1].norm() - 1.0 / 6.0).abs() < 1e-3, "{}", r[1]);
}

/// The score's covariance over noise realisations is [`score_covariance`]'s `J`, not the
/// Fisher matrix, when a Hann window correlates the bins: over 300 realisations the score
/// whitened by `J` has mean square 1 (standard error √(2/(300·7)) = 0.031; 20 % larger or
/// smaller error bars move it by 0.44 and 0.31), while whitened by `F` it is far above 1.
#[test]
fn the_score_covariance_is_j_when_a_window_correlates_the_bins() {
    use crate::signal::Window;
    let opts = SpectraOptions {
        window: Window::Hann,
        ..model_opts()
    };
    let m = 300;
    let free: Vec<usize> = (0..N_PARAMS).collect();
    let mut j = None;
    let mut f = None;
    let mut scores = Vec::new();
    for seed in 0..m {
        // small injections: a window makes `H(f_k)·DFT(w·i)` differ from `DFT(w·(h∗i))`
        // (leakage), a residual that grows with the injection's square, the score's noise
        // only with its amplitude
        let study = small_study(5000 + seed, 1e-11, "circular");
        let lik = likelihood_of(&study, &opts);
        let th = study.truth.to_array();
        let (g, fi) = gradient_and_fisher(&lik, &th, &free);
        if j.is_none() {
            j = Some(score_covariance(&lik, &th, &free));
            f = Some(fi);
        }
        scores.push(nalgebra::DVector::from_vec(g));
    }
    let mean_square = |c: &nalgebra::DMatrix<f64>| {
        let l = c.clone().cholesky().unwrap();
        scores
            .iter()
            .map(|g| l.l().solve_lower_triangular(g).unwrap().norm_squared())
            .sum::<f64>()
            / (m * N_PARAMS as u64) as f64
    };
    let (j, f) = (j.unwrap(), f.unwrap());
    let by_j = mean_square(&j);
    let by_f = mean_square(&f);
    eprintln!("whitened score mean square: by J {by_j}, by F {by_f}");
    assert!((by_j - 1.0).abs() < 0.12, "by J: {by_j}");
    assert!(by_f > 1.5, "by F: {by_f}");
}
