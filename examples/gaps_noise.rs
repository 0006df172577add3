//! How far the Welch noise estimate of a study with gaps is from the true noise, bin by bin:
//! for each seed the study is prepared twice, with the Welch estimate (`noise = "welch"`)
//! and with the exact noise model (`noise = "model"`), with and without its gaps, and the
//! ratio of the two estimates' residual PSDs (each channel's diagonal) is averaged over
//! realisations in octave bands of frequency. A ratio below 1 where the information lies
//! makes the Fisher errors short there.
//!
//!   cargo run --release --example gaps_noise -- examples/gaps.toml 40

use occam::config::Study;
use occam::jobs::prepare::prepare;
use occam::likelihood::NoiseSource;
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::path::Path;

/// Per (channel, octave): sum of ratio, sum of 1/ratio, count; and the dofs seen.
type Acc = (BTreeMap<(usize, i32), (f64, f64, f64)>, Vec<f64>);

fn one(base: &Study, seed: u64) -> Acc {
    let mut s = base.clone();
    s.seed = seed;
    let welch = prepare(&s).expect("prepare welch");
    s.analysis.noise = NoiseSource::Model;
    let model = prepare(&s).expect("prepare model");
    let mut acc: BTreeMap<(usize, i32), (f64, f64, f64)> = BTreeMap::new();
    let mut dofs = Vec::new();
    for (w, m) in welch
        .likelihood
        .spectra()
        .iter()
        .zip(model.likelihood.spectra())
    {
        assert_eq!(w.name, m.name);
        dofs.push(w.noise_dof.unwrap_or(f64::NAN));
        let r = w.nr;
        for (k, f) in w.freqs.iter().enumerate() {
            let oct = f.log2().floor() as i32;
            for c in 0..r {
                let i = k * r * r + c * r + c;
                let q = w.csd[i].re / m.csd[i].re;
                let e = acc.entry((c, oct)).or_default();
                e.0 += q;
                e.1 += 1.0 / q;
                e.2 += 1.0;
            }
        }
    }
    (acc, dofs)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let path = args.get(1).map_or("examples/gaps.toml", String::as_str);
    let n: u64 = args.get(2).map_or(20, |s| s.parse().expect("N"));
    let gapped = Study::load(Path::new(path)).expect("study");
    let free = gapped.without_gaps();
    for (label, study) in [("with gaps", &gapped), ("without gaps", &free)] {
        let all: Vec<Acc> = (0..n)
            .into_par_iter()
            .map(|k| one(study, study.seed.wrapping_add(1000 + k)))
            .collect();
        let mut tot: BTreeMap<(usize, i32), (f64, f64, f64)> = BTreeMap::new();
        let mut dofs = Vec::new();
        for (a, d) in all {
            dofs.extend(d);
            for (key, v) in a {
                let e = tot.entry(key).or_default();
                e.0 += v.0;
                e.1 += v.1;
                e.2 += v.2;
            }
        }
        dofs.sort_by(f64::total_cmp);
        println!(
            "\n{label}: {n} realisations; Welch dof per spectrum: min {:.1}, median {:.1}, max {:.1}",
            dofs[0],
            dofs[dofs.len() / 2],
            dofs[dofs.len() - 1]
        );
        println!(
            "{:>3} {:>20} {:>10} {:>10} {:>8}",
            "ch", "band (Hz)", "<Ŝ/S>", "<S/Ŝ>", "bins"
        );
        for ((c, oct), (q, iq, cnt)) in tot {
            println!(
                "{c:>3} {:>9.2e}–{:<9.2e} {:>10.4} {:>10.4} {:>8}",
                2f64.powi(oct),
                2f64.powi(oct + 1),
                q / cnt,
                iq / cnt,
                cnt
            );
        }
    }
}
