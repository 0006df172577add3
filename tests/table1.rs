//! The paper's Table I study on examples/tn3045.toml: the relative-binned likelihood matches
//! the exact one in the 5σ region, and the MCMC fit recovers every parameter within 3σ with
//! chain σ within 25 % of the Cramér-Rao σ.

mod common;

use occam::config::Study;
use occam::jobs::prepare::{prepare, relbin_of};
use occam::likelihood::{cramer_rao, fisher_exact, fisher_scoring};
use occam::ltp::N_PARAMS;
use std::path::Path;

fn study() -> Study {
    Study::load(Path::new("examples/tn3045.toml")).unwrap()
}

/// Points on the r-σ ellipsoid of F⁻¹: ± each axis of the Cholesky factor and random
/// directions.
fn ellipsoid(f: &nalgebra::DMatrix<f64>, c: &[f64], r: f64) -> Vec<[f64; N_PARAMS]> {
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};
    let l = f
        .clone()
        .cholesky()
        .unwrap()
        .inverse()
        .cholesky()
        .unwrap()
        .l();
    let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(3);
    let mut dirs: Vec<[f64; N_PARAMS]> = Vec::new();
    for i in 0..N_PARAMS {
        for s in [-1.0, 1.0] {
            let mut u = [0.0; N_PARAMS];
            u[i] = s;
            dirs.push(u);
        }
    }
    for _ in 0..40 {
        let mut u: [f64; N_PARAMS] = std::array::from_fn(|_| StandardNormal.sample(&mut rng));
        let n = u.iter().map(|x| x * x).sum::<f64>().sqrt();
        u.iter_mut().for_each(|x| *x /= n);
        dirs.push(u);
    }
    dirs.iter()
        .map(|u| {
            std::array::from_fn(|i| c[i] + r * (0..N_PARAMS).map(|j| l[(i, j)] * u[j]).sum::<f64>())
        })
        .collect()
}

#[test]
fn relative_binning_is_within_0_01_of_exact_over_the_5_sigma_region() {
    let s = study();
    let prep = prepare(&s).unwrap();
    let lik = &prep.likelihood;
    let free: Vec<usize> = (0..N_PARAMS).collect();
    let map = fisher_scoring(lik, &s.truth.to_array(), &free, 1e-3, 50).unwrap();
    assert!(map.converged);
    let f = fisher_exact(lik, &map.theta, &free);
    let rb = relbin_of(&s, lik, &map.theta).unwrap();
    let mut worst: f64 = 0.0;
    for p in ellipsoid(&f, &map.theta, 5.0) {
        let d = rb.ln_likelihood_full(&p) - lik.ln_likelihood_full(&p);
        worst = worst.max(d.abs());
    }
    eprintln!(
        "{} fine bins, {} coarse bins, worst |Δ ln L| = {worst:.2e} on the 5σ ellipsoid",
        lik.n_bins(),
        rb.n_coarse()
    );
    assert!(worst < 0.01, "worst |Δ ln L| = {worst}");
}

#[test]
fn table_one_fit_recovers_the_truth() {
    let mut s = study();
    s.fit.iterations = 8000;
    s.fit.burn_in = 3000;
    let prep = prepare(&s).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let o = occam::jobs::fit::run(&s, &prep, dir.path(), None, None, false).unwrap();
    let free: Vec<usize> = (0..N_PARAMS).collect();
    let cr = cramer_rao(&fisher_exact(&prep.likelihood, &o.map_full, &free)).unwrap();
    for (r, c) in o.summary.rows.iter().zip(&cr) {
        let pull = r.pull.unwrap();
        eprintln!(
            "{}: pull {pull:+.2}, σ/CR {:.3}, R-hat {:.4}, ESS {:.0}",
            r.name,
            r.sd / c,
            r.rhat,
            r.ess
        );
        assert!(pull.abs() < 3.0, "{}: {pull:.2}σ from the truth", r.name);
        // the chains' sd against the Cramér–Rao bound, within 4 of its own Monte-Carlo errors
        // (relative error of an sd from ESS draws ≈ 1/√(2 ESS): ±0.1 at ESS 850, where a
        // posterior 20 % too narrow fails; the old ±0.25 let it pass)
        assert!(r.ess > 400.0, "{}: ESS {}", r.name, r.ess);
        let tol = 4.0 / (2.0 * r.ess).sqrt();
        assert!(
            (r.sd / c - 1.0).abs() < tol,
            "{}: σ/CR = {} (± {tol} allowed at ESS {})",
            r.name,
            r.sd / c,
            r.ess
        );
        assert!(r.rhat < 1.05, "{}: R-hat {}", r.name, r.rhat);
    }
    // w1sq–w2sq at ρ = 0.85, condition number 22: no degeneracy to report
    assert!(
        !o.summary
            .warnings
            .iter()
            .any(|w| w.contains("nearly degenerate")),
        "{:?}",
        o.summary.warnings
    );
    occam::jobs::fit::write_outputs(&o, dir.path()).unwrap();
    for f in [
        "summary.json",
        "table.txt",
        "chains.npz",
        "trace.png",
        "trace.svg",
        "corner.png",
        "information.md",
        "information.json",
        "information.png",
    ] {
        assert!(dir.path().join(f).exists(), "{f}");
    }
    // where the information comes from: its σ is the Cramér–Rao bound at the MAP, x1's
    // experiment holds all of ω1²'s and x12's all of A_sus's, and the 53 mHz segment of x1
    // most of A_df's
    let info = o.information.as_ref().unwrap();
    for (s, c) in info.sigma.iter().zip(&cr) {
        assert!((s / c - 1.0).abs() < 1e-9, "{s} vs {c}");
    }
    let by_exp = &info.splits[0].parts;
    assert!(by_exp[0].share[0] > 0.999 && by_exp[1].share[5] > 0.999);
    let top = info.splits[1]
        .parts
        .iter()
        .find(|p| p.name.starts_with("inv1 x1 5.3"))
        .unwrap();
    assert!(top.share[4] > 0.5, "{top:?}");
}

/// A prior box that excludes the truth (a_df = 0.82 against [0.9, 1.5]) puts the MAP on its
/// lower bound: the fit still runs and says so, instead of exiting with no word about it.
#[test]
fn a_map_on_a_prior_bound_is_warned_about() {
    let mut s = study();
    s.fit.iterations = 1500;
    s.fit.burn_in = 500;
    s.fit.chains = 2;
    let mi = s.fit_model.model;
    let names = s.models.models[mi].param_names().to_vec();
    let mut kinds = s.models.priors[mi].kinds().to_vec();
    let k = names.iter().position(|n| n == "a_df").unwrap();
    kinds[k] = occam::prior::PriorKind::Uniform { lo: 0.9, hi: 1.5 };
    s.models.priors[mi] = occam::prior::Prior::new(names, kinds).unwrap();
    let prep = prepare(&s).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let o = occam::jobs::fit::run(&s, &prep, dir.path(), None, None, false).unwrap();
    assert!(
        (o.map_full[k] - 0.9).abs() < 1e-12,
        "MAP a_df = {}",
        o.map_full[k]
    );
    assert!(
        o.summary
            .warnings
            .iter()
            .any(|w| w.contains("bound of the prior box")
                && w.contains("`a_df` = 0.9 is on the lower bound")),
        "{:?}",
        o.summary.warnings
    );
}

/// `examples/tn3045-k14.toml` is the calibration of docs "What was measured": with the noise
/// model's CSD, every Cramér–Rao bound of Table I but Δt1's within 0.8–1.25 of K14's and of the
/// LTPDA training's (ltp-model.md §6.2), and Δt1's still about 8× K14's (no input of the
/// calibration moves it against A_df). Today's defaults (examples/tn3045.toml) are 2–2.7× off
/// for five of them, which this would catch if the preset drifted back.
#[test]
fn the_k14_preset_puts_every_bound_but_dt1_within_a_quarter_of_the_published_ones() {
    let bounds = |file: &str| {
        let mut s = Study::load(Path::new(file)).unwrap();
        s.analysis.noise = occam::likelihood::NoiseSource::Model;
        let prep = prepare(&s).unwrap();
        let free: Vec<usize> = (0..N_PARAMS).collect();
        cramer_rao(&fisher_exact(&prep.likelihood, &s.truth.to_array(), &free)).unwrap()
    };
    // (K14 Table I σ, the training's σ) in the order w1sq, w2sq, dt1, dt2, a_df, a_sus, d21
    let published: [(f64, Option<f64>); N_PARAMS] = [
        (2e-10, Some(1.7e-10)),
        (2e-10, Some(1.6e-10)),
        (5e-5, None),
        (2e-4, None),
        (2.5e-4, Some(2e-4)),
        (3e-6, Some(3.0e-6)),
        (1e-7, Some(1.1e-7)),
    ];
    let k14 = bounds("examples/tn3045-k14.toml");
    let today = bounds("examples/tn3045.toml");
    for (i, (s, (k, t))) in k14.iter().zip(published).enumerate() {
        if i == 2 {
            assert!((7.0..10.0).contains(&(s / k)), "dt1: σ ÷ K14 = {}", s / k);
            continue;
        }
        for (what, p) in [("K14", Some(k)), ("training", t)] {
            if let Some(p) = p {
                let r = s / p;
                assert!((0.8..=1.25).contains(&r), "parameter {i}: σ ÷ {what} = {r}");
            }
        }
    }
    let off = (0..N_PARAMS)
        .filter(|&i| today[i] / published[i].0 > 2.0)
        .count();
    assert_eq!(off, 6, "today's bounds: {today:?}");
}

/// Table I's error bars cover, over realisations of the study as shipped (Welch noise from
/// the noise-only stretch, ν = 29 degrees of freedom): per realisation the MAP (Fisher scoring
/// from the prior centre, as `occam fit` starts) and its sandwich error
/// `√(F⁻¹JF⁻¹)` ([`occam::likelihood::score_covariance`]), which `occam fit` reports beside the
/// Fisher (Cramér–Rao) error. The pulls `(MAP − truth)/σ` pooled over the seven parameters have
/// an RMS within 1 ± 2.5 of its own standard error (estimated from the realisations' mean
/// squares: the parameters of one realisation are correlated, the realisations are not), and
/// each parameter's mean pull is within 3/√n of 0. Error bars 20 % too large or too small move
/// the RMS by 17 % or 25 %, more than 3.5 standard errors at n = 60; a 2σ bias on one parameter
/// moves its mean by 2, 15/√n. The Fisher errors are short by √(ν/(ν−4)) = 1.077: measured over
/// 200 realisations (`OCCAM_TABLE1_REALISATIONS=200`), RMS pull 1.106 ± 0.024 by the Fisher
/// errors — which is why the fit reports the sandwich.
#[test]
fn table_one_error_bars_cover_over_realisations() {
    use occam::likelihood::score_covariance_differs;
    use rayon::prelude::*;
    let base = study();
    let n: u64 = std::env::var("OCCAM_TABLE1_REALISATIONS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(60);
    let truth = base.truth.to_array();
    let free: Vec<usize> = (0..N_PARAMS).collect();
    // per realisation and parameter: the pull by the sandwich and by the Fisher error
    let pulls: Vec<Vec<(f64, f64)>> = (0..n)
        .into_par_iter()
        .map(|k| {
            let mut s = base.clone();
            s.seed = base.seed.wrapping_add(3000 + k);
            let prep = prepare(&s).unwrap();
            let lik = &prep.likelihood;
            let why = score_covariance_differs(lik).expect("a Welch estimate");
            assert!(why.contains("ν = 29"), "{why}");
            common::map_pulls(&s, lik, &truth, &free)
        })
        .collect();
    let nf = n as f64;
    // the pooled RMS and its standard error from the realisations' own mean squares
    let rms = |pick: fn(&(f64, f64)) -> f64| {
        let own: Vec<f64> = pulls
            .iter()
            .map(|p| p.iter().map(|z| pick(z).powi(2)).sum::<f64>() / N_PARAMS as f64)
            .collect();
        let ms = own.iter().sum::<f64>() / nf;
        let se = (own.iter().map(|v| (v - ms).powi(2)).sum::<f64>() / (nf - 1.0) / nf).sqrt()
            / (2.0 * ms.sqrt());
        (ms.sqrt(), se)
    };
    let (sandwich, se) = rms(|z| z.0);
    let (fisher, fisher_se) = rms(|z| z.1);
    eprintln!(
        "{n} realisations: RMS pull {sandwich:.3} ± {se:.3} by the sandwich, {fisher:.3} ± {fisher_se:.3} by the Fisher errors"
    );
    let names = base.models.models[base.fit_model.model].param_names();
    let mut worst: f64 = 0.0;
    for i in 0..N_PARAMS {
        let z: Vec<f64> = pulls.iter().map(|p| p[i].0).collect();
        let mean = z.iter().sum::<f64>() / nf;
        let sd = (z.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (nf - 1.0)).sqrt();
        eprintln!("{}: mean pull {mean:+.3}, sd {sd:.3}", names[i]);
        worst = worst.max(mean.abs() * nf.sqrt());
    }
    assert!(
        (sandwich - 1.0).abs() < 2.5 * se,
        "RMS pull {sandwich:.3} is {:.1} standard errors from 1",
        (sandwich - 1.0) / se
    );
    assert!(worst < 3.0, "a mean pull is {worst:.2}/√n from 0");
}
