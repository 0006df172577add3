//! Datasets on disk: per experiment the outputs `o1, o12`, the commanded injections `i1, i12`
//! and a noise-only stretch, with the sample rate, the truth and the seed.
//!
//! Format: `dataset.npz` (readable with `numpy.load`; arrays named `<experiment>.o1`,
//! `<experiment>.o12`, `<experiment>.i1`, `<experiment>.i12`, `<experiment>.noise_o1`,
//! `<experiment>.noise_o12`, and `truth` when known) plus `dataset.json`, a sidecar with the
//! metadata. Users can also bring plain CSV time series ([`read_csv`], [`ExperimentData::from_csv`]).

use crate::ltp::LtpParams;
use ndarray::Array1;
use ndarray_npy::{NpzReader, NpzWriter};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Problems reading or writing data files; every message names the file.
#[derive(Debug, thiserror::Error)]
pub enum DataError {
    #[error("{file}: {source}")]
    Io {
        file: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{file}: {msg}")]
    Format { file: String, msg: String },
}

fn io_err(file: &Path) -> impl FnOnce(std::io::Error) -> DataError + '_ {
    move |source| DataError::Io {
        file: file.display().to_string(),
        source,
    }
}

fn fmt_err(file: &Path, msg: impl Into<String>) -> DataError {
    DataError::Format {
        file: file.display().to_string(),
        msg: msg.into(),
    }
}

/// One experiment's time series (SI units: metres, seconds).
#[derive(Debug, Clone, PartialEq)]
pub struct ExperimentData {
    pub name: String,
    /// Sample rate (Hz).
    pub fs: f64,
    /// Outputs `(o1, o12)` over the fit stretch.
    pub o: [Vec<f64>; 2],
    /// Commanded injections `(i1, i12)` over the fit stretch.
    pub i: [Vec<f64>; 2],
    /// Outputs `(o1, o12)` over the noise-only stretch.
    pub noise: [Vec<f64>; 2],
}

/// Metadata written beside the arrays.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Sidecar {
    /// occam version that wrote the file.
    pub occam_version: String,
    pub seed: Option<u64>,
    /// True parameters, by name, when the data are simulated.
    pub truth: Option<LtpParams>,
    pub experiments: Vec<SidecarExperiment>,
    /// Anything else the writer wants to record (resolved study, SNRs, …).
    #[serde(default)]
    pub extra: serde_json::Value,
}

/// Per-experiment metadata.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SidecarExperiment {
    pub name: String,
    pub fs: f64,
    pub n_samples: usize,
    pub n_noise_samples: usize,
}

/// A set of experiments plus metadata.
#[derive(Debug, Clone, PartialEq)]
pub struct Dataset {
    pub experiments: Vec<ExperimentData>,
    pub seed: Option<u64>,
    pub truth: Option<LtpParams>,
    pub extra: serde_json::Value,
}

const CHANNELS: [&str; 6] = ["o1", "o12", "i1", "i12", "noise_o1", "noise_o12"];

impl ExperimentData {
    /// Checks lengths and finiteness; the message names the array.
    pub fn validate(&self, file: &Path) -> Result<(), DataError> {
        if !(self.fs.is_finite() && self.fs > 0.0) {
            return Err(fmt_err(
                file,
                format!(
                    "experiment `{}`: sample rate {} is not > 0",
                    self.name, self.fs
                ),
            ));
        }
        let n = self.o[0].len();
        for (name, v) in self.channels() {
            let want = if name.starts_with("noise") {
                self.noise[0].len()
            } else {
                n
            };
            if v.len() != want {
                return Err(fmt_err(
                    file,
                    format!(
                        "experiment `{}`: `{name}` has {} samples but its companions have {want}; all channels of a stretch must have the same length",
                        self.name,
                        v.len()
                    ),
                ));
            }
            if let Some(k) = v.iter().position(|x| !x.is_finite()) {
                return Err(fmt_err(
                    file,
                    format!(
                        "experiment `{}`: `{name}` sample {k} is {} (every sample must be finite)",
                        self.name, v[k]
                    ),
                ));
            }
        }
        if n < 16 || self.noise[0].len() < 16 {
            return Err(fmt_err(
                file,
                format!(
                    "experiment `{}`: too short ({} fit samples, {} noise samples; need ≥ 16 each)",
                    self.name,
                    n,
                    self.noise[0].len()
                ),
            ));
        }
        Ok(())
    }

    /// The fit-stretch series of a named data channel (`o1`, `o12`, `i1`, `i12`), if the
    /// experiment has it.
    pub fn channel(&self, name: &str) -> Option<&[f64]> {
        match name {
            "o1" => Some(&self.o[0]),
            "o12" => Some(&self.o[1]),
            "i1" => Some(&self.i[0]),
            "i12" => Some(&self.i[1]),
            _ => None,
        }
    }

    /// The noise-only series of a named data channel, if the experiment has one. Channels
    /// without a noise-only series (the commanded injections) are noiseless by construction.
    pub fn noise_channel(&self, name: &str) -> Option<&[f64]> {
        match name {
            "o1" => Some(&self.noise[0]),
            "o12" => Some(&self.noise[1]),
            _ => None,
        }
    }

    fn channels(&self) -> [(&'static str, &Vec<f64>); 6] {
        [
            ("o1", &self.o[0]),
            ("o12", &self.o[1]),
            ("i1", &self.i[0]),
            ("i12", &self.i[1]),
            ("noise_o1", &self.noise[0]),
            ("noise_o12", &self.noise[1]),
        ]
    }

    /// Builds an experiment from two CSV files: `data` with columns `o1, o12, i1, i12` (and an
    /// optional uniformly spaced time column `t`), and `noise` with `o1, o12` (optional `t`).
    /// The sample rate comes from `t` when present, else from `fs`.
    pub fn from_csv(
        name: &str,
        data: &Path,
        noise: &Path,
        fs: Option<f64>,
    ) -> Result<Self, DataError> {
        let d = read_csv(data)?;
        let nz = read_csv(noise)?;
        let get = |t: &CsvTable, file: &Path, c: &str| -> Result<Vec<f64>, DataError> {
            t.column(c).cloned().ok_or_else(|| {
                fmt_err(
                    file,
                    format!(
                        "no column `{c}` (columns: {:?}); expected o1, o12, i1, i12",
                        t.names
                    ),
                )
            })
        };
        let rate = |t: &CsvTable, file: &Path| -> Result<Option<f64>, DataError> {
            t.sample_rate().map_err(|m| fmt_err(file, m))
        };
        let fs = match (rate(&d, data)?, rate(&nz, noise)?, fs) {
            (Some(a), Some(b), _) if (a - b).abs() > 1e-9 * a => {
                return Err(fmt_err(
                    noise,
                    format!("sample rate {b} Hz differs from the data file's {a} Hz"),
                ));
            }
            (Some(a), _, Some(f)) if (a - f).abs() > 1e-9 * a => {
                return Err(fmt_err(
                    data,
                    format!("time column gives {a} Hz but the study says fs = {f} Hz"),
                ));
            }
            (Some(a), _, _) | (None, Some(a), _) | (None, None, Some(a)) => a,
            (None, None, None) => {
                return Err(fmt_err(
                    data,
                    "no time column `t` and no `fs` given: the sample rate is unknown",
                ));
            }
        };
        let e = ExperimentData {
            name: name.into(),
            fs,
            o: [get(&d, data, "o1")?, get(&d, data, "o12")?],
            i: [get(&d, data, "i1")?, get(&d, data, "i12")?],
            noise: [get(&nz, noise, "o1")?, get(&nz, noise, "o12")?],
        };
        e.validate(data)?;
        Ok(e)
    }
}

impl Dataset {
    /// Writes `dir/dataset.npz` and `dir/dataset.json`, each atomically.
    pub fn write(&self, dir: &Path) -> Result<(PathBuf, PathBuf), DataError> {
        std::fs::create_dir_all(dir).map_err(io_err(dir))?;
        let npz = dir.join("dataset.npz");
        crate::atomic::write_with(&npz, |w| {
            let mut z = NpzWriter::new(w);
            let to_io = |e: ndarray_npy::WriteNpzError| std::io::Error::other(e.to_string());
            for e in &self.experiments {
                for (c, v) in e.channels() {
                    z.add_array(format!("{}.{c}", e.name), &Array1::from_vec(v.clone()))
                        .map_err(to_io)?;
                }
                z.add_array(format!("{}.fs", e.name), &Array1::from_vec(vec![e.fs]))
                    .map_err(to_io)?;
            }
            if let Some(t) = &self.truth {
                z.add_array("truth", &Array1::from_vec(t.to_array().to_vec()))
                    .map_err(to_io)?;
            }
            z.finish().map_err(to_io)?;
            Ok(())
        })
        .map_err(io_err(&npz))?;
        let side = Sidecar {
            occam_version: env!("CARGO_PKG_VERSION").into(),
            seed: self.seed,
            truth: self.truth,
            experiments: self
                .experiments
                .iter()
                .map(|e| SidecarExperiment {
                    name: e.name.clone(),
                    fs: e.fs,
                    n_samples: e.o[0].len(),
                    n_noise_samples: e.noise[0].len(),
                })
                .collect(),
            extra: self.extra.clone(),
        };
        let json = dir.join("dataset.json");
        let mut text = serde_json::to_string_pretty(&side).expect("sidecar serialises");
        text.push('\n');
        crate::atomic::write_bytes(&json, text.as_bytes()).map_err(io_err(&json))?;
        Ok((npz, json))
    }

    /// Reads a dataset written by [`Dataset::write`]: `path` is the directory, the `.npz` or
    /// the `.json`.
    pub fn read(path: &Path) -> Result<Dataset, DataError> {
        let dir = if path.is_dir() {
            path.to_path_buf()
        } else {
            path.parent().unwrap_or(Path::new(".")).to_path_buf()
        };
        let json = dir.join("dataset.json");
        let npz = dir.join("dataset.npz");
        let text = std::fs::read_to_string(&json).map_err(io_err(&json))?;
        let side: Sidecar = serde_json::from_str(&text)
            .map_err(|e| fmt_err(&json, format!("not an occam dataset sidecar: {e}")))?;
        let f = std::fs::File::open(&npz).map_err(io_err(&npz))?;
        let mut z = NpzReader::new(f).map_err(|e| fmt_err(&npz, e.to_string()))?;
        let mut experiments = Vec::new();
        for m in &side.experiments {
            let mut get = |c: &str| -> Result<Vec<f64>, DataError> {
                let key = format!("{}.{c}", m.name);
                let a: Array1<f64> = z
                    .by_name(&key)
                    .map_err(|e| fmt_err(&npz, format!("array `{key}`: {e}")))?;
                Ok(a.to_vec())
            };
            let mut v: Vec<Vec<f64>> = Vec::new();
            for c in CHANNELS {
                v.push(get(c)?);
            }
            let mut it = v.into_iter();
            let mut next = || it.next().expect("six channels");
            let e = ExperimentData {
                name: m.name.clone(),
                fs: m.fs,
                o: [next(), next()],
                i: [next(), next()],
                noise: [next(), next()],
            };
            e.validate(&npz)?;
            experiments.push(e);
        }
        if let Some(t) = side.truth
            && let Some(n) = t.non_finite()
        {
            return Err(fmt_err(&json, format!("truth.{n} is not finite")));
        }
        Ok(Dataset {
            experiments,
            seed: side.seed,
            truth: side.truth,
            extra: side.extra,
        })
    }
}

/// A CSV file of named numeric columns.
#[derive(Debug, Clone, PartialEq)]
pub struct CsvTable {
    pub names: Vec<String>,
    pub columns: Vec<Vec<f64>>,
}

impl CsvTable {
    /// The column called `name`.
    pub fn column(&self, name: &str) -> Option<&Vec<f64>> {
        self.names
            .iter()
            .position(|n| n == name)
            .map(|i| &self.columns[i])
    }

    /// The sample rate from a time column `t`, checking that it is uniformly spaced (a gap or
    /// a jitter above 1e−6 of the step is an error naming the row).
    pub fn sample_rate(&self) -> Result<Option<f64>, String> {
        let Some(t) = self.column("t") else {
            return Ok(None);
        };
        if t.len() < 2 {
            return Err("time column `t` needs at least two rows".into());
        }
        let dt = (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64;
        if !(dt > 0.0) {
            return Err("time column `t` must increase".into());
        }
        for k in 1..t.len() {
            let step = t[k] - t[k - 1];
            if (step - dt).abs() > 1e-6 * dt {
                return Err(format!(
                    "time column `t` is not uniformly sampled: step {step} s before data row {} (expected {dt} s); gaps must be filled or the series split",
                    k + 1
                ));
            }
        }
        Ok(Some(1.0 / dt))
    }
}

/// Reads a CSV file with a header row of column names and numeric rows. Lines starting with `#`
/// are comments. Errors name the file, the line and the column.
pub fn read_csv(path: &Path) -> Result<CsvTable, DataError> {
    let text = std::fs::read_to_string(path).map_err(io_err(path))?;
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
    let (_, header) = lines
        .next()
        .ok_or_else(|| fmt_err(path, "empty file: expected a header row of column names"))?;
    let names: Vec<String> = header.split(',').map(|s| s.trim().to_string()).collect();
    if names
        .iter()
        .any(|n| n.is_empty() || n.parse::<f64>().is_ok())
    {
        return Err(fmt_err(
            path,
            format!("line 1 must name the columns (e.g. `t,o1,o12,i1,i12`), got `{header}`"),
        ));
    }
    let mut columns = vec![Vec::new(); names.len()];
    for (ln, line) in lines {
        let cells: Vec<&str> = line.split(',').collect();
        if cells.len() != names.len() {
            return Err(fmt_err(
                path,
                format!(
                    "line {}: {} values for {} columns; every row needs one value per column (channels of different lengths?)",
                    ln + 1,
                    cells.len(),
                    names.len()
                ),
            ));
        }
        for (j, c) in cells.iter().enumerate() {
            let v: f64 = c.trim().parse().map_err(|_| {
                fmt_err(
                    path,
                    format!(
                        "line {}, column `{}`: `{}` is not a number",
                        ln + 1,
                        names[j],
                        c.trim()
                    ),
                )
            })?;
            if !v.is_finite() {
                return Err(fmt_err(
                    path,
                    format!(
                        "line {}, column `{}`: {v} is not finite (NaN and infinities are not allowed)",
                        ln + 1,
                        names[j]
                    ),
                ));
            }
            columns[j].push(v);
        }
    }
    if columns[0].is_empty() {
        return Err(fmt_err(path, "no data rows after the header"));
    }
    Ok(CsvTable { names, columns })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Dataset {
        let n = 64;
        let v = |a: f64| (0..n).map(|k| a * k as f64).collect::<Vec<_>>();
        Dataset {
            experiments: vec![ExperimentData {
                name: "inv1".into(),
                fs: 10.0,
                o: [v(1.0), v(2.0)],
                i: [v(3.0), v(4.0)],
                noise: [v(5.0)[..32].to_vec(), v(6.0)[..32].to_vec()],
            }],
            seed: Some(7),
            truth: Some(LtpParams::default()),
            extra: serde_json::json!({"note": "test"}),
        }
    }

    #[test]
    fn npz_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let d = sample();
        d.write(dir.path()).unwrap();
        let back = Dataset::read(dir.path()).unwrap();
        assert_eq!(back, d);
    }

    #[test]
    fn csv_errors_name_line_and_column() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("d.csv");
        std::fs::write(&p, "t,o1\n0,1\n0.1,nan\n").unwrap();
        let e = read_csv(&p).unwrap_err().to_string();
        assert!(
            e.contains("d.csv") && e.contains("line 3") && e.contains("o1"),
            "{e}"
        );
        std::fs::write(&p, "t,o1\n0,1\n0.1\n").unwrap();
        let e = read_csv(&p).unwrap_err().to_string();
        assert!(e.contains("line 3") && e.contains("1 values for 2"), "{e}");
        std::fs::write(&p, "t,o1\n0,1\n0.1,2\n0.3,3\n").unwrap();
        let e = read_csv(&p).unwrap().sample_rate().unwrap_err();
        assert!(e.contains("not uniformly sampled"), "{e}");
    }

    #[test]
    fn experiment_from_csv() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path().join("d.csv");
        let n = dir.path().join("n.csv");
        let mut s = String::from("t,o1,o12,i1,i12\n");
        for k in 0..20 {
            s += &format!("{},{},{},0,0\n", k as f64 * 0.1, k, -k);
        }
        std::fs::write(&d, &s).unwrap();
        let mut s = String::from("o1,o12\n");
        for k in 0..20 {
            s += &format!("{k},{k}\n");
        }
        std::fs::write(&n, &s).unwrap();
        let e = ExperimentData::from_csv("x", &d, &n, None).unwrap();
        assert!((e.fs - 10.0).abs() < 1e-9);
        assert_eq!(e.o[1][3], -3.0);
        // short noise series: different-length stretch is fine, but a missing column is not
        std::fs::write(&n, "o1\n1\n").unwrap();
        let err = ExperimentData::from_csv("x", &d, &n, None)
            .unwrap_err()
            .to_string();
        assert!(err.contains("o12"), "{err}");
    }
}
