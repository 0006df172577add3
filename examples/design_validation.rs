//! Proxy against full model selection: for designs spanning the range (the TN3045 ladder of
//! examples/design-optimise.toml at amplitudes 0.1× to 30× the budget, the budget's own
//! baseline, and the chosen design if `design.json` is given), the Asimov proxy and the mean ±
//! s.e. of select's reference ln B over R noise realisations, their offsets and Spearman's ρ.
//!   cargo run --release --example design_validation -- examples/design-optimise.toml 16
use occam::config::Study;
use std::path::Path;

fn ranks(v: &[f64]) -> Vec<f64> {
    let mut idx: Vec<usize> = (0..v.len()).collect();
    idx.sort_by(|&a, &b| v[a].total_cmp(&v[b]));
    let mut r = vec![0.0; v.len()];
    for (k, &i) in idx.iter().enumerate() {
        r[i] = k as f64;
    }
    r
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let study = Study::load(Path::new(&args[1])).expect("study");
    let r: usize = args.get(2).map_or(16, |s| s.parse().expect("R"));
    let plan = study
        .design
        .clone()
        .expect("[design]")
        .validate(&study)
        .expect("valid");
    let base = plan.baseline();
    let (mut p, mut m) = (Vec::new(), Vec::new());
    println!(
        "{:>8} {:>9} {:>16} {:>8}",
        "scale", "proxy", "MC mean ± se", "offset"
    );
    for k in [0.1, 0.3, 1.0, 3.0, 10.0, 30.0] {
        let segs: Vec<Vec<(f64, f64)>> = base
            .iter()
            .map(|c| c.iter().map(|&(f, a)| (f, k * a)).collect())
            .collect();
        let proxy = occam::jobs::design::asimov_score(&study, &plan, plan.experiments(&segs))
            .expect("proxy")
            .ln_b;
        let v = occam::jobs::design::validate(&study, &plan, "v", &segs, r).expect("validate");
        let (mean, se) = (v.mean.unwrap(), v.std_err.unwrap());
        println!(
            "{k:>8} {proxy:>9.3} {mean:>8.3} ± {se:<6.3} {:>8.3}",
            proxy - mean
        );
        p.push(proxy);
        m.push(mean);
    }
    let (rp, rm) = (ranks(&p), ranks(&m));
    let n = p.len() as f64;
    let d2: f64 = rp.iter().zip(&rm).map(|(a, b)| (a - b).powi(2)).sum();
    println!(
        "Spearman rank correlation {:.3}",
        1.0 - 6.0 * d2 / (n * (n * n - 1.0))
    );
}
