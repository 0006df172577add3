//! Modelled glitches cover: over noise realisations of `examples/glitches-short.toml` (Table I's
//! loop at 1 Hz, two force glitches per experiment, `glitches = "model"`), the loop parameters'
//! MAP scatters about the truth as their Fisher errors say. The reduced form of the glitch
//! guide's table (`cargo run --release --example glitch_coverage --
//! examples/glitches-short.toml 40 modelled`), with the power to fail on error bars 20 % off
//! or a 2σ bias of any one parameter, checked on the realisations themselves.

use occam::config::Study;
use occam::jobs::prepare::{default_start, prepare, reference_point};
use occam::likelihood::{cramer_rao, fisher_exact, fisher_scoring};
use occam::model::map_tolerance;
use rayon::prelude::*;
use std::path::Path;

/// Realisations: seeds 3014–3037 (the coverage example's first 24; about three minutes on two
/// cores).
const REALISATIONS: u64 = 24;

/// From pulls `z[realisation][parameter]` with their errors scaled by `scale`: the RMS pull
/// over every value, its standard error (from the realisations' own mean squares: the
/// parameters of one realisation are correlated, the realisations are not), and each
/// parameter's mean pull.
fn statistics(z: &[Vec<f64>], scale: f64) -> (f64, f64, Vec<f64>) {
    let n = z.len() as f64;
    let own: Vec<f64> = z
        .iter()
        .map(|p| p.iter().map(|v| (v / scale).powi(2)).sum::<f64>() / p.len() as f64)
        .collect();
    let m = own.iter().sum::<f64>() / n;
    let rms = m.sqrt();
    let se =
        (own.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0) / n).sqrt() / (2.0 * rms);
    let means = (0..z[0].len())
        .map(|k| z.iter().map(|p| p[k] / scale).sum::<f64>() / n)
        .collect();
    (rms, se, means)
}

/// The bounds: the RMS pull within 0.12 of 1 (its standard error at 24 realisations is about
/// 0.045; error bars 20 % too small make it 1.25, too large 0.83), every mean pull within 0.7
/// (3.4 standard errors of a mean of 24 unit pulls; a 2σ bias makes it 2).
fn holds((rms, _, means): &(f64, f64, Vec<f64>)) -> bool {
    (rms - 1.0).abs() < 0.12 && means.iter().all(|m| m.abs() < 0.7)
}

#[test]
fn modelled_glitches_cover_on_the_short_glitch_study() {
    let base = Study::load(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/glitches-short.toml"
    )))
    .unwrap();
    let truth = reference_point(&base, base.fit_model.model);
    let n_loop = base.fit_model.free.len();
    let names = base.models.models[base.fit_model.model].param_names();
    // per realisation: the loop's pulls; the injected glitches and those in a candidate's region
    let per: Vec<(Vec<f64>, usize, usize)> = (0..REALISATIONS)
        .into_par_iter()
        .map(|k| {
            let mut s = base.clone();
            s.seed = base.seed.wrapping_add(1000 + k);
            let prep = prepare(&s).unwrap();
            let study = prep.study(&s);
            let lik = &prep.likelihood;
            let spec = &study.fit_model;
            let map = fisher_scoring(
                lik,
                &default_start(study, spec),
                &spec.free,
                map_tolerance(lik.model().as_ref()),
                200,
            )
            .unwrap();
            assert!(
                map.converged,
                "seed {}: MAP search did not converge",
                s.seed
            );
            assert!(
                !map.at_bound[..n_loop].iter().any(|b| *b),
                "seed {}: a loop parameter's MAP on its bound",
                s.seed
            );
            let sd = cramer_rao(&fisher_exact(lik, &map.theta, &spec.free)).unwrap();
            let pulls = spec.free[..n_loop]
                .iter()
                .zip(&sd)
                .map(|(&i, s)| (map.theta[i] - truth[i]) / s)
                .collect();
            let (mut injected, mut found) = (0, 0);
            for (name, rec) in prep.dataset.extra["glitches"].as_object().unwrap() {
                for g in rec["fit"].as_array().into_iter().flatten() {
                    let t0 = g["t0"].as_f64().unwrap();
                    injected += 1;
                    found +=
                        usize::from(prep.glitch_candidates.iter().any(|c| {
                            &c.experiment == name && c.region[0] <= t0 && t0 < c.region[1]
                        }));
                }
            }
            (pulls, injected, found)
        })
        .collect();
    let z: Vec<Vec<f64>> = per.iter().map(|p| p.0.clone()).collect();
    for (k, p) in z.iter().enumerate() {
        eprintln!("seed {}: pulls {p:+.2?}", base.seed + 1000 + k as u64);
    }
    let injected: usize = per.iter().map(|p| p.1).sum();
    let found: usize = per.iter().map(|p| p.2).sum();
    eprintln!("{found} of {injected} injected glitches inside a modelled candidate's region");
    assert!(found * 100 >= injected * 98, "{found} of {injected}");
    let at = statistics(&z, 1.0);
    eprintln!("RMS pull {:.3} (standard error {:.3})", at.0, at.1);
    for (name, m) in names[..n_loop].iter().zip(&at.2) {
        eprintln!("{name}: mean pull {m:+.3}");
    }
    assert!(holds(&at), "RMS pull {:.3}, mean pulls {:.3?}", at.0, at.2);
    // the test's power, on the same realisations: error bars 20 % off either way, or a 2σ
    // bias of any one parameter, fail it
    for scale in [0.8, 1.2] {
        assert!(!holds(&statistics(&z, scale)), "errors × {scale} pass");
    }
    for k in 0..n_loop {
        let biased: Vec<Vec<f64>> = z
            .iter()
            .map(|p| {
                let mut p = p.clone();
                p[k] += 2.0;
                p
            })
            .collect();
        assert!(
            !holds(&statistics(&biased, 1.0)),
            "a 2σ bias of `{}` passes",
            names[k]
        );
    }
}
