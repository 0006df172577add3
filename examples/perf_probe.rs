//! Timing probe for the prepared LTP kernel and relative binning (Table I study).
use occam::config::Study;
use occam::experiment::{System, simulate};
use occam::likelihood::{
    ExperimentSpectra, Likelihood, NoiseSource, RelBinLikelihood, SpectraOptions,
};
use occam::model::{LtpModel, Model};
use std::hint::black_box;
use std::sync::Arc;
use std::time::Instant;

fn rate(mut f: impl FnMut(usize) -> f64) -> f64 {
    let mut acc = f(0);
    let t0 = Instant::now();
    let mut n = 0;
    while t0.elapsed().as_secs_f64() < 1.0 {
        n += 1;
        acc += f(n);
    }
    black_box(acc);
    n as f64 / t0.elapsed().as_secs_f64()
}

fn main() {
    let study = Study::load(std::path::Path::new("examples/tn3045.toml")).unwrap();
    let sim = simulate(&study).unwrap();
    let sys = System::of(&study);
    let csd = |f: f64| sys.noise_csd(f);
    let opts = SpectraOptions {
        noise: NoiseSource::Welch,
        ..Default::default()
    };
    let model: Arc<dyn Model> = Arc::new(LtpModel::new(
        "ltp",
        occam::model::LtpModelOptions {
            masses: study.masses,
            ..Default::default()
        },
    ));
    let th = study.truth.to_array();
    let spectra: Vec<_> = sim
        .dataset
        .experiments
        .iter()
        .map(|e| ExperimentSpectra::new(e, &opts, model.as_ref(), &th, Some(&csd)).unwrap())
        .collect();
    for e in &spectra {
        println!("{} n={} f0={} df={}", e.name, e.len(), e.freqs[0], e.df);
    }
    let lik = Likelihood::new(model, spectra, study.models.priors[0].clone()).unwrap();
    let rb = RelBinLikelihood::new(&lik, &th, &Default::default()).unwrap();
    if std::env::var("ONLY_RB").is_ok() {
        let mut x = th;
        let c = rate(|k| {
            x[4] = th[4] + 1e-9 * (k % 7) as f64;
            rb.ln_likelihood_full(&x)
        });
        println!("relbin batched {c:.0}/s");
        return;
    }
    for _ in 0..3 {
        let mut x = th;
        let a = rate(|k| {
            x[4] = th[4] + 1e-9 * (k % 7) as f64;
            lik.ln_likelihood_full(&x)
        });
        let b = rate(|k| {
            x[4] = th[4] + 1e-9 * (k % 7) as f64;
            -lik.residual_power_unprepared(&x)
        });
        let c = rate(|k| {
            x[4] = th[4] + 1e-9 * (k % 7) as f64;
            rb.ln_likelihood_full(&x)
        });
        let d = rate(|k| {
            x[4] = th[4] + 1e-9 * (k % 7) as f64;
            rb.ln_likelihood_unbatched(&x)
        });
        println!(
            "exact prepared {a:.0}/s  unprepared {b:.0}/s  relbin batched {c:.0}/s  unbatched {d:.0}/s"
        );
    }
}
