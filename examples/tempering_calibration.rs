//! Are `occam select`'s error bars right? The guidance-delay study (`examples/guidance-delays.toml`)
//! at ρ_opt = 60 on many independent data sets: every statistical row of every run against a
//! high-precision reference on the same data (issue 23, item 2).
//!
//! Per data seed `s` (the study's `seed`, which draws the noise; the samplers' `[select] seed`
//! is `s` too) the example runs `select` as a user would, then the reference on the same data:
//! a reversible-jump run 16 times longer (`rj_iterations × 16`, its own sampler seed, no
//! tempering), whose bridge estimate has a quarter of the standard run's error. Both run on
//! the relative-binned likelihood, as `select` does by default; with `[analysis] likelihood =
//! "exact"` and the same sampler seed the TI ln B of data seeds 60 and 15 moved by 0.002 and
//! 0.031 nats (the paths part once one accept decision differs), within its ± 0.022–0.027.
//! For every row it prints, over the seeds with a number:
//!
//! * `scatter ÷ stated`: the spread of `ln B − ln B_ref` over the root-mean-square of
//!   `√(σ² + σ_ref²)`; 1 when the stated errors are right;
//! * the mean offset from the reference and its standard error (a bias shows here);
//! * the fractions of pulls beyond 2σ and 3σ (4.6 % and 0.27 % for a Gaussian).
//!
//! ```text
//! cargo run --release --example tempering_calibration -- --seeds 200     # ≈ 15 s per seed
//! cargo run --release --example tempering_calibration -- --seeds 20 --first 1000 --snr 60
//! ```
//! A CSV of every run goes to `--csv FILE` (default `runs/tempering_calibration.csv`).

use occam::config::Study;
use occam::jobs::prepare::prepare_select;
use occam::jobs::select::SelectSummary;
use std::path::Path;

/// The statistical rows of a pair, in the table's order.
const ROWS: [&str; 5] = [
    "RJMCMC visits",
    "RJMCMC Rao-Blackwell",
    "RJMCMC bridge",
    "Thermodynamic integration",
    "Stepping-stone",
];

/// How much longer the reference's reversible jump runs.
const REF_FACTOR: usize = 16;

struct Args {
    seeds: usize,
    first: u64,
    snr: f64,
    csv: String,
}

fn args() -> Args {
    let mut a = Args {
        seeds: 200,
        first: 1,
        snr: 60.0,
        csv: "runs/tempering_calibration.csv".into(),
    };
    let mut it = std::env::args().skip(1);
    while let Some(k) = it.next() {
        let v = it.next().unwrap_or_else(|| panic!("{k} needs a value"));
        match k.as_str() {
            "--seeds" => a.seeds = v.parse().expect("--seeds: a count"),
            "--first" => a.first = v.parse().expect("--first: a seed"),
            "--snr" => a.snr = v.parse().expect("--snr: a number"),
            "--csv" => a.csv = v,
            _ => panic!("unknown option {k}: use --seeds, --first, --snr, --csv"),
        }
    }
    a
}

/// The study at `snr` on data seed `seed`; `reference` swaps the tempering for a reversible
/// jump [`REF_FACTOR`] times longer on its own sampler seed.
pub(crate) fn study_text(base: &str, snr: f64, seed: u64, reference: bool) -> String {
    let t = base
        .replace("target_snr = 450.0", &format!("target_snr = {snr:?}"))
        .replace("seed = 60\n", &format!("seed = {seed}\n"));
    let t = if reference {
        t.replace(
            "[select]\n",
            &format!(
                "[select]\nseed = {}\npt_temperatures = 0\n",
                seed + 1_000_000
            ),
        )
        .replace(
            "rj_iterations = 100000\n",
            &format!("rj_iterations = {}\n", 100_000 * REF_FACTOR),
        )
    } else {
        t.replace("[select]\n", &format!("[select]\nseed = {seed}\n"))
    };
    assert!(
        t.contains(&format!("seed = {seed}\n")) && t.contains("target_snr"),
        "examples/guidance-delays.toml changed: this example edits its `seed`, `target_snr` and `[select]` lines"
    );
    t
}

fn run(text: &str) -> SelectSummary {
    let study = Study::from_toml(text, "guidance-delays.toml", Path::new("examples")).unwrap();
    let prep = prepare_select(&study).unwrap();
    occam::jobs::select::run(&study, &prep, None).unwrap()
}

/// `(ln B, σ)` of `method` in the first pair, when it has both.
fn row(s: &SelectSummary, method: &str) -> Option<(f64, f64)> {
    let e = s.pairs[0].estimates.iter().find(|e| e.method == method)?;
    Some((e.ln_b?, e.std_err?))
}

/// What a row's pulls say: `(n, scatter ÷ stated, mean offset, its sd, > 2σ, > 3σ)`.
#[derive(Debug, PartialEq)]
pub(crate) struct Calibration {
    pub(crate) n: usize,
    pub(crate) ratio: f64,
    pub(crate) offset: f64,
    pub(crate) offset_se: f64,
    pub(crate) beyond2: f64,
    pub(crate) beyond3: f64,
}

/// `diffs[k] = (ln B − ln B_ref, combined stated σ)`.
pub(crate) fn calibrate(diffs: &[(f64, f64)]) -> Option<Calibration> {
    let n = diffs.len();
    if n < 2 {
        return None;
    }
    let k = n as f64;
    let mean = diffs.iter().map(|d| d.0).sum::<f64>() / k;
    let sd = (diffs.iter().map(|d| (d.0 - mean).powi(2)).sum::<f64>() / (k - 1.0)).sqrt();
    let rms = (diffs.iter().map(|d| d.1 * d.1).sum::<f64>() / k).sqrt();
    let frac = |z: f64| diffs.iter().filter(|d| d.0.abs() > z * d.1).count() as f64 / k;
    Some(Calibration {
        n,
        ratio: sd / rms,
        offset: mean,
        offset_se: sd / k.sqrt(),
        beyond2: frac(2.0),
        beyond3: frac(3.0),
    })
}

fn main() {
    let a = args();
    let base =
        std::fs::read_to_string("examples/guidance-delays.toml").expect("run from the crate root");
    let mut diffs: Vec<Vec<(f64, f64)>> = vec![Vec::new(); ROWS.len()];
    if let Some(dir) = Path::new(&a.csv).parent() {
        std::fs::create_dir_all(dir).ok();
    }
    let mut csv = String::from("seed,row,ln_b,std_err,ln_b_ref,std_err_ref\n");
    let t0 = std::time::Instant::now();
    for seed in a.first..a.first + a.seeds as u64 {
        let s = run(&study_text(&base, a.snr, seed, false));
        let r = run(&study_text(&base, a.snr, seed, true));
        let Some((ref_b, ref_se)) = row(&r, "RJMCMC bridge") else {
            eprintln!("seed {seed}: the reference run has no bridge estimate; skipped");
            continue;
        };
        let mut line = format!("seed {seed}: ref {ref_b:.4} ± {ref_se:.4}");
        for (k, name) in ROWS.iter().enumerate() {
            if let Some((b, se)) = row(&s, name) {
                diffs[k].push((b - ref_b, se.hypot(ref_se)));
                csv += &format!("{seed},{name},{b:e},{se:e},{ref_b:e},{ref_se:e}\n");
                line += &format!(" | {:+.2}σ", (b - ref_b) / se.hypot(ref_se));
            } else {
                line += " | –";
            }
        }
        eprintln!("{line}  ({:.0} s)", t0.elapsed().as_secs_f64());
        // after every seed, so that a long run stopped early keeps what it measured
        std::fs::write(&a.csv, &csv).expect("writing the CSV");
    }
    println!(
        "ρ_opt = {} on {} data seeds from {}; reference: a {REF_FACTOR}× longer reversible jump's bridge",
        a.snr, a.seeds, a.first
    );
    println!(
        "{:<27} {:>5} {:>16} {:>18} {:>7} {:>7}",
        "row", "runs", "scatter÷stated", "offset ± se", ">2σ", ">3σ"
    );
    for (k, name) in ROWS.iter().enumerate() {
        match calibrate(&diffs[k]) {
            Some(c) => println!(
                "{name:<27} {:>5} {:>16.3} {:>+9.4} ± {:<6.4} {:>7.3} {:>7.3}",
                c.n, c.ratio, c.offset, c.offset_se, c.beyond2, c.beyond3
            ),
            None => println!("{name:<27} fewer than two runs with a number"),
        }
    }
    println!("wrote {}", a.csv);
}
