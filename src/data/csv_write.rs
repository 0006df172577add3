//! A dataset as CSV files, the form `[[experiment]] data = "…csv"` reads back
//! ([`crate::data::DataSource`]): per experiment `<name>.csv` (the fit stretch) and, when it
//! has one, `<name>_noise.csv` (the noise-only stretch). Each has a header row `t,<channel>,…`
//! with the time in seconds from the first sample (`k/fs`) and every channel that holds data
//! (the fixed `o1, o12, i1, i12` when not empty, then the further channels in name order); a
//! missing sample (a gap) is an empty cell. The channels are written in Rust's shortest
//! round-trip exponent form (`-3.391313472530933e-10`), so reading the files back gives the
//! same bits; the time column in its shortest decimal form.

use super::dataset::{Dataset, Stretch};
use super::error::{DataError, io_err};
use super::gaps;
use std::io::Write;
use std::path::{Path, PathBuf};

impl Dataset {
    /// Writes `dir/<experiment>.csv` and `dir/<experiment>_noise.csv` for every experiment,
    /// each atomically; returns the paths written, in order.
    ///
    /// ```
    /// use occam::data::dataset::{Dataset, ExperimentData};
    /// let e = ExperimentData::new(
    ///     "inv1",
    ///     2.0,
    ///     [vec![1.0, 2.0], vec![3.0, 4.0]],
    ///     [vec![0.5, -0.5], vec![]],
    ///     [vec![0.1, 0.2, 0.3], vec![0.4, 0.5, 0.6]],
    /// );
    /// let d = Dataset { experiments: vec![e], seed: None, truth: None, extra: Default::default() };
    /// let dir = tempfile::tempdir().unwrap();
    /// let written = d.write_csv(dir.path()).unwrap();
    /// assert_eq!(written.len(), 2);
    /// let text = std::fs::read_to_string(dir.path().join("inv1.csv")).unwrap();
    /// assert_eq!(text, "t,o1,o12,i1\n0,1e0,3e0,5e-1\n0.5,2e0,4e0,-5e-1\n");
    /// ```
    pub fn write_csv(&self, dir: &Path) -> Result<Vec<PathBuf>, DataError> {
        std::fs::create_dir_all(dir).map_err(io_err(dir))?;
        let mut written = Vec::new();
        for e in &self.experiments {
            for (stretch, file) in [
                (Stretch::Fit, format!("{}.csv", e.name)),
                (Stretch::Noise, format!("{}_noise.csv", e.name)),
            ] {
                let none = Vec::new();
                let columns: Vec<(String, Vec<f64>)> = e
                    .series()
                    .into_iter()
                    .filter(|(_, s, v)| *s == stretch && !v.is_empty())
                    .map(|(c, _, v)| {
                        let g = match stretch {
                            Stretch::Fit if e.known_in_gaps.contains(&c) => &none,
                            Stretch::Fit => &e.gaps,
                            Stretch::Noise => &e.noise_gaps,
                        };
                        let name = c.strip_prefix("noise_").unwrap_or(&c).to_string();
                        (name, gaps::with_nan(v, g))
                    })
                    .collect();
                let Some(n) = columns.first().map(|c| c.1.len()) else {
                    continue;
                };
                let path = dir.join(file);
                crate::atomic::write_with(&path, |w| {
                    write!(w, "t")?;
                    for (c, _) in &columns {
                        write!(w, ",{c}")?;
                    }
                    writeln!(w)?;
                    for k in 0..n {
                        write!(w, "{}", k as f64 / e.fs)?;
                        for (_, v) in &columns {
                            match v.get(k) {
                                Some(x) if x.is_finite() => write!(w, ",{x:e}")?,
                                _ => write!(w, ",")?,
                            }
                        }
                        writeln!(w)?;
                    }
                    Ok(())
                })
                .map_err(io_err(&path))?;
                written.push(path);
            }
        }
        Ok(written)
    }
}
