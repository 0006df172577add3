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
