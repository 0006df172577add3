//! Helpers shared by the command-line tests.

use std::path::Path;
use std::process::Command;

/// Runs the `occam` binary in `cwd`: (success, stdout, stderr).
pub fn occam(args: &[&str], cwd: &Path) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_occam"))
        .args(args)
        .current_dir(cwd)
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
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
