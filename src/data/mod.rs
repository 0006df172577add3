//! Users' own data: where an experiment's time series come from when they are read rather
//! than simulated ([`DataSource`]), and the checks shared by every reader (a uniformly sampled
//! time column, [`uniform_rate`]).
//!
//! The on-disk dataset format written by `occam simulate` lives in [`crate::data::dataset`].

pub mod checkpoint;
pub mod dataset;
pub mod memory;
pub mod npz;
pub mod npz_write;
pub mod rundir;
pub mod source;

pub use source::DataSource;

/// The memory budget for data read from files, in bytes: the one budget of the study loader
/// ([`memory::budget_from_env`]: `OCCAM_MEMORY_BUDGET`, else 8 GiB). Readers
/// compare the sizes a file implies with it before allocating anything, so that a damaged or
/// enormous file is an error naming the file rather than an abort. An unreadable value is an
/// error naming the variable (never silently the default).
pub fn memory_budget() -> Result<u64, String> {
    // saturating: a budget above 2⁶⁴ bytes is no limit
    memory::budget_from_env().map(|b| b as u64)
}

/// [`memory_budget`], or the default budget when the variable cannot be read (for callers
/// that have already reported that error through [`check_budget`]).
pub fn memory_budget_bytes() -> u64 {
    memory_budget().unwrap_or(memory::DEFAULT_BUDGET as u64)
}

/// Checks that reading `what` of `file`, which needs `bytes` bytes, fits the memory budget.
pub(crate) fn check_budget(
    file: &std::path::Path,
    what: &str,
    bytes: u64,
) -> Result<(), crate::data::dataset::DataError> {
    let budget = memory_budget().map_err(|m| crate::data::dataset::fmt_err(file, m))?;
    if bytes > budget {
        return Err(crate::data::dataset::fmt_err(
            file,
            format!(
                "{what} needs {bytes} bytes, more than the memory budget of {budget} bytes; raise OCCAM_MEMORY_BUDGET if the machine has the memory, or split the data"
            ),
        ));
    }
    Ok(())
}

/// A 64-bit FNV-1a hash, fed in pieces. It identifies the `dataset.npz` that a `dataset.json`
/// was written with (not a defence against tampering, only against mixing up two runs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Fnv1a(u64);

impl Default for Fnv1a {
    fn default() -> Self {
        Fnv1a(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv1a {
    /// Feeds `bytes`.
    pub fn update(&mut self, bytes: &[u8]) {
        let mut h = self.0;
        for &b in bytes {
            h ^= b as u64;
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
        self.0 = h;
    }

    /// The hash of everything fed so far.
    pub fn finish(&self) -> u64 {
        self.0
    }

    /// The hash of `bytes`.
    pub fn of(bytes: &[u8]) -> u64 {
        let mut h = Fnv1a::default();
        h.update(bytes);
        h.finish()
    }

    /// The length and hash of everything `r` yields.
    pub fn of_reader(mut r: impl std::io::Read) -> std::io::Result<(u64, u64)> {
        let mut h = Fnv1a::default();
        let mut buf = vec![0u8; 1 << 16];
        let mut len = 0u64;
        loop {
            let n = match r.read(&mut buf) {
                Ok(0) => return Ok((len, h.finish())),
                Ok(n) => n,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e),
            };
            h.update(&buf[..n]);
            len += n as u64;
        }
    }
}

/// `x` rounded to 10 significant digits, for messages (`0.1`, not `0.10000000000000009`).
fn sig(x: f64) -> f64 {
    format!("{x:.9e}").parse().unwrap_or(x)
}

/// Relative tolerance on the spacing of a time column.
pub const TIME_TOLERANCE: f64 = 1e-6;

/// The sample rate of a time column `t` (named `column` in messages), checking that it is
/// strictly increasing and uniformly spaced: every step within [`TIME_TOLERANCE`] (relative)
/// of the median step, plus the rounding of `t` itself (a few ulp, which matters for absolute
/// times such as GPS seconds). `at(k)` locates sample `k` in messages (`"line 7"`,
/// `"sample 5"`). Returns `(n − 1) / (t_last − t_0)`.
pub fn uniform_rate(t: &[f64], column: &str, at: impl Fn(usize) -> String) -> Result<f64, String> {
    if t.len() < 2 {
        return Err(format!(
            "time column `{column}` needs at least two samples to give a sample rate"
        ));
    }
    for k in 1..t.len() {
        if !(t[k] > t[k - 1]) {
            return Err(format!(
                "{}, column `{column}`: time {} s does not increase (it follows {} s on {}); the time column must be strictly increasing",
                at(k),
                t[k],
                t[k - 1],
                at(k - 1)
            ));
        }
    }
    let mut steps: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    steps.sort_by(f64::total_cmp);
    let dt = steps[steps.len() / 2];
    for k in 1..t.len() {
        let step = t[k] - t[k - 1];
        let tol = TIME_TOLERANCE * dt + 4.0 * f64::EPSILON * t[k].abs().max(t[k - 1].abs());
        if (step - dt).abs() > tol {
            return Err(format!(
                "{}, column `{column}`: not uniformly sampled: the step from {} is {} s but the series' spacing is {} s (tolerance {TIME_TOLERANCE} relative); gaps must be filled or the series split",
                at(k),
                at(k - 1),
                sig(step),
                sig(dt)
            ));
        }
    }
    Ok((t.len() - 1) as f64 / (t[t.len() - 1] - t[0]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fnv1a_known_values() {
        // the reference values of the FNV-1a 64-bit test suite
        assert_eq!(Fnv1a::of(b""), 0xcbf29ce484222325);
        assert_eq!(Fnv1a::of(b"a"), 0xaf63dc4c8601ec8c);
        assert_eq!(Fnv1a::of(b"foobar"), 0x85944171f73967e8);
        let mut h = Fnv1a::default();
        h.update(b"foo");
        h.update(b"bar");
        assert_eq!(h.finish(), 0x85944171f73967e8);
        let big: Vec<u8> = (0..200_000u32).map(|k| (k * 7 % 251) as u8).collect();
        assert_eq!(
            Fnv1a::of_reader(&big[..]).unwrap(),
            (200_000, Fnv1a::of(&big))
        );
    }

    #[test]
    fn uniform_rate_accepts_gps_times_and_rejects_gaps() {
        let t: Vec<f64> = (0..1000).map(|k| 1.1e9 + 0.1 * k as f64).collect();
        let fs = uniform_rate(&t, "t", |k| format!("sample {k}")).unwrap();
        assert!((fs - 10.0).abs() < 1e-5, "{fs}");
        let mut g = t.clone();
        g.remove(500);
        let e = uniform_rate(&g, "t", |k| format!("sample {k}")).unwrap_err();
        assert!(e.contains("sample 500") && e.contains("sample 499"), "{e}");
        let e = uniform_rate(&[0.0, 1.0, 1.0], "time", |k| format!("line {}", k + 2)).unwrap_err();
        assert!(
            e.contains("line 4") && e.contains("`time`") && e.contains("increas"),
            "{e}"
        );
    }
}
