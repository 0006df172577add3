use occam::config::Study;
use occam::jobs::prepare::{default_start, prepare};
use occam::likelihood::GlitchTreatment;
use std::path::Path;
use std::time::Instant;
fn main() {
    let base = Study::load(Path::new("examples/glitches.toml")).unwrap();
    let mut s = base.clone();
    s.analysis.glitches = GlitchTreatment::Model;
    let prep = prepare(&s).unwrap();
    let study = prep.study(&s).clone();
    let lik = &prep.likelihood;
    let th = default_start(&study, &study.fit_model);
    let n = 50;
    let mut x = 0.0;
    let t0 = Instant::now();
    for i in 0..n {
        let mut t = th.clone();
        t[0] *= 1.0 + 1e-9 * i as f64;
        x += lik.ln_likelihood_full(&t);
    }
    println!(
        "params {} loop moves {:.3} ms",
        th.len(),
        t0.elapsed().as_secs_f64() * 1e3 / n as f64
    );
    let t0 = Instant::now();
    for i in 0..n {
        let mut t = th.clone();
        t[7] += 1e-3 * i as f64;
        x += lik.ln_likelihood_full(&t);
    }
    println!(
        "one glitch t0 moves {:.3} ms",
        t0.elapsed().as_secs_f64() * 1e3 / n as f64
    );
    let t0 = Instant::now();
    for i in 0..n {
        let mut t = th.clone();
        t[9] *= 1.0 + 1e-3 * i as f64;
        x += lik.ln_likelihood_full(&t);
    }
    println!(
        "one amplitude moves {:.3} ms",
        t0.elapsed().as_secs_f64() * 1e3 / n as f64
    );
    let t0 = Instant::now();
    for i in 0..n {
        let mut t = th.clone();
        for j in 7..t.len() {
            t[j] *= 1.0 + 1e-6 * i as f64;
        }
        t[0] *= 1.0 + 1e-9 * i as f64;
        x += lik.ln_likelihood_full(&t);
    }
    println!(
        "all moves {:.3} ms {x}",
        t0.elapsed().as_secs_f64() * 1e3 / n as f64
    );
    let t0 = Instant::now();
    for _ in 0..5 {
        x += lik.residual_power_unprepared(&th);
    }
    println!(
        "generic {:.3} ms {x}",
        t0.elapsed().as_secs_f64() * 1e3 / 5.0
    );
}
