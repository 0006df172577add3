//! Mutation test of the study loader (issue 10, deliverable 6): every example study and a few
//! hand-written ones, mutated deterministically (seeded), must load or be refused, never
//! panic; the studies that load go through the memory budget and the size computations too.
//!
//! Run with `cargo test --release --test mutate_study -- --nocapture` to see the counts.

use occam::config::{Study, budget};
use rand::{RngExt, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};

/// Cases per run in release builds (the CI configuration): 100 000.
const CASES: usize = 100_000;
/// Cases in unoptimised builds, where a case is ~20× slower: the same stream, cut short.
const CASES_DEBUG: usize = 10_000;
/// The RNG seed of the mutations (fixed: a failure is reproducible by its case number).
const SEED: u64 = 0x0cca_u64 << 32 | 10;

/// Numbers that break naive code: zeros, signs, extremes, non-finite, integer edges.
const EXTREMES: [&str; 17] = [
    "0",
    "-1",
    "1e300",
    "-1e300",
    "1e-300",
    "nan",
    "inf",
    "-inf",
    "9223372036854775807",
    "-9223372036854775808",
    "9223372036854775808",
    "18446744073709551615",
    "1e308",
    "0.0",
    "-0.0",
    "4294967296",
    "1e15",
];

/// Values of other types, to swap in for a number or a string.
const OTHER_TYPES: [&str; 8] = [
    "\"x\"",
    "true",
    "[1.0, 2.0, 3.0]",
    "[]",
    "{}",
    "{ kind = \"uniform\" }",
    "\"\"",
    "1979-05-27T07:32:00Z",
];

/// Hand-written seeds beside the examples: every table the loader knows.
const EXTRA_SEEDS: [&str; 3] = [
    r#"seed = 3
output = "o"
oms_delay = 0.1
[truth]
dt1 = 0.3
[noise]
readout_o1 = 1e-11
tm_corner = 1e-3
[simulation]
method = "time"
oversample = 4
noise = "realistic"
snr_band = [1e-3, 0.5]
target_snr = 50.0
[analysis]
band = [1e-3, 0.4]
welch_averages = 8
[fit]
free = ["a_df", "a_sus", "d21"]
fixed = { w1sq = -1.3e-6, w2sq = -1.9e-6, dt1 = 0.2, dt2 = 0.2 }
chains = 2
iterations = 3000
burn_in = 1000
thin = 2
checkpoint_every = 500
start = { a_df = 0.8 }
[[experiment]]
name = "a"
fs = 1.0
pre_pad = 200.0
post_pad = 1500.0
noise_duration = 8000.0
x1 = { kind = "sine_train", gap = 20.0, segments = [
  { freq = 0.002, amplitude = 1e-6, duration = 500.0 },
  { freq = 0.05, amplitude = 1e-7, duration = 200.0 } ] }
[[experiment]]
name = "b"
design = "tn3045_x12"
amplitude_scale = 0.5
"#,
    r#"seed = 4
output = "o"
[simulation.actuators]
tm1 = { gain = 1.1, pole = 1.963, delay = 0.01 }
[simulation.thruster]
response = "pole"
value = 3.0
[[model]]
kind = "ltp"
name = "pole"
thruster = "pole"
[[model]]
kind = "accel"
name = "acc"
delay = true
tau_ifo = 0.2
[[model]]
kind = "tied"
name = "sym"
of = "acc"
tie = { a2 = "a1" }
[prior]
f_df = { kind = "log_uniform", lo = 0.1, hi = 10.0 }
[select]
rj_iterations = 20000
rj_burn_in = 1000
pt_temperatures = 8
pt_iterations = 2000
pt_burn_in = 500
[[select.model]]
name = "X"
model = "pole"
[[select.model]]
name = "Y"
free = ["w1sq", "w2sq", "a_df", "a_sus", "d21"]
fixed = { dt1 = 0.2, dt2 = 0.2 }
prior_probability = 2.0
[sweep]
realisations = 2
truth = "X"
[[sweep.axis]]
key = "simulation.thruster.value"
from = 1.0
to = 10.0
points = 4
[[experiment]]
name = "inv1"
design = "tn3045_x1"
f1 = { kind = "sine", freq = 0.01, amplitude = 1e-9, duration = 1000.0 }
"#,
    r#"seed = 5
output = "o"
[design]
true_model = "X"
candidates = { from = 1e-3, to = 0.1, points = 12 }
segments = 5
segment_duration = 900.0
[[select.model]]
name = "X"
[[select.model]]
name = "Y"
free = ["w1sq", "w2sq", "a_df", "a_sus", "d21"]
fixed = { dt1 = 0.2, dt2 = 0.2 }
[[experiment]]
name = "inv1"
design = "tn3045_x1"
"#,
];

/// Byte ranges of the number tokens of `s` (digits with sign, dot, exponent; `nan`, `inf`).
fn numbers(s: &str) -> Vec<(usize, usize)> {
    let b = s.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let starts = b[i].is_ascii_digit()
            || ((b[i] == b'-' || b[i] == b'+') && i + 1 < b.len() && b[i + 1].is_ascii_digit());
        let word_before = i > 0 && (b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_');
        if starts && !word_before {
            let mut j = i + 1;
            while j < b.len()
                && (b[j].is_ascii_digit()
                    || b[j] == b'.'
                    || b[j] == b'e'
                    || b[j] == b'E'
                    || b[j] == b'_'
                    || ((b[j] == b'-' || b[j] == b'+') && (b[j - 1] == b'e' || b[j - 1] == b'E')))
            {
                j += 1;
            }
            out.push((i, j));
            i = j;
        } else {
            i += 1;
        }
    }
    out
}

/// Byte ranges of the keys (`key =` at the start of a line or after `{`/`,`).
fn keys(s: &str) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let b = s.as_bytes();
    for (i, _) in s.match_indices(" =") {
        let mut j = i;
        while j > 0 && (b[j - 1].is_ascii_alphanumeric() || b[j - 1] == b'_') {
            j -= 1;
        }
        if j < i {
            out.push((j, i));
        }
    }
    out
}

fn pick<'a, T>(rng: &mut Xoshiro256PlusPlus, v: &'a [T]) -> Option<&'a T> {
    if v.is_empty() {
        None
    } else {
        Some(&v[rng.random_range(0..v.len())])
    }
}

/// The largest char boundary ≤ `i`.
fn floor_boundary(s: &str, mut i: usize) -> usize {
    i = i.min(s.len());
    while !s.is_char_boundary(i) {
        i -= 1;
    }
    i
}

/// One mutation of `s`.
fn mutate(s: &str, rng: &mut Xoshiro256PlusPlus) -> String {
    let lines: Vec<&str> = s.lines().collect();
    match rng.random_range(0..10u32) {
        // a number → an extreme value (the most common mutation: it is what finds sizes)
        0..=2 => match pick(rng, &numbers(s)) {
            Some(&(a, b)) => format!("{}{}{}", &s[..a], pick(rng, &EXTREMES).unwrap(), &s[b..]),
            None => s.to_string(),
        },
        // a number or a string → another type
        3 => {
            let mut spans = numbers(s);
            spans.extend(
                s.match_indices('"')
                    .collect::<Vec<_>>()
                    .chunks(2)
                    .filter(|c| c.len() == 2)
                    .map(|c| (c[0].0, c[1].0 + 1)),
            );
            match pick(rng, &spans) {
                Some(&(a, b)) => {
                    format!("{}{}{}", &s[..a], pick(rng, &OTHER_TYPES).unwrap(), &s[b..])
                }
                None => s.to_string(),
            }
        }
        // delete a line
        4 => {
            let k = rng.random_range(0..lines.len().max(1));
            lines
                .iter()
                .enumerate()
                .filter(|(i, _)| *i != k)
                .map(|(_, l)| *l)
                .collect::<Vec<_>>()
                .join("\n")
        }
        // duplicate a line
        5 => {
            let k = rng.random_range(0..lines.len().max(1));
            let mut v = lines.clone();
            if let Some(l) = lines.get(k) {
                v.insert(k, l);
            }
            v.join("\n")
        }
        // swap two lines
        6 => {
            let mut v = lines.clone();
            if v.len() > 1 {
                let a = rng.random_range(0..v.len());
                let b = rng.random_range(0..v.len());
                v.swap(a, b);
            }
            v.join("\n")
        }
        // one key → another key of the file
        7 => {
            let ks = keys(s);
            match (pick(rng, &ks), pick(rng, &ks)) {
                (Some(&(a, b)), Some(&(c, d))) => {
                    format!("{}{}{}", &s[..a], &s[c..d], &s[b..])
                }
                _ => s.to_string(),
            }
        }
        // truncate
        8 => s[..floor_boundary(s, rng.random_range(0..=s.len()))].to_string(),
        // insert random bytes (as chars: the loader takes &str)
        _ => {
            let at = floor_boundary(s, rng.random_range(0..=s.len()));
            let n = rng.random_range(1..6);
            let junk: String = (0..n)
                .map(|_| match rng.random_range(0..4u32) {
                    0 => char::from(rng.random_range(0u8..128)),
                    1 => {
                        ['[', ']', '{', '}', '=', '"', '\n', '.', ',', '#'][rng.random_range(0..10)]
                    }
                    2 => char::from_u32(rng.random_range(0x80u32..0x2_0000)).unwrap_or('é'),
                    _ => char::from(rng.random_range(b'0'..=b'9')),
                })
                .collect();
            format!("{}{junk}{}", &s[..at], &s[at..])
        }
    }
}

/// What the commands compute from a loaded study before any big allocation.
fn sizes(study: &Study) {
    let _ = budget::check_study(study, budget::DEFAULT_BUDGET);
    let e = budget::estimate(study);
    assert!(!e.simulate.is_nan() || study.experiments.is_empty());
    for d in &study.experiments {
        let _ = (d.n_samples(), d.n_noise_samples(), d.n_samples_f64());
        for w in [&d.x1, &d.x12, &d.f1, &d.f2, &d.fsc] {
            let _ = w.len(d.fs);
        }
    }
    if let Some(o) = &study.design {
        let _ = o.validate(study);
    }
}

#[test]
fn mutated_studies_never_panic() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("examples");
    let mut seeds: Vec<(String, String)> = std::fs::read_dir(&dir)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .map(|p| {
            (
                p.file_name().unwrap().to_string_lossy().into_owned(),
                std::fs::read_to_string(&p).unwrap(),
            )
        })
        .collect();
    seeds.sort();
    assert!(seeds.len() >= 10, "{} example studies", seeds.len());
    for (i, s) in EXTRA_SEEDS.iter().enumerate() {
        seeds.push((format!("extra-{i}"), s.to_string()));
    }
    // every seed loads unmutated (else the mutations test nothing)
    for (name, text) in &seeds {
        if let Err(e) = Study::from_toml(text, name, &dir) {
            panic!("seed {name} does not load: {e}");
        }
    }
    let cases = if cfg!(debug_assertions) {
        CASES_DEBUG
    } else {
        CASES
    };
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(SEED);
    let (mut ok, mut err, mut panics) = (0usize, 0usize, Vec::new());
    let t0 = std::time::Instant::now();
    for case in 0..cases {
        let (name, text) = &seeds[case % seeds.len()];
        let mut t = text.clone();
        for _ in 0..rng.random_range(1..=3) {
            t = mutate(&t, &mut rng);
        }
        let r = catch_unwind(AssertUnwindSafe(|| {
            match Study::from_toml(&t, "m.toml", Path::new(&dir)) {
                Ok(s) => {
                    sizes(&s);
                    true
                }
                Err(e) => {
                    // every refusal names the file
                    assert!(e.to_string().contains("m.toml"), "{e}");
                    false
                }
            }
        }));
        match r {
            Ok(true) => ok += 1,
            Ok(false) => err += 1,
            Err(p) => {
                let msg = p
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default();
                panics.push(format!("case {case} (from {name}): {msg}\n---\n{t}\n---"));
            }
        }
    }
    std::panic::set_hook(hook);
    let secs = t0.elapsed().as_secs_f64();
    println!(
        "mutate_study: {cases} cases from {} seeds in {secs:.1} s: {ok} Ok, {err} Err, {} panics",
        seeds.len(),
        panics.len()
    );
    assert!(ok > cases / 100 && err > cases / 10, "{ok} Ok, {err} Err");
    assert!(
        panics.is_empty(),
        "{} panics; the first:\n{}",
        panics.len(),
        panics
            .iter()
            .take(3)
            .cloned()
            .collect::<Vec<_>>()
            .join("\n")
    );
}
