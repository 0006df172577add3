//! [`DataSource`]: one experiment's data read from a CSV or npz file named in the study.
//! [`ExperimentData::from_csv`] is the shorthand for two CSV files with the fixed columns.

use super::dataset::{
    ExperimentData, FIXED_CHANNELS, check_channel_name, read_csv, sample_problem,
};
use super::error::{DataError, fmt_err};
use super::gaps;
use super::memory::{check_budget, memory_budget_bytes};
use super::time_column::time_grid;
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
    /// Missing data of the fit stretch, `[t0, t1]` in seconds from its first sample, beside
    /// the file's own (NaN, empty cells, missing time stamps).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub gaps: Vec<[f64; 2]>,
    /// Missing data of the noise-only stretch, likewise.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub noise_gaps: Vec<[f64; 2]>,
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
        let mut z = super::npz::NpzArchive::open(file).map_err(|m| fmt_err(file, m))?;
        let names = z.names();
        if names.is_empty() {
            return Err(fmt_err(file, "empty archive: it holds no arrays"));
        }
        // the sizes of the arrays to be read, against the budget, before reading any
        let (mut total, mut largest) = (0u64, 0u64);
        let mut seen = Vec::new();
        for &w in wanted {
            if names.iter().any(|n| n == w) && !seen.contains(&w) {
                seen.push(w);
                let n = z.stored_size(w).map_err(|m| fmt_err(file, m))?;
                total = total.saturating_add(n);
                largest = largest.max(n);
            }
        }
        check_budget(file, "reading its arrays", total.saturating_add(largest))?;
        let budget = memory_budget_bytes();
        let mut columns = BTreeMap::new();
        let mut first: Option<(String, usize)> = None;
        for &w in wanted {
            if !names.iter().any(|n| n == w) || columns.contains_key(w) {
                continue;
            }
            let v = z.read_f64(w, budget).map_err(|m| fmt_err(file, m))?;
            if v.is_empty() {
                return Err(fmt_err(file, format!("array `{w}` has no samples")));
            }
            if let Some((k, why)) = v
                .iter()
                .enumerate()
                .find_map(|(k, x)| sample_problem(*x, "NaN").map(|w| (k, w)))
            {
                return Err(fmt_err(file, format!("array `{w}`, sample {k}: {why}")));
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

    /// The sample rate of the time column `column`, if the file has one, and the position of
    /// each row on the uniform grid when time stamps are missing ([`time_grid`]).
    fn rate(&self, column: &str) -> Result<Option<RateAndGrid>, DataError> {
        let Some(t) = self.get(column) else {
            return Ok(None);
        };
        if let Some(k) = t.iter().position(|x| x.is_nan()) {
            return Err(fmt_err(
                &self.file,
                format!(
                    "{}, column `{column}`: the time stamp is missing (NaN or empty); leave the row out instead — a missing time stamp is a gap",
                    self.at(k)
                ),
            ));
        }
        time_grid(t, column, |k| self.at(k))
            .map(Some)
            .map_err(|m| fmt_err(&self.file, m))
    }

    /// Spreads the columns `names` onto the uniform grid `pos` (from [`Table::rate`]), with
    /// NaN (a gap) at every missing time stamp; the grid's size is checked against the memory
    /// budget first.
    fn fill_missing_stamps(&mut self, pos: &[usize], names: &[&str]) -> Result<(), DataError> {
        let len = pos.last().map_or(0, |p| p + 1);
        let bytes = (len as u64)
            .saturating_mul(8)
            .saturating_mul(names.len() as u64 + 1);
        check_budget(&self.file, "filling its missing time stamps", bytes)?;
        for n in names {
            if let Some(v) = self.columns.get_mut(*n) {
                let mut full = vec![f64::NAN; len];
                for (&p, &x) in pos.iter().zip(v.iter()) {
                    full[p] = x;
                }
                *v = full;
            }
        }
        Ok(())
    }
}

/// A time column's sample rate and, when time stamps are missing, each row's grid position.
type RateAndGrid = (f64, Option<Vec<usize>>);

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
        let read: Vec<(String, String)> = channels
            .iter()
            .map(|c| (c.clone(), "a model".to_string()))
            .collect();
        self.load_read_by(name, base, &read)
    }

    /// [`load`](Self::load), with each channel paired with who reads it (`model `a``), which
    /// the error names when the data file lacks the channel.
    pub fn load_read_by(
        &self,
        name: &str,
        base: &Path,
        channels: &[(String, String)],
    ) -> Result<ExperimentData, DataError> {
        let data = base.join(&self.data);
        let mut chans: Vec<&str> = Vec::new();
        let reader = |c: &str| {
            channels
                .iter()
                .find(|(k, _)| k == c)
                .map_or("", |(_, by)| by.as_str())
        };
        for (c, _) in channels {
            if !FIXED_CHANNELS.contains(&c.as_str()) {
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

        let mut table = Table::read(&data, &wanted)?;
        let (data_rate, data_grid) = table.rate(t_col)?.unzip();
        if let Some(Some(pos)) = &data_grid {
            table.fill_missing_stamps(pos, &wanted)?;
        }
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
                        "experiment `{name}`: {} reads channel `{c}`, but the file has no {} `{col}` (it has {} {}){hint}",
                        reader(c),
                        table.kind().trim_end_matches('s'),
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
            let mut nt = Table::read(nf, &wanted)?;
            let (rate, grid) = nt.rate(t_col)?.unzip();
            if let Some(Some(pos)) = &grid {
                nt.fill_missing_stamps(pos, &wanted)?;
            }
            noise_rate = rate;
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
            e.set_channel(c, v);
        }
        for (c, v) in noise {
            e.set_noise_channel(c, v);
        }
        // NaN, empty cells and missing time stamps: gaps of every channel of the stretch
        e.take_nan_gaps();
        let listed = gaps::from_times(&self.gaps, fs, e.n_samples(), "gaps")
            .map_err(|m| fmt_err(&data, format!("experiment `{name}`: {m}")))?;
        e.add_gaps(&listed);
        let m = e.n_noise_samples();
        if m > 0 {
            let listed = gaps::from_times(&self.noise_gaps, fs, m, "noise_gaps")
                .map_err(|m| fmt_err(&data, format!("experiment `{name}`: {m}")))?;
            e.add_noise_gaps(&listed);
        }
        if e.gaps.is_empty() {
            e.known_in_gaps.clear();
        }
        e.validate(&data)?;
        Ok(e)
    }
}

impl ExperimentData {
    /// Builds an experiment from two CSV files: `data` with columns `o1, o12, i1, i12` (and an
    /// optional uniformly spaced time column `t`), and `noise` with `o1, o12` (optional `t`).
    /// The sample rate comes from `t` when present, else from `fs`. See
    /// [`DataSource`] for renamed columns, npz files and further channels.
    pub fn from_csv(
        name: &str,
        data: &Path,
        noise: &Path,
        fs: Option<f64>,
    ) -> Result<Self, DataError> {
        let src = DataSource {
            data: data.to_path_buf(),
            columns: BTreeMap::new(),
            fs,
            noise_data: Some(noise.to_path_buf()),
            gaps: Vec::new(),
            noise_gaps: Vec::new(),
        };
        let channels = FIXED_CHANNELS.map(String::from);
        let e = src.load(name, Path::new(""), &channels)?;
        for (c, v) in ["o1", "o12"].iter().zip(&e.noise) {
            if v.is_empty() {
                return Err(fmt_err(
                    noise,
                    format!("no column `{c}`: the noise-only stretch needs o1 and o12"),
                ));
            }
        }
        Ok(e)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::Array1;
    use ndarray_npy::NpzWriter;

    fn chans(c: &[&str]) -> Vec<String> {
        c.iter().map(|s| s.to_string()).collect()
    }

    /// A CSV with a comment, renamed columns and `n` rows at 10 Hz; `row(k)` gives the values.
    fn csv(header: &str, n: usize, row: impl Fn(usize) -> String) -> String {
        let mut s = format!("# exported by a test\n{header}\n");
        for k in 0..n {
            s += &row(k);
            s.push('\n');
        }
        s
    }

    fn renamed() -> DataSource {
        DataSource {
            data: "run.csv".into(),
            columns: [
                ("t", "t_s"),
                ("o1", "o1_m"),
                ("o12", "o12_m"),
                ("i1", "i1_m"),
                ("i12", "i12_m"),
                ("g1", "g1_N"),
            ]
            .into_iter()
            .map(|(a, b)| (a.to_string(), b.to_string()))
            .collect(),
            fs: None,
            noise_data: Some("quiet.csv".into()),
            gaps: Vec::new(),
            noise_gaps: Vec::new(),
        }
    }

    const HEADER: &str = "t_s,o1_m,o12_m,i1_m,i12_m,g1_N,unused";

    fn write_good(dir: &Path) {
        let s = csv(HEADER, 40, |k| {
            format!(
                "{},{k},{},{},0,{},7",
                100.0 + 0.1 * k as f64,
                -(k as f64),
                2 * k,
                0.5 * k as f64
            )
        });
        std::fs::write(dir.join("run.csv"), s).unwrap();
        let s = csv("t_s,o1_m,o12_m,g1_N", 30, |k| {
            format!("{},{},{},{}", 0.1 * k as f64, 1e-9 * k as f64, 2.0, 3.0)
        });
        std::fs::write(dir.join("quiet.csv"), s).unwrap();
    }

    fn load_err(src: &DataSource, dir: &Path, c: &[&str]) -> String {
        src.load("inv1", dir, &chans(c)).unwrap_err().to_string()
    }

    #[test]
    fn csv_with_renamed_columns() {
        let dir = tempfile::tempdir().unwrap();
        write_good(dir.path());
        let src = renamed();
        let e = src
            .load(
                "inv1",
                dir.path(),
                &chans(&["o1", "o12", "i1", "i12", "g1"]),
            )
            .unwrap();
        assert_eq!(e.name, "inv1");
        assert!((e.fs - 10.0).abs() < 1e-9, "{}", e.fs);
        assert_eq!(e.channel("o12").unwrap()[3], -3.0);
        assert_eq!(e.channel("i1").unwrap()[4], 8.0);
        assert_eq!(e.channel("g1").unwrap()[2], 1.0);
        assert_eq!(e.channel("unused"), None);
        assert_eq!(e.n_samples(), 40);
        // the noise stretch has the measured channels, not the injections
        assert_eq!(e.noise_channel("o1").unwrap().len(), 30);
        assert_eq!(e.noise_channel("g1").unwrap()[0], 3.0);
        assert_eq!(e.noise_channel("i1"), None);
        assert_eq!(e.n_noise_samples(), 30);
        // only what the models need is read; `fs` given and agreeing is fine
        let mut s = src.clone();
        s.fs = Some(10.0);
        s.noise_data = None;
        let e = s.load("inv1", dir.path(), &chans(&["o1", "g1"])).unwrap();
        assert_eq!(e.channel_names(), chans(&["o1", "g1"]));
        assert_eq!(e.n_noise_samples(), 0);
        // and the experiment round-trips through a dataset directory
        let d = crate::data::dataset::Dataset {
            experiments: vec![
                src.load(
                    "inv1",
                    dir.path(),
                    &chans(&["o1", "o12", "i1", "i12", "g1"]),
                )
                .unwrap(),
            ],
            seed: None,
            truth: None,
            extra: serde_json::Value::Null,
        };
        d.write(&dir.path().join("ds")).unwrap();
        let back = crate::data::dataset::Dataset::read(&dir.path().join("ds")).unwrap();
        assert_eq!(back, d);
    }

    fn write_npz(path: &Path, arrays: &[(&str, Vec<f64>)]) {
        let mut z = NpzWriter::new(std::fs::File::create(path).unwrap());
        for (n, v) in arrays {
            z.add_array(*n, &Array1::from_vec(v.clone())).unwrap();
        }
        z.finish().unwrap();
    }

    #[test]
    fn npz_source() {
        let dir = tempfile::tempdir().unwrap();
        let ramp = |a: f64, n: usize| (0..n).map(|k| a * k as f64).collect::<Vec<_>>();
        write_npz(
            &dir.path().join("run.npz"),
            &[
                ("time", ramp(0.5, 64)),
                ("o1", ramp(1.0, 64)),
                ("x12", ramp(2.0, 64)),
                ("g2", ramp(3.0, 64)),
                ("label", vec![1.0]),
            ],
        );
        write_npz(
            &dir.path().join("noise.npz"),
            &[("o1", ramp(1.0, 20)), ("x12", ramp(1.0, 20))],
        );
        let src = DataSource {
            data: "run.npz".into(),
            columns: [("t", "time"), ("o12", "x12")]
                .into_iter()
                .map(|(a, b)| (a.to_string(), b.to_string()))
                .collect(),
            fs: None,
            noise_data: Some("noise.npz".into()),
            gaps: Vec::new(),
            noise_gaps: Vec::new(),
        };
        let e = src
            .load("x", dir.path(), &chans(&["o1", "o12", "g2"]))
            .unwrap();
        assert!((e.fs - 2.0).abs() < 1e-12);
        assert_eq!(e.channel("o12").unwrap()[5], 10.0);
        assert_eq!(e.channel("g2").unwrap()[5], 15.0);
        assert_eq!(e.noise_channel("o12").unwrap().len(), 20);
        assert_eq!(e.noise_channel("g2"), None);

        // arrays of different lengths
        write_npz(
            &dir.path().join("run.npz"),
            &[("o1", ramp(1.0, 64)), ("x12", ramp(2.0, 60))],
        );
        let mut s = src.clone();
        s.fs = Some(2.0);
        s.columns.remove("t");
        s.noise_data = None;
        let err = load_err(&s, dir.path(), &["o1", "o12"]);
        assert!(
            err.contains("run.npz") && err.contains("`x12` has 60") && err.contains("`o1` has 64"),
            "{err}"
        );
        // a NaN is a missing sample; an infinity names the array and the sample
        let mut bad = ramp(1.0, 64);
        bad[9] = f64::NAN;
        write_npz(&dir.path().join("run.npz"), &[("o1", bad.clone())]);
        let e = s.load("inv1", dir.path(), &chans(&["o1"])).unwrap();
        assert_eq!((e.gaps.clone(), e.o[0][9]), (vec![[9, 10]], 0.0));
        bad[9] = f64::INFINITY;
        write_npz(&dir.path().join("run.npz"), &[("o1", bad.clone())]);
        let err = load_err(&s, dir.path(), &["o1"]);
        assert!(
            err.contains("run.npz") && err.contains("array `o1`, sample 9") && err.contains("inf"),
            "{err}"
        );
        // finite, but its square overflows: named as well (the fit failed later, with NaN)
        bad[9] = -1e308;
        write_npz(&dir.path().join("run.npz"), &[("o1", bad)]);
        let err = load_err(&s, dir.path(), &["o1"]);
        assert!(
            err.contains("run.npz")
                && err.contains("array `o1`, sample 9")
                && err.contains("-1e308 is beyond ±1e150"),
            "{err}"
        );
        // a missing array lists the ones that exist
        write_npz(
            &dir.path().join("run.npz"),
            &[("o1", ramp(1.0, 64)), ("x12", ramp(2.0, 64))],
        );
        let err = load_err(&s, dir.path(), &["o1", "o12", "g2"]);
        assert!(
            err.contains("run.npz")
                && err.contains("reads channel `g2`, but the file has no array `g2`")
                && err.contains("arrays `o1`, `x12`"),
            "{err}"
        );
    }

    /// Writes `text` as the data file and returns the load error.
    fn csv_err(dir: &Path, text: &str, fs: Option<f64>, c: &[&str]) -> String {
        std::fs::write(dir.join("bad.csv"), text).unwrap();
        let src = DataSource {
            data: "bad.csv".into(),
            columns: BTreeMap::new(),
            fs,
            noise_data: None,
            gaps: Vec::new(),
            noise_gaps: Vec::new(),
        };
        load_err(&src, dir, c)
    }

    fn good_rows(n: usize) -> String {
        (0..n)
            .map(|k| format!("{},{k}\n", 0.1 * k as f64))
            .collect()
    }

    #[test]
    fn bad_csv_values_name_file_line_and_column() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        // line 1 comment, line 2 header, data from line 3: row k on line k + 3
        let rows = |bad_row: usize, cell: &str| {
            let mut s = String::from("# comment\nt,o1\n");
            for k in 0..20 {
                if k == bad_row {
                    s += &format!("{},{cell}\n", 0.1 * k as f64);
                } else {
                    s += &format!("{},{k}\n", 0.1 * k as f64);
                }
            }
            s
        };
        for cell in ["inf", "-inf"] {
            let e = csv_err(d, &rows(4, cell), None, &["o1"]);
            assert!(
                e.contains("bad.csv") && e.contains("line 7") && e.contains("column `o1`"),
                "{cell}: {e}"
            );
            assert!(e.contains("not finite"), "{e}");
        }
        let e = csv_err(d, &rows(5, "1.2.3"), None, &["o1"]);
        assert!(
            e.contains("bad.csv")
                && e.contains("line 8")
                && e.contains("column `o1`")
                && e.contains("`1.2.3` is not a number"),
            "{e}"
        );
        // ragged row
        let e = csv_err(d, "t,o1\n0,1\n0.1,2,3\n", None, &["o1"]);
        assert!(
            e.contains("bad.csv") && e.contains("line 3") && e.contains("3 values for 2 columns"),
            "{e}"
        );
    }

    #[test]
    fn bad_csv_headers() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        // a missing column names the channel, the column and the columns there are
        let e = csv_err(d, &format!("t,o1\n{}", good_rows(20)), None, &["o1", "o12"]);
        assert!(
            e.contains("bad.csv")
                && e.contains("channel `o12`")
                && e.contains("no column `o12`")
                && e.contains("`t`, `o1`"),
            "{e}"
        );
        // a mapped column that is missing
        std::fs::write(d.join("m.csv"), format!("t,o1\n{}", good_rows(20))).unwrap();
        let src = DataSource {
            data: "m.csv".into(),
            columns: [("o1".to_string(), "o1_m".to_string())].into(),
            fs: None,
            noise_data: None,
            gaps: Vec::new(),
            noise_gaps: Vec::new(),
        };
        let e = load_err(&src, d, &["o1"]);
        assert!(
            e.contains("m.csv") && e.contains("channel `o1`") && e.contains("no column `o1_m`"),
            "{e}"
        );
        // duplicated header
        let e = csv_err(d, "t,o1,o1\n0,1,2\n", None, &["o1"]);
        assert!(
            e.contains("bad.csv")
                && e.contains("line 1")
                && e.contains("`o1` appears twice")
                && e.contains("columns 2 and 3"),
            "{e}"
        );
        // missing header (numbers in the first row), an unnamed column
        let e = csv_err(d, "0,1\n0.1,2\n", None, &["o1"]);
        assert!(
            e.contains("bad.csv") && e.contains("line 1, column 1"),
            "{e}"
        );
        let e = csv_err(d, "# c\nt,,o1\n0,1,2\n", None, &["o1"]);
        assert!(e.contains("line 2, column 2"), "{e}");
        // empty file, header only
        let e = csv_err(d, "", None, &["o1"]);
        assert!(e.contains("bad.csv") && e.contains("empty file"), "{e}");
        let e = csv_err(d, "# only a comment\n\n", None, &["o1"]);
        assert!(e.contains("empty file"), "{e}");
        let e = csv_err(d, "t,o1\n", None, &["o1"]);
        assert!(e.contains("no data rows") && e.contains("line 1"), "{e}");
    }

    #[test]
    fn bad_time_columns_and_rates() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        // a missing time stamp: row 10 (line 12) is one step late, sample 10 is a gap
        let mut s = String::from("t,o1\n");
        for k in 0..30 {
            let t = 0.1 * k as f64 + if k >= 10 { 0.1 } else { 0.0 };
            s += &format!("{t},{k}\n");
        }
        std::fs::write(d.join("bad.csv"), &s).unwrap();
        let src = DataSource {
            data: "bad.csv".into(),
            columns: BTreeMap::new(),
            fs: None,
            noise_data: None,
            gaps: vec![[2.0, 2.5]],
            noise_gaps: Vec::new(),
        };
        let e = src.load("inv1", d, &chans(&["o1"])).unwrap();
        assert_eq!(e.n_samples(), 31);
        assert_eq!(e.gaps, vec![[10, 11], [20, 25]]);
        assert_eq!((e.o[0][9], e.o[0][10], e.o[0][11]), (9.0, 0.0, 10.0));
        assert!((e.fs - 10.0).abs() < 1e-9, "{}", e.fs);
        // half a step late is on no grid
        let mut s = String::from("t,o1\n");
        for k in 0..30 {
            let t = 0.1 * k as f64 + if k >= 10 { 0.05 } else { 0.0 };
            s += &format!("{t},{k}\n");
        }
        let e = csv_err(d, &s, None, &["o1"]);
        assert!(
            e.contains("bad.csv")
                && e.contains("line 12, column `t`")
                && e.contains("from line 11")
                && e.contains("step from line 11 is 0.15 s")
                && e.contains("spacing 0.1 s"),
            "{e}"
        );
        // not increasing
        let e = csv_err(d, "t,o1\n0,1\n1,2\n1,3\n", None, &["o1"]);
        assert!(
            e.contains("line 4, column `t`") && e.contains("does not increase"),
            "{e}"
        );
        // `fs` disagreeing with the time column
        let e = csv_err(d, &format!("t,o1\n{}", good_rows(20)), Some(4.0), &["o1"]);
        assert!(
            e.contains("bad.csv") && e.contains("10") && e.contains("fs = 4 Hz"),
            "{e}"
        );
        // no time column and no fs; with fs it loads
        let no_t: String = (0..20).map(|k| format!("{k}\n")).collect();
        let e = csv_err(d, &format!("o1\n{no_t}"), None, &["o1"]);
        assert!(e.contains("sample rate is unknown"), "{e}");
        std::fs::write(d.join("ok.csv"), format!("o1\n{no_t}")).unwrap();
        let src = DataSource {
            data: "ok.csv".into(),
            columns: BTreeMap::new(),
            fs: Some(3.0),
            noise_data: Some("n.csv".into()),
            gaps: Vec::new(),
            noise_gaps: Vec::new(),
        };
        // a noise file at another sample rate
        let slow: String = (0..20)
            .map(|k| format!("{},{k}\n", 0.5 * k as f64))
            .collect();
        std::fs::write(d.join("n.csv"), format!("t,o1\n{slow}")).unwrap();
        let e = load_err(&src, d, &["o1"]);
        assert!(
            e.contains("n.csv") && e.contains("2 Hz") && e.contains("3 Hz") && e.contains("ok.csv"),
            "{e}"
        );
        // a noise file without any of the channels
        std::fs::write(d.join("n.csv"), format!("x\n{no_t}")).unwrap();
        let e = load_err(&src, d, &["o1"]);
        assert!(
            e.contains("n.csv") && e.contains("`o1`") && e.contains("`x`"),
            "{e}"
        );
        // too few rows
        let e = csv_err(d, &format!("t,o1\n{}", good_rows(5)), None, &["o1"]);
        assert!(e.contains("bad.csv") && e.contains("too short"), "{e}");
    }

    #[test]
    fn missing_files_and_formats() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let src = DataSource {
            data: "nope/run.csv".into(),
            columns: BTreeMap::new(),
            fs: Some(1.0),
            noise_data: None,
            gaps: Vec::new(),
            noise_gaps: Vec::new(),
        };
        let e = load_err(&src, d, &["o1"]);
        assert!(
            e.contains("nope/run.csv") && e.contains("no such file"),
            "{e}"
        );
        std::fs::write(d.join("run.txt"), "o1\n1\n").unwrap();
        let mut s = src.clone();
        s.data = "run.txt".into();
        let e = load_err(&s, d, &["o1"]);
        assert!(e.contains("run.txt") && e.contains(".csv"), "{e}");
        // the noise file too
        std::fs::write(d.join("run.csv"), format!("o1\n{}", "1\n".repeat(20))).unwrap();
        s.data = "run.csv".into();
        s.noise_data = Some("quiet.csv".into());
        let e = load_err(&s, d, &["o1"]);
        assert!(e.contains("quiet.csv") && e.contains("no such file"), "{e}");
        // a reserved channel name
        s.noise_data = None;
        let e = load_err(&s, d, &["o1", "t"]);
        assert!(e.contains("reserved"), "{e}");
    }

    #[test]
    fn source_from_toml() {
        let s: DataSource = toml::from_str(
            "data = \"a.csv\"\nfs = 2.0\ncolumns = { o1 = \"x\" }\nnoise_data = \"n.npz\"\n",
        )
        .unwrap();
        assert_eq!(s.column_of("o1"), "x");
        assert_eq!(s.column_of("o12"), "o12");
        assert!(toml::from_str::<DataSource>("data = \"a.csv\"\ncolumn = {}\n").is_err());
    }
}
