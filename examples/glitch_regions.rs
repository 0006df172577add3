//! Whether the modelled glitches of a simulated study sit at the best joint maximum: for each
//! detected region whose candidates can be matched one to one with the glitches injected in
//! it, the MAP search is run again from the injected glitches (loop at the MAP) and its
//! `ln L` compared with the MAP's.
//!
//!   cargo run --release --example glitch_regions -- STUDY

use occam::config::Study;
use occam::density::LogDensity;
use occam::jobs::prepare::{default_start, prepare};
use occam::likelihood::fisher_scoring;
use occam::model::map_tolerance;
use std::path::Path;

fn main() {
    let path = std::env::args()
        .nth(1)
        .expect("usage: glitch_regions STUDY");
    let study = Study::load(Path::new(&path)).unwrap_or_else(|e| panic!("{path}: {e}"));
    let t = std::time::Instant::now();
    let prep = prepare(&study).unwrap_or_else(|e| panic!("prepare: {e}"));
    let study = prep.study(&study).clone();
    let lik = &prep.likelihood;
    let free = &study.fit_model.free;
    let tol = map_tolerance(lik.model().as_ref());
    let start = default_start(&study, &study.fit_model);
    let map = fisher_scoring(lik, &start, free, tol, 200).expect("MAP");
    let names = lik.model().param_names();
    let lp_map = lik.ln_posterior(&map.theta);
    println!(
        "prepared and MAP in {:.0} s (converged {}), ln post {lp_map:.3}",
        t.elapsed().as_secs_f64(),
        map.converged
    );
    let idx = |n: &str| names.iter().position(|m| m == n).expect(n);
    let g = prep.dataset.extra["glitches"]
        .as_object()
        .expect("glitches");
    let mut regions: Vec<(String, [f64; 2])> = Vec::new();
    for c in &prep.glitch_candidates {
        if !regions.contains(&(c.experiment.clone(), c.region)) {
            regions.push((c.experiment.clone(), c.region));
        }
    }
    for (exp, region) in regions {
        let cands: Vec<_> = prep
            .glitch_candidates
            .iter()
            .filter(|c| c.experiment == exp && c.region == region)
            .collect();
        // Δg = a2 − a1: a push on test mass 1 is −A
        let inj: Vec<[f64; 3]> = g[&exp]["fit"]
            .as_array()
            .into_iter()
            .flatten()
            .filter_map(|x| {
                let t0 = x["t0"].as_f64()?;
                let a = x["amplitude"].as_f64()? * if x["tm"].as_u64()? == 1 { -1.0 } else { 1.0 };
                (region[0] <= t0 && t0 < region[1]).then_some([t0, x["decay"].as_f64()?, a])
            })
            .collect();
        println!("{exp} [{:.0}, {:.0}] s:", region[0], region[1]);
        for c in &cands {
            let v = |s: &str| map.theta[idx(&format!("{}_{s}", c.name))];
            println!(
                "  {} fitted t0 {:.1} tau {:.1} a {:.3e}",
                c.name,
                v("t0"),
                v("tau"),
                v("a")
            );
        }
        for i in &inj {
            println!("  injected t0 {:.1} tau {:.1} a {:.3e}", i[0], i[1], i[2]);
        }
        if inj.len() != cands.len() {
            continue;
        }
        let mut th = map.theta.clone();
        for (c, i) in cands.iter().zip(&inj) {
            for (s, v) in ["t0", "tau", "a"].iter().zip(i) {
                th[idx(&format!("{}_{s}", c.name))] = *v;
            }
        }
        match fisher_scoring(lik, &th, free, tol, 200) {
            Ok(m) => println!(
                "  from the injected: converged {}, ln post {:.3} ({:+.3} against the MAP)",
                m.converged,
                lik.ln_posterior(&m.theta),
                lik.ln_posterior(&m.theta) - lp_map
            ),
            Err(e) => println!("  from the injected: {e}"),
        }
    }
}
