//! Helpers shared by the command-line tests.

use std::path::Path;
use std::process::Command;

#[allow(dead_code)] // not every test binary that shares this module runs the binary
/// Runs the `occam` binary in `cwd`: (success, stdout, stderr). Every `error:` and
/// `warning:` line it prints is held to [`readable`], so the whole suite scans every message
/// it provokes.
pub fn occam(args: &[&str], cwd: &Path) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_occam"))
        .args(args)
        .current_dir(cwd)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    for line in err.lines() {
        if (line.starts_with("error:") || line.starts_with("warning:"))
            && let Err(why) = readable(line)
        {
            panic!("occam {args:?}: {why}: {line}");
        }
    }
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        err,
    )
}

/// Rust's debug formatting that must never reach a person (issue 51).
const DEBUG_FORMS: [&str; 6] = ["Some(", "None,", "Error {", "kind:", "Semantic(", "Io("];

/// `Ok` when `msg` holds none of [`DEBUG_FORMS`] and no cause twice (a `: `-separated part
/// of 24 or more characters that appears again in the message).
#[allow(dead_code)]
pub fn readable(msg: &str) -> Result<(), String> {
    if let Some(d) = DEBUG_FORMS.iter().find(|d| msg.contains(*d)) {
        return Err(format!("Rust debug formatting `{d}`"));
    }
    for part in msg.split(": ") {
        let part = part.trim();
        if part.chars().count() >= 24 && msg.matches(part).count() > 1 {
            return Err(format!("a cause said twice: `{part}`"));
        }
    }
    Ok(())
}

/// Two small experiments at 1 Hz (guidance sines on x1 and x12, long noise-only stretches):
/// the `[[experiment]]` tables of the command-line tests' studies.
#[allow(dead_code)] // not every test binary that shares this module uses it
pub const TWO_EXPERIMENTS: &str = r#"
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
fs = 1.0
pre_pad = 200.0
post_pad = 1500.0
noise_duration = 8000.0
x12 = { kind = "sine", freq = 0.002, amplitude = 1e-6, duration = 500.0 }
"#;

/// A small two-model select study (with a `[fit]`) on [`TWO_EXPERIMENTS`].
#[allow(dead_code)]
pub fn small() -> String {
    format!(
        "{}{}",
        r#"
seed = 8
output = "out"
[analysis]
band = [1e-3, 0.4]
[fit]
free = ["a_df", "a_sus", "d21"]
fixed = { w1sq = -1.3e-6, w2sq = -1.9e-6, dt1 = 0.2, dt2 = 0.2 }
chains = 2
iterations = 2000
burn_in = 500
[select]
rj_iterations = 6000
rj_burn_in = 500
iterations = 2000
burn_in = 500
pt_temperatures = 6
pt_iterations = 1500
pt_burn_in = 300
[[select.model]]
name = "X"
free = ["a_df", "a_sus", "d21"]
fixed = { w1sq = -1.3e-6, w2sq = -1.9e-6, dt1 = 0.2, dt2 = 0.2 }
[[select.model]]
name = "Y"
free = ["a_df", "a_sus"]
fixed = { w1sq = -1.3e-6, w2sq = -1.9e-6, dt1 = 0.2, dt2 = 0.2, d21 = 0.0 }
"#,
        TWO_EXPERIMENTS
    )
}

/// Writes a CSV file: a time column `k / fs` under `header[0]`, then one column per series.
#[allow(dead_code)]
pub fn write_csv(path: &Path, header: &[&str], cols: &[&[f64]], fs: f64) {
    use std::fmt::Write as _;
    let mut s = header.join(",") + "\n";
    for k in 0..cols[0].len() {
        write!(s, "{:.17e}", k as f64 / fs).unwrap();
        for c in cols {
            write!(s, ",{:.17e}", c[k]).unwrap();
        }
        s.push('\n');
    }
    std::fs::write(path, s).unwrap();
}

#[allow(dead_code)]
/// The summary's numbers: its JSON with every timing field removed.
pub fn numbers(v: serde_json::Value) -> serde_json::Value {
    use serde_json::Value;
    match v {
        Value::Object(m) => Value::Object(
            m.into_iter()
                .filter(|(k, _)| !(k.starts_with("seconds") || k.ends_with("per_second")))
                .map(|(k, x)| (k, numbers(x)))
                .collect(),
        ),
        Value::Array(a) => Value::Array(a.into_iter().map(numbers).collect()),
        x => x,
    }
}

#[allow(dead_code)]
/// A run directory's `summary.json` without its timing fields.
pub fn summary_numbers(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("summary.json")).unwrap();
    numbers(serde_json::from_str(&text).unwrap())
}

#[allow(dead_code)] // used by the coverage tests only
/// Per free parameter of the fit model (in the order of `free`), the MAP's pull
/// `(MAP − truth)/σ` by the sandwich error `√(F⁻¹JF⁻¹)` and by the Fisher (Cramér–Rao) error.
/// The MAP is found by Fisher scoring from the prior centre, as `occam fit` starts, and must
/// converge inside the prior box.
pub fn map_pulls(
    s: &occam::config::Study,
    lik: &occam::likelihood::Likelihood,
    truth: &[f64],
    free: &[usize],
) -> Vec<(f64, f64)> {
    use occam::jobs::prepare::default_start;
    use occam::likelihood::{
        cramer_rao, fisher_exact, fisher_scoring, sandwich_errors, score_covariance,
    };
    let map = fisher_scoring(lik, &default_start(s, &s.fit_model), free, 1e-3, 200).unwrap();
    assert!(
        map.converged && !map.at_bound.iter().any(|b| *b),
        "seed {}",
        s.seed
    );
    let f = fisher_exact(lik, &map.theta, free);
    let cr = cramer_rao(&f).unwrap();
    let sw = sandwich_errors(&f, &score_covariance(lik, &map.theta, free)).unwrap();
    free.iter()
        .enumerate()
        .map(|(k, &i)| {
            let d = map.theta[i] - truth[i];
            (d / sw[k], d / cr[k])
        })
        .collect()
}
