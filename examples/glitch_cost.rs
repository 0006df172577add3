//! What a modelled-glitch likelihood costs on a study (`[analysis] glitches = "model"`): the
//! preparation (simulation, detection, the scan for the glitches' starts), one `ln L` after a
//! move of the loop's parameters and after a move of one glitch's, one Fisher pass (gradient
//! and Fisher matrix over every free parameter) and the multi-start MAP search of `occam fit`.
//!
//!   cargo run --release --example glitch_cost -- STUDY.toml [EVALUATIONS]
//!
//! For `examples/glitches.toml` with `glitches = "model"` see docs/src/guide/glitches.md
//! ("What it costs").

use occam::density::LogDensity as _;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let Some(path) = args.get(1) else {
        eprintln!("usage: glitch_cost STUDY.toml [EVALUATIONS]");
        std::process::exit(2);
    };
    let n: usize = args.get(2).map_or(20, |s| s.parse().expect("EVALUATIONS"));
    let study = occam::config::Study::load(std::path::Path::new(path)).expect("study");
    let t = Instant::now();
    let prep = occam::jobs::prepare::prepare(&study).expect("prepare");
    println!("prepare: {:.1} s", t.elapsed().as_secs_f64());
    let s = prep.study(&study);
    let lik = &prep.likelihood;
    let free = &s.fit_model.free;
    let start = occam::jobs::prepare::default_start(s, &s.fit_model);
    println!("{} free parameters", free.len());
    // each evaluation moves the parameter by a relative 1e−9, so that no cache holds it
    let per_eval = |i: usize| {
        let mut th = start.clone();
        let t = Instant::now();
        for k in 0..n {
            th[i] = start[i] * (1.0 + 1e-9 * (k + 1) as f64);
            std::hint::black_box(lik.ln_likelihood(&th));
        }
        t.elapsed().as_secs_f64() * 1e3 / n as f64
    };
    println!("ln L, loop parameter moved: {:.1} ms", per_eval(free[0]));
    let last = *free.last().expect("a free parameter");
    println!(
        "ln L, one glitch parameter ({}) moved: {:.1} ms",
        lik.model().param_names()[last],
        per_eval(last)
    );
    let t = Instant::now();
    std::hint::black_box(occam::likelihood::gradient_and_fisher(lik, &start, free));
    println!(
        "gradient and Fisher matrix: {:.2} s",
        t.elapsed().as_secs_f64()
    );
    let t = Instant::now();
    let map = occam::jobs::prepare::map_search(lik, free, &start, s.fit.map_starts);
    println!(
        "MAP search ({} quasi-random starts besides the given one): {:.1} s, {}",
        s.fit.map_starts,
        t.elapsed().as_secs_f64(),
        match &map {
            Ok(m) => format!("{} distinct maxima", m.maxima.len()),
            Err(e) => format!("failed: {e}"),
        }
    );
}
