//! [`DataSource`]: one experiment's data read from a CSV or npz file named in the study.

use crate::dataset::{DataError, ExperimentData, check_channel_name, fmt_err, read_csv};
use ndarray::Array1;
use ndarray_npy::NpzReader;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Where one `[[experiment]]`'s data come from when it is read, not simulated.
///
/// ```toml
/// [[experiment]]
/// name = "inv1"
/// data = "data/inv1.csv"          # or .npz
/// noise_data = "data/quiet.csv"   # only for the Welch noise estimate
/// columns = { t = "t_s", o1 = "o1_m", o12 = "o12_m", i1 = "i1_m", i12 = "i12_m" }
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DataSource {
    /// A `.csv` file (header row of column names) or an `.npz` archive (1-D float64 arrays),
    /// relative to the study file.
    pub data: PathBuf,
    /// Channel → column header (CSV) or array name (npz). A channel not listed is looked up
    /// under its own name; `t` is the time column (optional).
    #[serde(default)]
    pub columns: BTreeMap<String, String>,
    /// Sample rate (Hz); needed when there is no time column, and must agree with it otherwise.
    #[serde(default)]
    pub fs: Option<f64>,
    /// A noise-only stretch (same column map), needed only for the Welch noise estimate.
    #[serde(default)]
    pub noise_data: Option<PathBuf>,
}

/// Columns of a CSV file or arrays of an npz archive.
struct Table {
    file: PathBuf,
    /// Every column (array) name in the file, in file order.
    names: Vec<String>,
    /// The columns that were read, by name.
    columns: BTreeMap<String, Vec<f64>>,
    /// CSV: the 1-based line of each row; npz: none.
    lines: Option<Vec<usize>>,
}

impl Table {
    /// Reads `file`: every column of a CSV, the arrays in `wanted` of an npz.
    fn read(file: &Path, wanted: &[&str]) -> Result<Table, DataError> {
        if !file.exists() {
            return Err(fmt_err(file, "no such file"));
        }
        match file.extension().and_then(|x| x.to_str()) {
            Some(x) if x.eq_ignore_ascii_case("csv") => {
                let t = read_csv(file)?;
                Ok(Table {
                    file: file.into(),
                    columns: t.names.iter().cloned().zip(t.columns).collect(),
                    names: t.names,
                    lines: Some(t.lines),
                })
            }
            Some(x) if x.eq_ignore_ascii_case("npz") => Self::read_npz(file, wanted),
            _ => Err(fmt_err(
                file,
                "unknown data format: expected a .csv file or an .npz archive",
            )),
        }
    }

    fn read_npz(file: &Path, wanted: &[&str]) -> Result<Table, DataError> {
        let f = std::fs::File::open(file).map_err(|source| DataError::Io {
            file: file.display().to_string(),
            source,
        })?;
        let mut z = NpzReader::new(f)
            .map_err(|e| fmt_err(file, format!("not a readable npz archive: {e}")))?;
        let names = z
            .names()
            .map_err(|e| fmt_err(file, format!("not a readable npz archive: {e}")))?;
        if names.is_empty() {
            return Err(fmt_err(file, "empty archive: it holds no arrays"));
        }
        let mut columns = BTreeMap::new();
        let mut first: Option<(String, usize)> = None;
        for &w in wanted {
            if !names.iter().any(|n| n == w) || columns.contains_key(w) {
                continue;
            }
            let a: Array1<f64> = z.by_name(w).map_err(|e| {
                fmt_err(
                    file,
                    format!("array `{w}`: cannot read it as a 1-D float64 array: {e}"),
                )
            })?;
            let v = a.to_vec();
            if v.is_empty() {
                return Err(fmt_err(file, format!("array `{w}` has no samples")));
            }
            if let Some(k) = v.iter().position(|x| !x.is_finite()) {
                return Err(fmt_err(
                    file,
                    format!(
                        "array `{w}`, sample {k}: {} is not finite (NaN and infinities are not allowed)",
                        v[k]
                    ),
                ));
            }
            match &first {
                None => first = Some((w.to_string(), v.len())),
                Some((f, n)) if *n != v.len() => {
                    return Err(fmt_err(
                        file,
                        format!(
                            "array `{w}` has {} samples but `{f}` has {n}; all channels (and the time column) must have the same length",
                            v.len()
                        ),
                    ));
                }
                Some(_) => {}
            }
            columns.insert(w.to_string(), v);
        }
        Ok(Table {
            file: file.into(),
            names,
            columns,
            lines: None,
        })
    }

    /// Where sample `k` is, for messages.
    fn at(&self, k: usize) -> String {
        match &self.lines {
            Some(l) => format!("line {}", l[k]),
            None => format!("sample {k}"),
        }
    }

    fn kind(&self) -> &'static str {
        if self.lines.is_some() {
            "columns"
        } else {
            "arrays"
        }
    }

    fn listing(&self) -> String {
        self.names
            .iter()
            .map(|n| format!("`{n}`"))
            .collect::<Vec<_>>()
            .join(", ")
    }

    fn get(&self, column: &str) -> Option<&Vec<f64>> {
        self.columns.get(column)
    }

    /// The sample rate of the time column `column`, if the file has one.
    fn rate(&self, column: &str) -> Result<Option<f64>, DataError> {
        let Some(t) = self.get(column) else {
            return Ok(None);
        };
        super::uniform_rate(t, column, |k| self.at(k))
            .map(Some)
            .map_err(|m| fmt_err(&self.file, m))
    }
}

/// Relative agreement required between sample rates from different sources.
const RATE_TOLERANCE: f64 = 1e-6;

impl DataSource {
    /// The column (array) holding channel `c`.
    pub fn column_of<'a>(&'a self, c: &'a str) -> &'a str {
        self.columns.get(c).map(|s| s.as_str()).unwrap_or(c)
    }

    /// Reads experiment `name`'s data. `base` is the directory paths are relative to (the
    /// study file's); `channels` are the data channels the models need (`o1`, `o12`, `i1`,
    /// `i12`, `g1`, …), each of which must be in the data file.
    ///
    /// The noise-only stretch, when `noise_data` is given, holds the needed channels that the
    /// noise file has, except the injections `i1`, `i12` (noiseless by construction). The
    /// sample rate comes from the time column, else from `fs`, else from the noise file's time
    /// column.
    pub fn load(
        &self,
        name: &str,
        base: &Path,
        channels: &[String],
    ) -> Result<ExperimentData, DataError> {
        let data = base.join(&self.data);
        let mut chans: Vec<&str> = Vec::new();
        for c in channels {
            if !crate::dataset::FIXED_CHANNELS.contains(&c.as_str()) {
                check_channel_name(c)
                    .map_err(|m| fmt_err(&data, format!("experiment `{name}`: {m}")))?;
            }
            if !chans.contains(&c.as_str()) {
                chans.push(c);
            }
        }
        if chans.is_empty() {
            return Err(fmt_err(
                &data,
                format!("experiment `{name}`: no data channels requested"),
            ));
        }
        if let Some((k, _)) = self.columns.iter().find(|(_, v)| v.trim().is_empty()) {
            return Err(fmt_err(
                &data,
                format!("experiment `{name}`: `columns.{k}` is empty"),
            ));
        }
        let t_col = self.column_of("t");
        let mut wanted: Vec<&str> = chans.iter().map(|c| self.column_of(c)).collect();
        wanted.push(t_col);

        let table = Table::read(&data, &wanted)?;
        if self.columns.contains_key("t") && !table.names.iter().any(|n| n == t_col) {
            return Err(fmt_err(
                &data,
                format!(
                    "experiment `{name}`: no time column `{t_col}` (set by `columns.t`); the file has {} {}",
                    table.kind(),
                    table.listing()
                ),
            ));
        }
        let mut fit: BTreeMap<&str, Vec<f64>> = BTreeMap::new();
        for &c in &chans {
            let col = self.column_of(c);
            let v = table.get(col).ok_or_else(|| {
                let hint = if self.columns.contains_key(c) {
                    String::new()
                } else {
                    format!("; map it to another with `columns = {{ {c} = \"...\" }}`")
                };
                fmt_err(
                    &data,
                    format!(
                        "experiment `{name}` needs channel `{c}`: no column `{col}` (the file has {} {}){hint}",
                        table.kind(),
                        table.listing()
                    ),
                )
            })?;
            fit.insert(c, v.clone());
        }

        // sample rate
        if let Some(f) = self.fs
            && !(f.is_finite() && f > 0.0)
        {
            return Err(fmt_err(
                &data,
                format!("experiment `{name}`: fs = {f} Hz is not > 0"),
            ));
        }
        let data_rate = table.rate(t_col)?;
        if let (Some(a), Some(f)) = (data_rate, self.fs)
            && (a - f).abs() > RATE_TOLERANCE * a
        {
            return Err(fmt_err(
                &data,
                format!(
                    "experiment `{name}`: the time column `{t_col}` gives {a} Hz but fs = {f} Hz"
                ),
            ));
        }

        // noise-only stretch
        let mut noise: BTreeMap<&str, Vec<f64>> = BTreeMap::new();
        let mut noise_rate = None;
        let noise_file = self.noise_data.as_ref().map(|p| base.join(p));
        if let Some(nf) = &noise_file {
            let nt = Table::read(nf, &wanted)?;
            let noisy: Vec<&str> = chans
                .iter()
                .copied()
                .filter(|c| *c != "i1" && *c != "i12")
                .collect();
            for &c in &noisy {
                if let Some(v) = nt.get(self.column_of(c)) {
                    noise.insert(c, v.clone());
                }
            }
            if noise.is_empty() {
                let cols: Vec<String> = noisy
                    .iter()
                    .map(|c| format!("`{}`", self.column_of(c)))
                    .collect();
                return Err(fmt_err(
                    nf,
                    format!(
                        "experiment `{name}`: the noise-only file has none of the channels' columns {} (it has {} {})",
                        cols.join(", "),
                        nt.kind(),
                        nt.listing()
                    ),
                ));
            }
            if let Some((c, v)) = noise.iter().find(|(_, v)| v.len() < 16) {
                return Err(fmt_err(
                    nf,
                    format!(
                        "experiment `{name}`: the noise-only stretch of `{c}` has {} samples; need ≥ 16",
                        v.len()
                    ),
                ));
            }
            noise_rate = nt.rate(t_col)?;
            if let (Some(b), Some(a)) = (noise_rate, data_rate.or(self.fs))
                && (a - b).abs() > RATE_TOLERANCE * a
            {
                return Err(fmt_err(
                    nf,
                    format!(
                        "experiment `{name}`: sample rate {b} Hz (time column `{t_col}`) differs from the data's {a} Hz ({})",
                        data.display()
                    ),
                ));
            }
        }
        let fs = data_rate.or(self.fs).or(noise_rate).ok_or_else(|| {
            fmt_err(
                &data,
                format!(
                    "experiment `{name}`: no time column `{t_col}` and no `fs` given: the sample rate is unknown"
                ),
            )
        })?;

        let mut e = ExperimentData::new(
            name,
            fs,
            [Vec::new(), Vec::new()],
            [Vec::new(), Vec::new()],
            [Vec::new(), Vec::new()],
        );
        for (c, v) in fit {
            match c {
                "o1" => e.o[0] = v,
                "o12" => e.o[1] = v,
                "i1" => e.i[0] = v,
                "i12" => e.i[1] = v,
                _ => {
                    e.extra.insert(c.to_string(), v);
                }
            }
        }
        for (c, v) in noise {
            match c {
                "o1" => e.noise[0] = v,
                "o12" => e.noise[1] = v,
                _ => {
                    e.noise_extra.insert(c.to_string(), v);
                }
            }
        }
        e.validate(&data)?;
        Ok(e)
    }
}
