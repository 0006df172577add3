//! The memory budget: every size a study implies, computed from the study alone before
//! anything big is allocated, and checked against a budget.
//!
//! The budget is [`DEFAULT_BUDGET`] (8 GiB) unless the environment variable
//! `OCCAM_MEMORY_BUDGET` says otherwise (`16GiB`, `500MB`, `2e9`; see [`parse_size`]).
//! [`crate::config::StudyFile::resolve`] checks it, so every command that reads a study
//! (`simulate`, `fit`, `select`, `sweep` for each of its point studies, `design`) is covered;
//! sizes are computed in `f64`, so `pre_pad = 1e308` gives an infinite size, not a wrapped
//! integer.
//!
//! # Model of the memory (bytes)
//! Per simulated experiment with `n` fit samples (`fs × (pre_pad + injection + post_pad)`,
//! gaps included) and `m` noise-only samples (`fs × noise_duration`):
//! * series and their spectra: `24 (C n + 5 m)`, with `C` = 7 fit-stretch channels (`o1`,
//!   `o12`, the injections `i1`, `i12`, the telemetry `g1`, `g2`, `gsc`) plus 3 when it injects
//!   forces; 5 noise-only channels; 8 B per real sample, the same again for the half-length
//!   complex DFT of each and again for work copies. Measured: `occam simulate
//!   examples/tn3045.toml` (two experiments, n ≈ 1.9e5, m = 2e5) peaks at 104 MiB above the
//!   program's own 8 MiB; this model gives 107 MiB;
//! * `noise = "realistic"`: the noise is synthesised on a 4× longer grid, `2 × 4 × 16 (n + m)`;
//! * `method = "time"`: the loop runs at `oversample × fs`, four series and the up-sampled
//!   injections and their spectra, `64 × oversample × n`.
//!
//! Experiments read from files (`data = …`) are sized by their readers, not here.
//!
//! The samplers add to the data (8 B per stored number, `D` free parameters):
//! * `fit`: `chains × iterations / thin × (D + 2)` (samples, `ln L`, `ln π`);
//! * `select`: per model, `chains × iterations × (D + 2)` for the Metropolis–Hastings runs and
//!   `pt_temperatures × pt_iterations × (D + 2)` for parallel tempering, plus the
//!   reversible-jump draws `rj_iterations × (P + 2)` (`P`: the union of the models' parameters);
//! * `sweep`: each point's study is checked as a `select` (the check runs on every point study
//!   when the sweep is planned), plus [`SWEEP_RECORD_BYTES`] per task;
//! * `design`: each candidate design is a simulated study with `channels` experiments of
//!   `segments × (segment_duration + gap)` at 10 Hz plus the default pads and noise stretch.
//!
//! The model is deliberately generous (it counts every array that may be alive at once): its
//! job is to refuse inputs that cannot fit, with a message naming the field, not to predict the
//! peak to the byte.

use super::error::ConfigError;
pub use super::limits::MAX_NAME_LEN;
use super::study::{SimulationOptions, Study};
pub use crate::data::memory::{BUDGET_ENV, DEFAULT_BUDGET, GIB, budget_from_env, parse_size};
use crate::experiment::ExperimentDesign;
use crate::experiment::options::{Method, NoiseSynthesis};

/// Most iterations (`fit.iterations`, `select.iterations`, `select.rj_iterations`,
/// `select.pt_iterations`) a study may ask for: 10⁹. One iteration costs at least a
/// microsecond (a likelihood evaluation), so 10⁹ is already a quarter of an hour per chain at
/// best and days for real likelihoods; beyond it a run is a hang, not a study. It also keeps
/// every product of counts (× 4096 chains × 200 rungs) far inside `u64`.
pub const MAX_ITERATIONS: usize = 1_000_000_000;

/// Most chains of `fit.chains` and `select.chains` (as `select.rj_chains`): 4096. The chains
/// run on the thread pool; more chains than that are not a sampler setting but a typo.
pub const MAX_CHAINS: usize = 4096;

/// Largest `[fit] map_starts`: each start is a full MAP search of every model.
pub const MAX_MAP_STARTS: usize = 64;

/// Bytes per sweep task record kept in memory (identity, outcome, error text).
pub const SWEEP_RECORD_BYTES: f64 = 4096.0;

/// A stretch this long (s, 11.6 days) or shorter is not what to shorten when the sample rate
/// is above [`MODEST_FS`]: the message then names `fs`.
const MODEST_DURATION: f64 = 1e6;
/// LISA Pathfinder's data are at 10 Hz; a rate above 1 kHz is what to lower first.
const MODEST_FS: f64 = 1e3;

/// Bytes per sample and channel of a stretch: the series, its spectrum, a work copy.
const BYTES_PER_SAMPLE: f64 = 24.0;

/// Sample rate of the experiments built by `occam design` (Hz).
const DESIGN_FS: f64 = 10.0;

/// A byte count in short binary units, e.g. `7.5 GiB`, `3.2e5 TiB` for absurd ones.
pub fn human_bytes(b: f64) -> String {
    if !b.is_finite() {
        return "an infinite number of bytes".into();
    }
    let units = ["B", "KiB", "MiB", "GiB", "TiB"];
    let mut v = b;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < units.len() {
        v /= 1024.0;
        u += 1;
    }
    if v >= 1e4 {
        format!("{v:.1e} {}", units[u])
    } else if v >= 100.0 || u == 0 {
        format!("{v:.0} {}", units[u])
    } else {
        format!("{v:.1} {}", units[u])
    }
}

/// The size of one simulated experiment.
#[derive(Debug, Clone, PartialEq)]
pub struct ExperimentSize {
    /// Fit-stretch samples `n`.
    pub fit_samples: f64,
    /// Noise-only samples `m`.
    pub noise_samples: f64,
    /// Fit-stretch channels `C`.
    pub channels: f64,
    /// Bytes by the model of the module docs.
    pub bytes: f64,
    /// The field (relative to `experiment[k].` or absolute when it starts with `simulation.`)
    /// that drives the size, and its part of the bytes.
    pub driver: String,
}

/// The size of experiment `d` under the simulation options `sim` (see the module docs).
pub fn experiment_size(d: &ExperimentDesign, sim: &SimulationOptions) -> ExperimentSize {
    let n = d.n_samples_f64();
    let m = d.n_noise_samples_f64();
    // a model simulation's named injections add their own series and, at most, as many read-outs
    let c = if d.has_forces() { 10.0 } else { 7.0 } + 2.0 * d.inject.len() as f64;
    let series = BYTES_PER_SAMPLE * (c * n + 5.0 * m);
    let realistic = if sim.noise == NoiseSynthesis::Realistic {
        2.0 * 4.0 * 16.0 * (n + m)
    } else {
        0.0
    };
    let time = if sim.method == Method::Time {
        64.0 * sim.oversample as f64 * n
    } else {
        0.0
    };
    let bytes = series + realistic + time;
    // which field to shorten: the biggest of the stretches, unless a simulation option
    // multiplies the size more than the stretches do
    let fs = d.fs;
    let pad = |t: f64| (t * fs).round().max(0.0);
    let mut parts: Vec<(String, f64)> = vec![
        ("pre_pad".into(), pad(d.pre_pad)),
        ("post_pad".into(), pad(d.post_pad)),
        ("noise_duration".into(), m),
    ];
    for (ch, w) in d.waveforms() {
        parts.push((ch, w.len_f64(fs)));
    }
    let (mut driver, big) =
        parts
            .into_iter()
            .fold((String::from("fs"), -1.0), |(bn, bv), (n, v)| {
                if v > bv || v.is_nan() {
                    (n, v)
                } else {
                    (bn, bv)
                }
            });
    if time > series + realistic {
        driver = "simulation.oversample".into();
    } else if realistic > series {
        driver = "simulation.noise".into();
    } else if !(big / fs <= MODEST_DURATION) || !fs.is_finite() {
        // the stretch is long in seconds: shorten it
    } else if fs > MODEST_FS {
        // every stretch is modest in seconds: the sample rate blows them up
        driver = "fs".into();
    }
    ExperimentSize {
        fit_samples: n,
        noise_samples: m,
        channels: c,
        bytes,
        driver,
    }
}

/// A study's memory per command (bytes), by the model of the module docs.
#[derive(Debug, Clone, PartialEq)]
pub struct MemoryEstimate {
    /// `simulate`: every simulated experiment.
    pub simulate: f64,
    /// `fit`: the data and the chains.
    pub fit: f64,
    /// `select` (and each sweep task): the data and every sampler's stored draws.
    pub select: f64,
    /// `sweep`: one task plus the task records.
    pub sweep: f64,
    /// `design`: one candidate design's simulation (0 without `[design]`).
    pub design: f64,
}

/// The memory each command of `study` needs (see the module docs).
pub fn estimate(study: &Study) -> MemoryEstimate {
    let data: f64 = study
        .experiments
        .iter()
        .map(|d| experiment_size(d, &study.simulation).bytes)
        .sum();
    let stored = |chains: f64, iters: f64, d: usize| chains * iters * (d as f64 + 2.0) * 8.0;
    let f = &study.fit;
    let fit = data
        + stored(
            f.chains as f64,
            f.iterations as f64 / f.thin.max(1) as f64,
            study.fit_model.free.len(),
        );
    let s = &study.select;
    let mut select = data;
    let mut d_max = 0;
    for m in &study.select_models {
        let d = m.spec.free.len();
        d_max = d_max.max(d);
        select += stored(s.chains as f64, s.iterations as f64, d);
        let (rungs, sweeps, _) = s.tempering_ladder();
        if rungs > 0 {
            select += stored(rungs as f64, sweeps as f64, d);
        }
    }
    if !study.select_models.is_empty() {
        // the jump chain's kept draws (`rj_chain.npz`): a row over the union of the models'
        // parameter names, plus the model index and ln L
        let mut union: Vec<&str> = Vec::new();
        let mut unnamed = 0;
        for m in &study.select_models {
            let names = study
                .models
                .models
                .get(m.spec.model)
                .map(|x| x.param_names());
            for &i in &m.spec.free {
                match names.and_then(|n| n.get(i)) {
                    Some(n) if !union.contains(&n.as_str()) => union.push(n),
                    Some(_) => {}
                    None => unnamed += 1,
                }
            }
        }
        let width = (union.len() + unnamed).max(d_max);
        select += stored(1.0, rj_longest(s) as f64, width);
    }
    let tasks = study.sweep.as_ref().map_or(0.0, |sw| {
        let points: f64 = sw
            .axis
            .iter()
            .map(|a| {
                a.values
                    .as_ref()
                    .map_or(a.points.unwrap_or(1) as f64, |v| v.len() as f64)
            })
            .product();
        points * sw.realisations as f64
    });
    let sweep = select + tasks * SWEEP_RECORD_BYTES;
    let design = study.design.as_ref().map_or(0.0, |o| {
        let n = DESIGN_FS * (2000.0 + o.segments as f64 * (o.segment_duration + o.gap) + 8000.0);
        let m = DESIGN_FS * 20000.0;
        let one = BYTES_PER_SAMPLE * (7.0 * n + 5.0 * m)
            + if study.simulation.noise == NoiseSynthesis::Realistic {
                128.0 * (n + m)
            } else {
                0.0
            };
        one * o.channels.len() as f64
    });
    MemoryEstimate {
        simulate: data,
        fit,
        select,
        sweep,
        design,
    }
}

/// The longest reversible jump a select run may make: `rj_iterations`, or with a
/// `target_error` its budget.
fn rj_longest(s: &super::study::SelectOptions) -> usize {
    match s.target_error {
        Some(_) => s.rj_budget(),
        None => s.rj_iterations,
    }
}

fn over(bytes: f64, budget: f64) -> bool {
    !(bytes <= budget)
}

fn tail(bytes: f64, budget: f64) -> String {
    format!(
        "{} ({bytes:.1e} B), above the {} memory budget (set {BUDGET_ENV}, e.g. \"16GiB\", to change it)",
        human_bytes(bytes),
        human_bytes(budget)
    )
}

/// Checks one experiment (`experiment[k]` of `file`) against the budget; `data_so_far` is the
/// bytes of the experiments before it. Returns the experiment's bytes.
pub fn check_experiment(
    d: &ExperimentDesign,
    k: usize,
    sim: &SimulationOptions,
    data_so_far: f64,
    budget: f64,
    file: &str,
) -> Result<f64, ConfigError> {
    let s = experiment_size(d, sim);
    let total = data_so_far + s.bytes;
    if over(total, budget) {
        let field = if s.driver.starts_with("simulation.") {
            s.driver.clone()
        } else {
            format!("experiment[{k}].{}", s.driver)
        };
        let what = match s.driver.as_str() {
            "pre_pad" => format!("pre_pad = {} s", d.pre_pad),
            "post_pad" => format!("post_pad = {} s", d.post_pad),
            "noise_duration" => format!("noise_duration = {} s", d.noise_duration),
            "simulation.oversample" => format!("oversample = {}", sim.oversample),
            "simulation.noise" => "noise = \"realistic\" (a 4× longer synthesis grid)".into(),
            "fs" => format!("fs = {} Hz", d.fs),
            ch => format!("the `{ch}` injection"),
        };
        let others = if data_so_far > 0.0 {
            format!(" (with the experiments before it: {})", human_bytes(total))
        } else {
            String::new()
        };
        return Err(ConfigError::Invalid {
            file: file.into(),
            field,
            msg: format!(
                "experiment `{}`: {what} at fs = {} Hz makes {:.2e} fit samples and {:.2e} noise-only samples × {} channels, their spectra and work arrays: {}{others}; shorten it or lower fs",
                d.name,
                d.fs,
                s.fit_samples,
                s.noise_samples,
                s.channels,
                tail(s.bytes, budget)
            ),
        });
    }
    Ok(s.bytes)
}

/// Checks every command's memory of a resolved study against `budget` bytes; the error names
/// the field that drives the biggest part. [`crate::config::StudyFile::resolve`] calls this
/// with [`budget_from_env`]; call it again on a study changed after resolution.
pub fn check_study(study: &Study, budget: f64) -> Result<MemoryEstimate, ConfigError> {
    let file = study.source.as_str();
    let mut so_far = 0.0;
    let sim_index: Vec<usize> = study
        .experiment_names
        .iter()
        .enumerate()
        .filter(|(_, n)| study.experiments.iter().any(|d| &d.name == *n))
        .map(|(i, _)| i)
        .collect();
    for (j, d) in study.experiments.iter().enumerate() {
        let k = sim_index.get(j).copied().unwrap_or(j);
        so_far += check_experiment(d, k, &study.simulation, so_far, budget, file)?;
    }
    let e = estimate(study);
    let bad = |field: &str, msg: String| ConfigError::Invalid {
        file: file.into(),
        field: field.into(),
        msg,
    };
    if over(e.fit, budget) {
        let f = &study.fit;
        let field = if f.chains > f.iterations / f.thin.max(1) {
            "fit.chains"
        } else {
            "fit.iterations"
        };
        return Err(bad(
            field,
            format!(
                "{} chains × {} iterations / thin {} × {} stored numbers each, with the data: {}; lower it or raise `fit.thin`",
                f.chains,
                f.iterations,
                f.thin,
                study.fit_model.free.len() + 2,
                tail(e.fit, budget)
            ),
        ));
    }
    if over(e.select, budget) {
        let s = &study.select;
        let d = study
            .select_models
            .iter()
            .map(|m| m.spec.free.len() as f64 + 2.0)
            .fold(0.0, f64::max);
        let k = study.select_models.len() as f64;
        let parts = [
            (
                "select.iterations",
                k * s.chains as f64 * s.iterations as f64,
            ),
            (
                "select.pt_iterations",
                match s.tempering_ladder() {
                    (0, _, _) => 0.0,
                    (rungs, sweeps, _) => k * rungs as f64 * sweeps as f64,
                },
            ),
            (
                if s.target_error.is_some() {
                    "select.rj_max_iterations"
                } else {
                    "select.rj_iterations"
                },
                rj_longest(s) as f64,
            ),
        ];
        let (field, _) = parts
            .iter()
            .fold(("select.iterations", -1.0), |(bf, bv), &(f, v)| {
                if v > bv { (f, v) } else { (bf, bv) }
            });
        return Err(bad(
            field,
            format!(
                "{} models × (chains {} × iterations {} + rungs {} × pt_iterations {}) + reversible-jump iterations {}, up to {d} stored numbers each, with the data: {}; lower it",
                k,
                s.chains,
                s.iterations,
                s.tempering_ladder().0,
                s.tempering_ladder().1,
                rj_longest(s),
                tail(e.select, budget)
            ),
        ));
    }
    if over(e.sweep, budget) {
        return Err(bad(
            "sweep.realisations",
            format!(
                "the sweep's tasks and one task's model selection: {}; split the sweep",
                tail(e.sweep, budget)
            ),
        ));
    }
    if over(e.design, budget) {
        return Err(bad(
            "design.segment_duration",
            format!(
                "each candidate design simulates its channels' segments at {DESIGN_FS} Hz: {}; shorten the segments or use fewer",
                tail(e.design, budget)
            ),
        ));
    }
    Ok(e)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn load(extra: &str) -> Result<Study, ConfigError> {
        Study::from_toml(
            &format!("seed = 1\noutput = \"o\"\n{extra}"),
            "s.toml",
            std::path::Path::new("."),
        )
    }

    #[test]
    fn sizes_parse_with_units() {
        let g = GIB;
        for (s, v) in [
            ("16GiB", 16.0 * g),
            ("16 gib", 16.0 * g),
            ("16G", 16.0 * g),
            ("1.5TiB", 1.5 * 1024.0 * g),
            ("500MB", 5e8),
            ("2e9", 2e9),
            ("2E9 B", 2e9),
            ("64k", 65536.0),
            ("3kB", 3000.0),
        ] {
            assert_eq!(parse_size(s).unwrap(), v, "{s}");
        }
        for s in ["", "GiB", "lots", "-1GiB", "0", "1e400", "nan", "5 parsecs"] {
            assert!(parse_size(s).is_err(), "{s}");
        }
        assert_eq!(human_bytes(8.0 * g), "8.0 GiB");
        assert_eq!(human_bytes(512.0), "512 B");
        assert_eq!(human_bytes(1e30), "9.1e17 TiB");
    }

    /// The TN3045 experiment by hand: n = 20000 + 7·12001 + 6·1200 + 80000, m = 200000.
    #[test]
    fn experiment_size_by_hand() {
        let d = ExperimentDesign::tn3045_x1();
        let sim = SimulationOptions::default();
        let s = experiment_size(&d, &sim);
        let n = (20000 + 7 * 12001 + 6 * 1200 + 80000) as f64;
        assert_eq!(s.fit_samples, n);
        assert_eq!(s.noise_samples, 200_000.0);
        assert_eq!(s.bytes, 24.0 * (7.0 * n + 5.0 * 200_000.0));
        assert_eq!(s.driver, "noise_duration");
        let time = SimulationOptions {
            method: Method::Time,
            oversample: 1000,
            ..sim.clone()
        };
        let t = experiment_size(&d, &time);
        assert_eq!(t.bytes, s.bytes + 64.0 * 1000.0 * n);
        assert_eq!(t.driver, "simulation.oversample");
        let real = SimulationOptions {
            noise: NoiseSynthesis::Realistic,
            ..sim
        };
        assert_eq!(
            experiment_size(&d, &real).bytes,
            s.bytes + 128.0 * (n + 200_000.0)
        );
    }

    #[test]
    fn huge_inputs_are_refused_naming_the_field() {
        let exp = "[[experiment]]\nname = \"a\"\ndesign = \"tn3045_x1\"\n";
        for (extra, field) in [
            ("noise_duration = 1e12\n", "experiment[0].noise_duration"),
            ("pre_pad = 1e308\n", "experiment[0].pre_pad"),
            ("post_pad = 1e300\n", "experiment[0].post_pad"),
            ("fs = 1e300\n", "experiment[0].fs"),
            ("fs = 1e9\n", "experiment[0].fs"),
        ] {
            let e = load(&format!("{exp}{extra}")).unwrap_err().to_string();
            assert!(
                e.contains("s.toml") && e.contains(field) && e.contains("memory budget"),
                "{extra}: {e}"
            );
        }
        let e = load(&format!(
            "[simulation]\nmethod = \"time\"\noversample = 1000\n{exp}"
        ))
        .unwrap_err()
        .to_string();
        assert!(e.contains("`simulation.oversample`"), "{e}");
        let e = load(&format!(
            "[fit]\nchains = 4096\niterations = 1000000000\nburn_in = 1\n{exp}"
        ))
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("`fit.iterations`") && e.contains("budget"),
            "{e}"
        );
        // without [[select.model]] nothing is stored for select: 1e9 RJ iterations load
        assert!(load(&format!("[select]\nrj_iterations = 1000000000\n{exp}")).is_ok());
        let two = "[[select.model]]\nname = \"X\"\n[[select.model]]\nname = \"Y\"\nfree = [\"w1sq\", \"w2sq\", \"a_df\", \"a_sus\", \"d21\"]\nfixed = { dt1 = 0.2, dt2 = 0.2 }\n";
        let e = load(&format!("[select]\nrj_iterations = 1000000000\n{two}{exp}"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("`select.rj_iterations`"), "{e}");
    }

    #[test]
    fn a_resolved_study_fits_and_a_small_budget_refuses_it() {
        let s = load("[[experiment]]\nname = \"a\"\ndesign = \"tn3045_x1\"\n").unwrap();
        let e = check_study(&s, DEFAULT_BUDGET).unwrap();
        assert!(e.simulate > 1e7 && e.simulate < 1e8, "{e:?}");
        assert!(e.fit > e.simulate && e.design == 0.0);
        let err = check_study(&s, 1e6).unwrap_err().to_string();
        assert!(err.contains("experiment[0].noise_duration"), "{err}");
        let err = check_study(&s, e.simulate + 1.0).unwrap_err().to_string();
        assert!(err.contains("`fit.iterations`"), "{err}");
    }
}
