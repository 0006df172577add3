//! Cost of one `ln L` evaluation of each statistic (`[analysis] statistic`) on the Table I
//! study (`examples/tn3045.toml`: two experiments, the built-in closed loop, seven
//! parameters), at the truth, exact likelihood (no relative binning).
//!
//! `cargo run --release --example statistic_cost`

use occam::config::Study;
use occam::likelihood::Statistic;
use std::path::Path;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut study = Study::load(&root.join("examples/tn3045.toml"))?;
    let prep = occam::jobs::prepare::prepare(&study)?;
    let mi = study.fit_model.model;
    let th = study.truth.to_array();
    for stat in [
        Statistic::Whittle,
        Statistic::StudentT,
        Statistic::Wishart,
        Statistic::LogPeriodogram,
    ] {
        study.analysis.statistic = stat;
        let lik = occam::jobs::prepare::likelihood_of(&study, mi, &prep.dataset)?;
        let mut x = th;
        let mut s = 0.0;
        // warm-up (and the log-periodogram's thread-local buffers)
        s += lik.ln_likelihood_full(&x);
        let reps = 200;
        let t0 = Instant::now();
        for k in 0..reps {
            x[0] = th[0] * (1.0 + 1e-9 * k as f64);
            s += lik.ln_likelihood_full(&x);
        }
        let per = t0.elapsed().as_secs_f64() / reps as f64;
        let extra = match stat {
            Statistic::StudentT => format!(", ν = {:?}", lik.student_t_dof()),
            Statistic::Wishart => format!(", M = {:?}", lik.wishart_averages()),
            Statistic::LogPeriodogram => format!(
                ", retained Welch bins and M_eff per experiment {:?}",
                lik.log_periodogram_bins()
                    .iter()
                    .map(|(f, m)| (f.len(), (m * 100.0).round() / 100.0))
                    .collect::<Vec<_>>()
            ),
            Statistic::Whittle => String::new(),
        };
        println!(
            "{:>16}: {:.1} µs per ln L ({} in-band bins, series of {} samples{extra}; checksum {s:.6e})",
            stat.name(),
            per * 1e6,
            lik.n_bins(),
            lik.spectra().iter().map(|e| e.n).sum::<usize>(),
        );
    }
    Ok(())
}
