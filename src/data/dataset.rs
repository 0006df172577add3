//! Datasets on disk: per experiment the outputs `o1, o12`, the commanded injections `i1, i12`,
//! any further named channels (`g1`, `g2`, …) and a noise-only stretch, with the sample rate,
//! the truth and the seed.
//!
//! Format: `dataset.npz` (readable with `numpy.load`; arrays named `<experiment>.o1`,
//! `<experiment>.o12`, `<experiment>.i1`, `<experiment>.i12`, `<experiment>.noise_o1`,
//! `<experiment>.noise_o12` (empty when the channel is absent), `<experiment>.<channel>` and
//! `<experiment>.noise_<channel>` for further channels, `<experiment>.fs`, and `truth` when
//! known) plus `dataset.json`, a sidecar with the metadata that lists the further channels.
//! [`Dataset::read`] checks the two against each other.
//!
//! Integrity: [`Dataset::write`] writes the archive first and the sidecar last, and the sidecar
//! records the archive's length and FNV-1a hash (`npz_digest`). [`Dataset::read`] refuses an
//! archive that does not match (a run killed between the two writes, or files copied from two
//! runs), then checks every experiment's sample rate, lengths, channel names and the truth
//! against the arrays, and every array's size against the memory budget before reading it
//! ([`crate::data::npz`]). Sidecars without a digest (written before it existed) are read with
//! the field checks alone. Users' own files are read by [`crate::data::DataSource`] (CSV via
//! [`read_csv`], or npz).

pub use super::error::DataError;
use super::error::{fmt_err, io_err};
use super::fnv::Fnv1a;
use super::gaps::{self, Span};
use super::memory::{check_budget, memory_budget_bytes};
use super::time_column::uniform_rate;
use crate::ltp::LtpParams;
use ndarray::Array1;
use ndarray_npy::NpzWriter;
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The longest experiment or channel name, in bytes: names become array names in the npz
/// archive, whose format caps a file name at 65 535 bytes.
pub const MAX_NAME_LEN: usize = 256;

/// The channels every experiment has a slot for; an empty series means the channel is absent.
pub const FIXED_CHANNELS: [&str; 4] = ["o1", "o12", "i1", "i12"];

/// Checks that `name` can name a data channel: letters, digits, `_` or `-`; not `t` (the time
/// column), not `fs`, and not starting with `noise_` (those name noise-only arrays on disk).
pub fn check_channel_name(name: &str) -> Result<(), String> {
    if name.is_empty()
        || name.len() > MAX_NAME_LEN
        || !name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
    {
        return Err(format!(
            "channel name `{}`: use 1 to {MAX_NAME_LEN} letters, digits, `_` or `-` (it names arrays in the dataset)",
            name.chars().take(40).collect::<String>()
        ));
    }
    if name == "t" || name == "fs" || name.starts_with("noise_") {
        return Err(format!(
            "channel name `{name}` is reserved (`t` is the time column, `fs` the sample rate, `noise_*` the noise-only arrays)"
        ));
    }
    Ok(())
}

/// One experiment's time series (SI units: metres, seconds).
///
/// The outputs and injections have fixed slots; any further channel (commanded forces `g1`,
/// `g2`, …) lives in [`ExperimentData::extra`]. An empty fixed series means the experiment
/// does not have that channel ([`ExperimentData::channel`] returns `None` for it).
#[derive(Debug, Clone, PartialEq)]
pub struct ExperimentData {
    pub name: String,
    /// Sample rate (Hz).
    pub fs: f64,
    /// Outputs `(o1, o12)` over the fit stretch.
    pub o: [Vec<f64>; 2],
    /// Commanded injections `(i1, i12)` over the fit stretch.
    pub i: [Vec<f64>; 2],
    /// Outputs `(o1, o12)` over the noise-only stretch (empty when there is none).
    pub noise: [Vec<f64>; 2],
    /// Further named channels over the fit stretch.
    pub extra: BTreeMap<String, Vec<f64>>,
    /// Noise-only series of further channels (a subset of the keys of `extra`).
    pub noise_extra: BTreeMap<String, Vec<f64>>,
    /// Missing samples of the fit stretch, in every channel at once ([`crate::data::gaps`]:
    /// normalised half-open ranges; the samples hold `0.0`). Empty for gap-free data.
    pub gaps: Vec<Span>,
    /// Missing samples of the noise-only stretch, likewise.
    pub noise_gaps: Vec<Span>,
    /// Fit-stretch channels whose values inside the gaps are real (commanded injections
    /// recorded through a telemetry gap); every other channel is blanked there.
    pub known_in_gaps: Vec<String>,
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
    /// The size and hash of the `dataset.npz` written with this sidecar, so that a sidecar
    /// beside another run's archive (a run killed between the two writes) is refused. Absent
    /// in datasets written before it existed; those are read unchecked.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub npz_digest: Option<NpzDigest>,
}

/// Identifies one `dataset.npz` file: its length and 64-bit FNV-1a hash
/// ([`Fnv1a`]) as 16 hex digits.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NpzDigest {
    pub bytes: u64,
    pub fnv1a64: String,
}

impl NpzDigest {
    /// The digest of a file of `bytes` bytes with hash `hash`.
    pub fn new(bytes: u64, hash: u64) -> Self {
        NpzDigest {
            bytes,
            fnv1a64: format!("{hash:016x}"),
        }
    }

    /// The digest of the file at `path`, read in pieces.
    pub fn of_file(path: &Path) -> Result<Self, DataError> {
        let f = super::infile::open(path).map_err(io_err(path))?;
        let (n, h) = Fnv1a::of_reader(std::io::BufReader::new(f)).map_err(io_err(path))?;
        Ok(NpzDigest::new(n, h))
    }
}

/// Per-experiment metadata.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SidecarExperiment {
    pub name: String,
    pub fs: f64,
    pub n_samples: usize,
    pub n_noise_samples: usize,
    /// Channels beyond `o1, o12, i1, i12` (arrays `<experiment>.<channel>`).
    #[serde(default)]
    pub channels: Vec<String>,
    /// Those of `channels` with a noise-only series (arrays `<experiment>.noise_<channel>`).
    #[serde(default)]
    pub noise_channels: Vec<String>,
    /// Missing samples of the fit stretch (`[start, end)`; NaN in the arrays).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub gaps: Vec<Span>,
    /// Missing samples of the noise-only stretch, likewise.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub noise_gaps: Vec<Span>,
}

/// A set of experiments plus metadata.
#[derive(Debug, Clone, PartialEq)]
pub struct Dataset {
    pub experiments: Vec<ExperimentData>,
    pub seed: Option<u64>,
    pub truth: Option<LtpParams>,
    pub extra: serde_json::Value,
}

/// Arrays every experiment has in `dataset.npz` (possibly empty), in writing order.
const NPZ_FIXED: [&str; 6] = ["o1", "o12", "i1", "i12", "noise_o1", "noise_o12"];

/// Which stretch a series belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Stretch {
    Fit,
    Noise,
}

impl ExperimentData {
    /// An experiment with only the fixed channels (`extra`, `noise_extra` empty).
    pub fn new(
        name: &str,
        fs: f64,
        o: [Vec<f64>; 2],
        i: [Vec<f64>; 2],
        noise: [Vec<f64>; 2],
    ) -> Self {
        ExperimentData {
            name: name.into(),
            fs,
            o,
            i,
            noise,
            extra: BTreeMap::new(),
            noise_extra: BTreeMap::new(),
            gaps: Vec::new(),
            noise_gaps: Vec::new(),
            known_in_gaps: Vec::new(),
        }
    }

    /// The fit stretch's samples `[a, b)` (a valid run) as an experiment of its own, with the
    /// whole noise-only stretch (and its gaps); `name` names it.
    pub fn slice(&self, name: &str, [a, b]: Span) -> ExperimentData {
        let cut = |v: &Vec<f64>| {
            if v.is_empty() {
                Vec::new()
            } else {
                v[a..b].to_vec()
            }
        };
        ExperimentData {
            name: name.into(),
            fs: self.fs,
            o: [cut(&self.o[0]), cut(&self.o[1])],
            i: [cut(&self.i[0]), cut(&self.i[1])],
            noise: self.noise.clone(),
            extra: self
                .extra
                .iter()
                .map(|(k, v)| (k.clone(), cut(v)))
                .collect(),
            noise_extra: self.noise_extra.clone(),
            gaps: Vec::new(),
            noise_gaps: self.noise_gaps.clone(),
            known_in_gaps: Vec::new(),
        }
    }

    /// Whether either stretch has missing samples.
    pub fn has_gaps(&self) -> bool {
        !(self.gaps.is_empty() && self.noise_gaps.is_empty())
    }

    /// The valid runs of the fit stretch (one run, the whole stretch, without gaps).
    pub fn valid_runs(&self) -> Vec<Span> {
        gaps::valid_runs(self.n_samples(), &self.gaps)
    }

    /// The valid runs of the noise-only stretch.
    pub fn noise_valid_runs(&self) -> Vec<Span> {
        gaps::valid_runs(self.n_noise_samples(), &self.noise_gaps)
    }

    /// Marks `gaps` of the fit stretch (merged with any it has) and blanks their samples in
    /// every channel but those of [`ExperimentData::known_in_gaps`].
    pub fn add_gaps(&mut self, gaps: &[Span]) {
        let mut all = std::mem::take(&mut self.gaps);
        all.extend_from_slice(gaps);
        let g = gaps::normalise(all);
        let known = std::mem::take(&mut self.known_in_gaps);
        for (c, st, v) in self.series_mut() {
            if st == Stretch::Fit && !known.contains(&c) {
                gaps::blank(v, &g);
            }
        }
        self.known_in_gaps = known;
        self.gaps = g;
    }

    /// Marks `gaps` of the noise-only stretch, likewise.
    pub fn add_noise_gaps(&mut self, gaps: &[Span]) {
        let mut all = std::mem::take(&mut self.noise_gaps);
        all.extend_from_slice(gaps);
        let g = gaps::normalise(all);
        for (_, st, v) in self.series_mut() {
            if st == Stretch::Noise {
                gaps::blank(v, &g);
            }
        }
        self.noise_gaps = g;
    }

    /// Turns the NaN samples of each stretch into gaps of that stretch (every channel of a
    /// stretch misses a sample that one of them misses).
    /// A fit-stretch channel with values and no NaN in the gaps keeps them
    /// ([`ExperimentData::known_in_gaps`]).
    pub fn take_nan_gaps(&mut self) {
        let (mut named, mut series): (Vec<String>, Vec<&mut Vec<f64>>) = self
            .series_mut()
            .into_iter()
            .filter(|(_, st, _)| *st == Stretch::Fit)
            .map(|(c, _, v)| (c, v))
            .unzip();
        let (found, kept) = gaps::take_nan_gaps_keeping(&mut series);
        named.retain({
            let mut it = kept.iter();
            move |_| *it.next().expect("one flag per series")
        });
        let merged = gaps::normalise(self.gaps.iter().copied().chain(found).collect());
        self.gaps = merged;
        self.known_in_gaps = named;
        let mut series: Vec<&mut Vec<f64>> = self
            .series_mut()
            .into_iter()
            .filter(|(_, st, _)| *st == Stretch::Noise)
            .map(|(_, _, v)| v)
            .collect();
        let found = gaps::take_nan_gaps(&mut series);
        self.add_noise_gaps(&found);
    }

    /// Every stored series, mutably, with its stretch (as [`Self::series`]).
    fn series_mut(&mut self) -> Vec<(String, Stretch, &mut Vec<f64>)> {
        let [o1, o12] = &mut self.o;
        let [i1, i12] = &mut self.i;
        let [n1, n12] = &mut self.noise;
        let mut v: Vec<(String, Stretch, &mut Vec<f64>)> = vec![
            ("o1".into(), Stretch::Fit, o1),
            ("o12".into(), Stretch::Fit, o12),
            ("i1".into(), Stretch::Fit, i1),
            ("i12".into(), Stretch::Fit, i12),
            ("noise_o1".into(), Stretch::Noise, n1),
            ("noise_o12".into(), Stretch::Noise, n12),
        ];
        for (c, s) in self.extra.iter_mut() {
            v.push((c.clone(), Stretch::Fit, s));
        }
        for (c, s) in self.noise_extra.iter_mut() {
            v.push((format!("noise_{c}"), Stretch::Noise, s));
        }
        v
    }

    /// Every stored series as `(array suffix, stretch, series)`, fixed slots first (including
    /// empty ones), then the extra channels in name order.
    pub(super) fn series(&self) -> Vec<(String, Stretch, &Vec<f64>)> {
        let mut v: Vec<(String, Stretch, &Vec<f64>)> = vec![
            ("o1".into(), Stretch::Fit, &self.o[0]),
            ("o12".into(), Stretch::Fit, &self.o[1]),
            ("i1".into(), Stretch::Fit, &self.i[0]),
            ("i12".into(), Stretch::Fit, &self.i[1]),
            ("noise_o1".into(), Stretch::Noise, &self.noise[0]),
            ("noise_o12".into(), Stretch::Noise, &self.noise[1]),
        ];
        for (c, s) in &self.extra {
            v.push((c.clone(), Stretch::Fit, s));
        }
        for (c, s) in &self.noise_extra {
            v.push((format!("noise_{c}"), Stretch::Noise, s));
        }
        v
    }

    /// Number of samples of the fit stretch (the length of its channels).
    pub fn n_samples(&self) -> usize {
        self.series()
            .iter()
            .filter(|(_, s, _)| *s == Stretch::Fit)
            .map(|(_, _, v)| v.len())
            .max()
            .unwrap_or(0)
    }

    /// Number of samples of the noise-only stretch (0 when there is none).
    pub fn n_noise_samples(&self) -> usize {
        self.series()
            .iter()
            .filter(|(_, s, _)| *s == Stretch::Noise)
            .map(|(_, _, v)| v.len())
            .max()
            .unwrap_or(0)
    }

    /// The names of the channels the experiment has over the fit stretch.
    pub fn channel_names(&self) -> Vec<String> {
        FIXED_CHANNELS
            .iter()
            .filter(|c| self.channel(c).is_some())
            .map(|c| c.to_string())
            .chain(self.extra.keys().cloned())
            .collect()
    }

    /// Checks channel names, lengths and finiteness; the message names the array.
    ///
    /// Every present fit-stretch channel has the same length (≥ 16); the noise-only channels
    /// likewise (≥ 16, or no noise-only stretch at all).
    pub fn validate(&self, file: &Path) -> Result<(), DataError> {
        if self.name.is_empty()
            || self.name.len() > MAX_NAME_LEN
            || !self
                .name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
        {
            let shown: String = self.name.chars().take(40).collect();
            return Err(fmt_err(
                file,
                format!(
                    "experiment name `{shown}`{} ({} bytes): use 1 to {MAX_NAME_LEN} letters, digits, `_` or `-` (it names arrays in the dataset)",
                    if shown.len() < self.name.len() {
                        "…"
                    } else {
                        ""
                    },
                    self.name.len()
                ),
            ));
        }
        let err = |msg: String| fmt_err(file, format!("experiment `{}`: {msg}", self.name));
        if !(self.fs.is_finite() && self.fs > 0.0) {
            return Err(err(format!("sample rate {} is not > 0", self.fs)));
        }
        for c in self.extra.keys().chain(self.noise_extra.keys()) {
            if FIXED_CHANNELS.contains(&c.as_str()) {
                return Err(err(format!(
                    "extra channel `{c}` duplicates a fixed channel (store it in `o`/`i`/`noise`)"
                )));
            }
            check_channel_name(c).map_err(&err)?;
        }
        if let Some(c) = self
            .noise_extra
            .keys()
            .find(|c| !self.extra.contains_key(*c))
        {
            return Err(err(format!(
                "channel `{c}` has a noise-only series but no fit-stretch series"
            )));
        }
        for (k, s) in self.extra.iter() {
            if s.is_empty() {
                return Err(err(format!("channel `{k}` has no samples")));
            }
        }
        for (k, s) in self.noise_extra.iter() {
            if s.is_empty() {
                return Err(err(format!("`noise_{k}` has no samples")));
            }
        }
        let (n, m) = (self.n_samples(), self.n_noise_samples());
        for (name, stretch, v) in self.series() {
            let want = match stretch {
                Stretch::Fit => n,
                Stretch::Noise => m,
            };
            if !v.is_empty() && v.len() != want {
                return Err(err(format!(
                    "`{name}` has {} samples but its companions have {want}; all channels of a stretch must have the same length",
                    v.len()
                )));
            }
            if let Some(k) = v.iter().position(|x| !x.is_finite()) {
                return Err(err(format!(
                    "`{name}` sample {k} is {} (every sample must be finite)",
                    v[k]
                )));
            }
        }
        if n < 16 || (m > 0 && m < 16) {
            return Err(err(format!(
                "too short ({n} fit samples, {m} noise samples; need ≥ 16 each, or no noise-only stretch)"
            )));
        }
        gaps::check(&self.gaps, n).map_err(|m| err(format!("fit stretch: {m}")))?;
        gaps::check(&self.noise_gaps, m).map_err(|m| err(format!("noise-only stretch: {m}")))?;
        Ok(())
    }

    /// Stores the fit-stretch series of channel `name`: the LTP names in their fixed slots,
    /// any other as an extra channel.
    pub fn set_channel(&mut self, name: &str, v: Vec<f64>) {
        match name {
            "o1" => self.o[0] = v,
            "o12" => self.o[1] = v,
            "i1" => self.i[0] = v,
            "i12" => self.i[1] = v,
            _ => {
                self.extra.insert(name.to_string(), v);
            }
        }
    }

    /// Stores the noise-only series of channel `name` (`o1`, `o12` in their slots, any other
    /// beside the extras; [`Self::validate`] refuses one for a commanded injection `i1`, `i12`).
    pub fn set_noise_channel(&mut self, name: &str, v: Vec<f64>) {
        match name {
            "o1" => self.noise[0] = v,
            "o12" => self.noise[1] = v,
            _ => {
                self.noise_extra.insert(name.to_string(), v);
            }
        }
    }

    /// The fit-stretch series of a named data channel (`o1`, `o12`, `i1`, `i12`, or an extra
    /// channel such as `g1`), if the experiment has it.
    pub fn channel(&self, name: &str) -> Option<&[f64]> {
        let v = match name {
            "o1" => &self.o[0],
            "o12" => &self.o[1],
            "i1" => &self.i[0],
            "i12" => &self.i[1],
            _ => return self.extra.get(name).map(|v| v.as_slice()),
        };
        (!v.is_empty()).then_some(v.as_slice())
    }

    /// The noise-only series of a named data channel, if the experiment has one. Channels
    /// without a noise-only series (the commanded injections) are noiseless by construction.
    pub fn noise_channel(&self, name: &str) -> Option<&[f64]> {
        let v = match name {
            "o1" => &self.noise[0],
            "o12" => &self.noise[1],
            "i1" | "i12" => return None,
            _ => return self.noise_extra.get(name).map(|v| v.as_slice()),
        };
        (!v.is_empty()).then_some(v.as_slice())
    }
}

impl Dataset {
    /// Writes `dir/dataset.npz` and `dir/dataset.json`, each atomically, the archive first;
    /// the sidecar records the archive's digest ([`NpzDigest`]), so [`Dataset::read`] refuses
    /// a sidecar beside an archive written by another run.
    pub fn write(&self, dir: &Path) -> Result<(PathBuf, PathBuf), DataError> {
        std::fs::create_dir_all(dir).map_err(io_err(dir))?;
        let npz = dir.join("dataset.npz");
        for e in &self.experiments {
            e.validate(&npz)?;
        }
        crate::atomic::write_with(&npz, |w| {
            let mut z = NpzWriter::new(w);
            let to_io = |e: ndarray_npy::WriteNpzError| std::io::Error::other(e.to_string());
            for e in &self.experiments {
                for (c, stretch, v) in e.series() {
                    // a missing sample is a NaN on disk
                    let none = Vec::new();
                    let g = match stretch {
                        Stretch::Fit if e.known_in_gaps.contains(&c) => &none,
                        Stretch::Fit => &e.gaps,
                        Stretch::Noise => &e.noise_gaps,
                    };
                    z.add_array(
                        format!("{}.{c}", e.name),
                        &Array1::from_vec(gaps::with_nan(v, g)),
                    )
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
        // the digest of the file as it is on disk, written last into the sidecar
        let npz_digest = Some(NpzDigest::of_file(&npz)?);
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
                    n_samples: e.n_samples(),
                    n_noise_samples: e.n_noise_samples(),
                    channels: e.extra.keys().cloned().collect(),
                    noise_channels: e.noise_extra.keys().cloned().collect(),
                    gaps: e.gaps.clone(),
                    noise_gaps: e.noise_gaps.clone(),
                })
                .collect(),
            extra: self.extra.clone(),
            npz_digest,
        };
        let json = dir.join("dataset.json");
        let mut text = serde_json::to_string_pretty(&side).expect("sidecar serialises");
        text.push('\n');
        crate::atomic::write_bytes(&json, text.as_bytes()).map_err(io_err(&json))?;
        Ok((npz, json))
    }

    /// The sidecar and array files of a dataset given as its directory, its `.json` or its
    /// `.npz`. The path must exist.
    fn files(path: &Path) -> Result<(PathBuf, PathBuf), DataError> {
        let meta = std::fs::metadata(path).map_err(|e| {
            fmt_err(
                path,
                format!(
                    "cannot open the dataset ({e}); give the directory written by `occam simulate` (holding dataset.json and dataset.npz)"
                ),
            )
        })?;
        let (json, npz) = if meta.is_dir() {
            (path.join("dataset.json"), path.join("dataset.npz"))
        } else {
            match path.extension().and_then(|x| x.to_str()) {
                Some("json") | Some("npz") => {
                    (path.with_extension("json"), path.with_extension("npz"))
                }
                _ => {
                    return Err(fmt_err(
                        path,
                        "not a dataset: give the directory written by `occam simulate`, or its dataset.json or dataset.npz",
                    ));
                }
            }
        };
        for f in [&json, &npz] {
            if !f.is_file() {
                return Err(fmt_err(
                    f,
                    format!(
                        "no such file: {} is not a complete occam dataset (it needs dataset.json and dataset.npz)",
                        path.display()
                    ),
                ));
            }
        }
        Ok((json, npz))
    }

    /// Reads a dataset written by [`Dataset::write`]: `path` is the directory, the `.npz` or
    /// the `.json` (which must exist). The sidecar is checked against the arrays: the archive's
    /// digest when the sidecar records one, the same experiments, sample rates, lengths and
    /// channels, and the same truth. Sizes are checked against the memory budget
    /// ([`crate::data::memory_budget`]) before anything is read.
    pub fn read(path: &Path) -> Result<Dataset, DataError> {
        let (json, npz) = Self::files(path)?;
        super::infile::check(&json).map_err(io_err(&json))?;
        let jlen = std::fs::metadata(&json).map_err(io_err(&json))?.len();
        check_budget(&json, "the sidecar", jlen.saturating_mul(4))?;
        let text = std::fs::read(&json).map_err(io_err(&json))?;
        let side = Self::parse_sidecar(&json, &text)?;
        if let Some(want) = &side.npz_digest {
            Self::check_digest(&json, &npz, want, &NpzDigest::of_file(&npz)?)?;
        }
        let z = crate::data::npz::NpzArchive::open(&npz).map_err(|m| fmt_err(&npz, m))?;
        Self::from_parts(side, z, &json, &npz)
    }

    /// Reads a dataset from the contents of its two files (as [`Dataset::read`] does from
    /// disk); messages call them `dataset.json` and `dataset.npz`.
    pub fn from_bytes(json_text: &[u8], npz_bytes: &[u8]) -> Result<Dataset, DataError> {
        let (json, npz) = (Path::new("dataset.json"), Path::new("dataset.npz"));
        let side = Self::parse_sidecar(json, json_text)?;
        if let Some(want) = &side.npz_digest {
            let have = NpzDigest::new(npz_bytes.len() as u64, Fnv1a::of(npz_bytes));
            Self::check_digest(json, npz, want, &have)?;
        }
        let z = crate::data::npz::NpzBytes::from_bytes(npz_bytes).map_err(|m| fmt_err(npz, m))?;
        Self::from_parts(side, z, json, npz)
    }

    fn parse_sidecar(json: &Path, text: &[u8]) -> Result<Sidecar, DataError> {
        let text = std::str::from_utf8(text).map_err(|e| {
            fmt_err(
                json,
                format!(
                    "not UTF-8 text (byte {}); not an occam dataset sidecar",
                    e.valid_up_to()
                ),
            )
        })?;
        serde_json::from_str(text).map_err(|e| {
            let key = json_key_before(text, e.line(), e.column())
                .map(|k| format!(" (at `{k}`)"))
                .unwrap_or_default();
            fmt_err(json, format!("not an occam dataset sidecar{key}: {e}"))
        })
    }

    fn check_digest(
        json: &Path,
        npz: &Path,
        want: &NpzDigest,
        have: &NpzDigest,
    ) -> Result<(), DataError> {
        if want != have {
            return Err(fmt_err(
                npz,
                format!(
                    "does not match {} (written by a different run; rerun `occam simulate`): the sidecar's `npz_digest` is {} bytes, FNV-1a {}, the archive is {} bytes, FNV-1a {}",
                    json.display(),
                    want.bytes,
                    want.fnv1a64,
                    have.bytes,
                    have.fnv1a64
                ),
            ));
        }
        Ok(())
    }

    /// Checks the sidecar `side` against the archive `z` and reads the arrays.
    fn from_parts<R: std::io::Read + std::io::Seek>(
        side: Sidecar,
        mut z: crate::data::npz::NpzArchive<R>,
        json: &Path,
        npz: &Path,
    ) -> Result<Dataset, DataError> {
        let (json, npz) = (json.to_path_buf(), npz.to_path_buf());
        let mismatch = |msg: String| DataError::Mismatch {
            json: json.display().to_string(),
            npz: npz.display().to_string(),
            msg,
        };
        let names: BTreeSet<String> = z.names().into_iter().collect();

        // the sidecar's list of arrays against the archive's
        let mut listed = BTreeSet::new();
        for m in &side.experiments {
            if !listed.insert(format!("{}.fs", m.name)) {
                return Err(fmt_err(
                    &json,
                    format!("experiment `{}` is listed twice", m.name),
                ));
            }
            let extra = m
                .channels
                .iter()
                .cloned()
                .chain(m.noise_channels.iter().map(|c| format!("noise_{c}")));
            for c in NPZ_FIXED.iter().map(|c| c.to_string()).chain(extra) {
                listed.insert(format!("{}.{c}", m.name));
            }
        }
        if side.truth.is_some() {
            listed.insert("truth".into());
        }
        if let Some(a) = listed.difference(&names).next() {
            return Err(mismatch(format!(
                "the sidecar implies an array `{a}` that the archive does not have"
            )));
        }
        if let Some(a) = names.difference(&listed).next() {
            let exp = a.split('.').next().unwrap_or(a);
            let what = if side.experiments.iter().any(|m| m.name == exp) {
                format!("the archive has an array `{a}` that the sidecar does not list")
            } else {
                format!(
                    "the archive has an array `{a}` of an experiment `{exp}` that the sidecar does not list"
                )
            };
            return Err(mismatch(what));
        }

        // every array's size, against the budget, before any is read: all of them are held at
        // once, plus the largest one's bytes while it is decoded
        let (mut total, mut largest) = (0u64, 0u64);
        for a in &listed {
            let n = z.stored_size(a).map_err(|m| fmt_err(&npz, m))?;
            total = total.saturating_add(n);
            largest = largest.max(n);
        }
        check_budget(&npz, "reading its arrays", total.saturating_add(largest))?;
        let budget = memory_budget_bytes();

        let mut get = |key: &str| -> Result<Vec<f64>, DataError> {
            z.read_f64(key, budget).map_err(|m| fmt_err(&npz, m))
        };
        let mut experiments = Vec::new();
        for m in &side.experiments {
            let key = |c: &str| format!("{}.{c}", m.name);
            let fs = get(&key("fs"))?;
            if fs.len() != 1 || !(fs[0] == m.fs) {
                return Err(mismatch(format!(
                    "experiment `{}`: the sidecar says fs = {} Hz but `{}` holds {fs:?}",
                    m.name,
                    m.fs,
                    key("fs")
                )));
            }
            let mut e = ExperimentData::new(
                &m.name,
                m.fs,
                [get(&key("o1"))?, get(&key("o12"))?],
                [get(&key("i1"))?, get(&key("i12"))?],
                [get(&key("noise_o1"))?, get(&key("noise_o12"))?],
            );
            for c in &m.channels {
                e.extra.insert(c.clone(), get(&key(c))?);
            }
            for c in &m.noise_channels {
                e.noise_extra
                    .insert(c.clone(), get(&key(&format!("noise_{c}")))?);
            }
            for (c, stretch, v) in e.series() {
                let (want, field) = match stretch {
                    Stretch::Fit => (m.n_samples, "n_samples"),
                    Stretch::Noise => (m.n_noise_samples, "n_noise_samples"),
                };
                // an empty fixed slot is an absent channel
                let fixed = NPZ_FIXED.contains(&c.as_str());
                if v.len() != want && !(fixed && v.is_empty()) {
                    return Err(mismatch(format!(
                        "experiment `{}`: the sidecar says {field} = {want} but `{}` has {} samples",
                        m.name,
                        key(&c),
                        v.len()
                    )));
                }
            }
            e.take_nan_gaps();
            e.add_gaps(&m.gaps);
            e.add_noise_gaps(&m.noise_gaps);
            if e.gaps.is_empty() {
                e.known_in_gaps.clear();
            }
            if (&e.gaps, &e.noise_gaps) != (&m.gaps, &m.noise_gaps) {
                return Err(mismatch(format!(
                    "experiment `{}`: the sidecar lists gaps {:?} (noise-only {:?}) but the archive's NaN samples make them {:?} (noise-only {:?})",
                    m.name, m.gaps, m.noise_gaps, e.gaps, e.noise_gaps
                )));
            }
            e.validate(&npz)?;
            experiments.push(e);
        }
        if let Some(t) = side.truth {
            if let Some(n) = t.non_finite() {
                return Err(fmt_err(&json, format!("truth.{n} is not finite")));
            }
            let a = get("truth")?;
            if a != t.to_array().to_vec() {
                return Err(mismatch(
                    "the sidecar's truth differs from the archive's `truth`".into(),
                ));
            }
        }
        Ok(Dataset {
            experiments,
            seed: side.seed,
            truth: side.truth,
            extra: side.extra,
        })
    }

    /// Checks that the dataset holds exactly the experiments `expected` (the study's), in any
    /// order; the message lists what is missing and what is left over.
    pub fn check_names(&self, expected: &[String]) -> Result<(), DataError> {
        let have: BTreeSet<&str> = self.experiments.iter().map(|e| e.name.as_str()).collect();
        let want: BTreeSet<&str> = expected.iter().map(|s| s.as_str()).collect();
        if have == want {
            return Ok(());
        }
        let list = |s: Vec<&&str>| {
            s.iter()
                .map(|x| format!("`{x}`"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let missing = list(want.difference(&have).collect());
        let surplus = list(have.difference(&want).collect());
        let mut msg = format!(
            "the dataset's experiments ({}) are not the study's ({})",
            list(have.iter().collect()),
            list(want.iter().collect())
        );
        if !missing.is_empty() {
            msg += &format!("; missing from the dataset: {missing}");
        }
        if !surplus.is_empty() {
            msg += &format!("; not in the study: {surplus}");
        }
        Err(DataError::Names { msg })
    }
}

/// The last object key (`"name":`) before line `line`, column `col` (1-based, as serde_json
/// reports errors) of `text`, so that a type error names its field.
fn json_key_before(text: &str, line: usize, col: usize) -> Option<String> {
    let start: usize = text
        .split_inclusive('\n')
        .take(line.saturating_sub(1))
        .map(str::len)
        .sum();
    let end = (start + col).min(text.len());
    let prefix = text.get(..end)?;
    let mut rest = prefix;
    while let Some(c) = rest.rfind(':') {
        let before = rest[..c].trim_end();
        if let Some(b) = before.strip_suffix('"')
            && let Some(q) = b.rfind('"')
        {
            return Some(b[q + 1..].to_string());
        }
        rest = &rest[..c];
    }
    None
}

/// A CSV file of named numeric columns.
#[derive(Debug, Clone, PartialEq)]
pub struct CsvTable {
    pub names: Vec<String>,
    pub columns: Vec<Vec<f64>>,
    /// The 1-based line number of each data row in the file (the header and comments count).
    pub lines: Vec<usize>,
}

impl CsvTable {
    /// The column called `name`.
    pub fn column(&self, name: &str) -> Option<&Vec<f64>> {
        self.names
            .iter()
            .position(|n| n == name)
            .map(|i| &self.columns[i])
    }

    /// The sample rate from a time column `t`, checking that it is uniformly spaced (see
    /// [`uniform_rate`]); `None` without a column `t`.
    pub fn sample_rate(&self) -> Result<Option<f64>, String> {
        let Some(t) = self.column("t") else {
            return Ok(None);
        };
        uniform_rate(t, "t", |k| format!("line {}", self.lines[k])).map(Some)
    }
}

/// Memory a CSV file of `len` bytes can need once read, as a multiple of its size: the text,
/// plus at most one 8-byte value and one 8-byte line number per 2 bytes of text (every value
/// takes at least a digit and a separator).
const CSV_MEMORY_FACTOR: u64 = 9;

/// Largest magnitude of a sample read from a user's file: beyond it its square (a power, a
/// periodogram) overflows, and the run failed later with NaN in messages that named no file.
pub const MAX_SAMPLE: f64 = 1e150;

/// Why the sample `v` of a user's file cannot be read, if it cannot (`missing` says how
/// the format marks a missing sample). NaN is a missing sample, not a problem.
pub fn sample_problem(v: f64, missing: &str) -> Option<String> {
    if v.is_infinite() {
        Some(format!(
            "{v} is not finite (infinities are not allowed; {missing} marks a missing sample)"
        ))
    } else if v.abs() > MAX_SAMPLE {
        Some(format!(
            "{v:e} is beyond ±{MAX_SAMPLE:e}, not a measurement in SI units (its square, a power, \
             overflows); {missing} marks a missing sample"
        ))
    } else {
        None
    }
}

/// Reads a CSV file with a header row of column names and numeric rows. Lines starting with `#`
/// and blank lines are skipped; header names and values may be enclosed in double quotes; a
/// UTF-8 byte-order mark and `\r\n` line ends are accepted. Errors name the file, the line
/// (1-based, counting the header and comments) and the column. The file's size is checked
/// against the memory budget ([`crate::data::memory_budget`]) before it is read.
pub fn read_csv(path: &Path) -> Result<CsvTable, DataError> {
    super::infile::check(path).map_err(io_err(path))?;
    let len = std::fs::metadata(path).map_err(io_err(path))?.len();
    check_budget(
        path,
        &format!("reading this {len}-byte CSV file"),
        len.saturating_mul(CSV_MEMORY_FACTOR),
    )?;
    let bytes = std::fs::read(path).map_err(io_err(path))?;
    parse_csv(path, &bytes)
}

/// Parses the contents of a CSV file as [`read_csv`] does; `file` names it in messages.
pub fn parse_csv(file: &Path, bytes: &[u8]) -> Result<CsvTable, DataError> {
    let path = file;
    let text = std::str::from_utf8(bytes).map_err(|e| {
        let line = bytes[..e.valid_up_to()]
            .iter()
            .filter(|&&b| b == b'\n')
            .count()
            + 1;
        fmt_err(
            path,
            format!(
                "line {line}: not UTF-8 text (byte {}); save the file as UTF-8 or ASCII",
                e.valid_up_to()
            ),
        )
    })?;
    // a byte-order mark (spreadsheets write one) is not part of the first column's name
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
    let (hl, header) = lines.next().ok_or_else(|| {
        fmt_err(
            path,
            "empty file: expected a header row of column names, then one row per sample",
        )
    })?;
    let no_cr = |ln: usize, line: &str| {
        if line.contains('\r') {
            Err(fmt_err(
                path,
                format!(
                    "line {}: a carriage return inside the line (old Mac line ends?); end lines with `\\n` or `\\r\\n`",
                    ln + 1
                ),
            ))
        } else {
            Ok(())
        }
    };
    no_cr(hl, header)?;
    let mut names: Vec<String> = Vec::new();
    for (j, cell) in header.split(',').enumerate() {
        let n = unquote(cell)
            .map_err(|m| fmt_err(path, format!("line {}, column {}: {m}", hl + 1, j + 1)))?;
        names.push(n.trim().to_string());
    }
    if let Some(j) = names
        .iter()
        .position(|n| n.is_empty() || n.parse::<f64>().is_ok())
    {
        let shown: String = header.chars().take(80).collect();
        return Err(fmt_err(
            path,
            format!(
                "line {}, column {}: the first row must name the columns (e.g. `t,o1,o12,i1,i12`), got `{shown}`",
                hl + 1,
                j + 1
            ),
        ));
    }
    let mut seen: std::collections::HashMap<&str, usize> = std::collections::HashMap::new();
    for (j, n) in names.iter().enumerate() {
        if let Some(k) = seen.insert(n.as_str(), j) {
            return Err(fmt_err(
                path,
                format!(
                    "line {}: column `{n}` appears twice (columns {} and {}); column names must be unique",
                    hl + 1,
                    k + 1,
                    j + 1
                ),
            ));
        }
    }
    let mut columns = vec![Vec::new(); names.len()];
    let mut rows = Vec::new();
    for (ln, line) in lines {
        no_cr(ln, line)?;
        let n_cells = line.split(',').count();
        if n_cells != names.len() {
            return Err(fmt_err(
                path,
                format!(
                    "line {}: {n_cells} values for {} columns; every row needs one value per column (channels of different lengths? a decimal comma?)",
                    ln + 1,
                    names.len()
                ),
            ));
        }
        for (j, c) in line.split(',').enumerate() {
            let at = || format!("line {}, column `{}`", ln + 1, names[j]);
            let cell = unquote(c).map_err(|m| fmt_err(path, format!("{}: {m}", at())))?;
            let cell = cell.trim();
            // an empty cell or a NaN is a missing sample (a gap)
            let v: f64 = if cell.is_empty() {
                f64::NAN
            } else {
                cell.parse().map_err(|_| {
                    let shown: String = cell.chars().take(40).collect();
                    fmt_err(path, format!("{}: `{shown}` is not a number", at()))
                })?
            };
            if let Some(why) = sample_problem(v, "NaN or an empty cell") {
                return Err(fmt_err(path, format!("{}: {why}", at())));
            }
            columns[j].push(v);
        }
        rows.push(ln + 1);
    }
    if rows.is_empty() {
        return Err(fmt_err(
            path,
            format!("no data rows after the header (line {})", hl + 1),
        ));
    }
    Ok(CsvTable {
        names,
        columns,
        lines: rows,
    })
}

/// A CSV cell without its enclosing double quotes, if it has a pair; a lone quote is an error
/// (a quoted field holding a comma, which this reader does not split on).
fn unquote(cell: &str) -> Result<&str, String> {
    let t = cell.trim();
    let inner = t
        .strip_prefix('"')
        .and_then(|r| r.strip_suffix('"'))
        .unwrap_or(t);
    if inner.contains('"') {
        let shown: String = t.chars().take(40).collect();
        return Err(format!(
            "unbalanced or embedded quote in `{shown}`: quote a whole field or none of it, and use `.` as the decimal separator (fields holding commas are not supported)"
        ));
    }
    Ok(inner)
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
                extra: BTreeMap::new(),
                noise_extra: BTreeMap::new(),
                gaps: Vec::new(),
                noise_gaps: Vec::new(),
                known_in_gaps: Vec::new(),
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
        // NaN and an empty cell are missing samples, an infinity is an error
        std::fs::write(&p, "t,o1,o12\n0,1,2\n0.1,nan,3\n0.2,4,\n").unwrap();
        let t = read_csv(&p).unwrap();
        assert!(t.columns[1][1].is_nan() && t.columns[2][2].is_nan());
        std::fs::write(&p, "t,o1\n0,1\n0.1,-inf\n").unwrap();
        let e = read_csv(&p).unwrap_err().to_string();
        assert!(
            e.contains("d.csv") && e.contains("line 3") && e.contains("o1"),
            "{e}"
        );
        std::fs::write(&p, "t,o1\n0,1\n0.1,1e308\n").unwrap();
        let e = read_csv(&p).unwrap_err().to_string();
        assert!(
            e.contains("d.csv") && e.contains("line 3, column `o1`") && e.contains("beyond ±1e150"),
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
        let s: String = (0..20).map(|k| format!("{k}\n")).collect();
        std::fs::write(&n, format!("o1\n{s}")).unwrap();
        let err = ExperimentData::from_csv("x", &d, &n, None)
            .unwrap_err()
            .to_string();
        assert!(err.contains("o12"), "{err}");
    }

    fn with_extras() -> Dataset {
        let mut d = sample();
        let e = &mut d.experiments[0];
        e.extra.insert("g1".into(), vec![0.5; 64]);
        e.extra.insert("g2".into(), vec![-0.5; 64]);
        e.noise_extra.insert("g1".into(), vec![0.25; 32]);
        d
    }

    #[test]
    fn extra_channels_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let d = with_extras();
        let (npz, json) = d.write(dir.path()).unwrap();
        let side: Sidecar = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        assert_eq!(side.experiments[0].channels, vec!["g1", "g2"]);
        assert_eq!(side.experiments[0].noise_channels, vec!["g1"]);
        let mut z = ndarray_npy::NpzReader::new(std::fs::File::open(&npz).unwrap()).unwrap();
        let names = z.names().unwrap();
        assert!(names.contains(&"inv1.g2".to_string()), "{names:?}");
        assert!(names.contains(&"inv1.noise_g1".to_string()), "{names:?}");
        // read back from the directory, the json or the npz
        for p in [dir.path().to_path_buf(), json, npz] {
            let back = Dataset::read(&p).unwrap();
            assert_eq!(back, d);
            let e = &back.experiments[0];
            assert_eq!(e.channel("g2").unwrap()[0], -0.5);
            assert_eq!(e.noise_channel("g1").unwrap().len(), 32);
            assert_eq!(e.noise_channel("g2"), None);
            assert_eq!(e.noise_channel("i1"), None);
        }
    }

    #[test]
    fn torn_pair_is_refused_and_old_pairs_load() {
        let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
        let d = sample();
        let (npz, json) = d.write(a.path()).unwrap();
        let side: Sidecar = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        let bytes = std::fs::read(&npz).unwrap();
        assert_eq!(
            side.npz_digest,
            Some(NpzDigest::new(bytes.len() as u64, Fnv1a::of(&bytes)))
        );
        // from the bytes, as from the files
        let text = std::fs::read(&json).unwrap();
        assert_eq!(Dataset::from_bytes(&text, &bytes).unwrap(), d);
        // another run's archive (same shapes, other numbers) beside this sidecar
        let mut other = sample();
        other.experiments[0].o[0][5] = 1.25;
        let (npz_b, _) = other.write(b.path()).unwrap();
        std::fs::copy(&npz_b, &npz).unwrap();
        let e = Dataset::read(a.path()).unwrap_err().to_string();
        assert!(
            e.contains(&format!(
                "{}: does not match {}",
                npz.display(),
                json.display()
            )) && e.contains("written by a different run; rerun `occam simulate`"),
            "{e}"
        );
        let e = Dataset::from_bytes(&text, &std::fs::read(&npz_b).unwrap())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("dataset.npz: does not match dataset.json"),
            "{e}"
        );
        // a sidecar written before digests existed: read, and still checked field by field
        let mut v: serde_json::Value = serde_json::from_slice(&text).unwrap();
        assert!(v.as_object_mut().unwrap().remove("npz_digest").is_some());
        std::fs::write(&json, serde_json::to_string_pretty(&v).unwrap()).unwrap();
        assert_eq!(Dataset::read(a.path()).unwrap(), other);
        std::fs::write(&npz, &bytes).unwrap();
        assert_eq!(Dataset::read(a.path()).unwrap(), d);
        v["experiments"][0]["fs"] = 11.0.into();
        std::fs::write(&json, serde_json::to_string_pretty(&v).unwrap()).unwrap();
        let e = Dataset::read(a.path()).unwrap_err().to_string();
        assert!(e.contains("disagree") && e.contains("fs = 11 Hz"), "{e}");
        // a malformed digest is named
        v["npz_digest"] = serde_json::json!({"bytes": "x"});
        std::fs::write(&json, serde_json::to_string_pretty(&v).unwrap()).unwrap();
        let e = Dataset::read(a.path()).unwrap_err().to_string();
        assert!(e.contains("dataset.json") && e.contains("sidecar"), "{e}");
    }

    #[test]
    fn sidecar_type_errors_name_the_field() {
        let text = "{\n  \"experiments\": [\n    {\"name\": \"a\", \"fs\": 1.0, \"n_samples\": 1e300}\n  ]\n}";
        let e = Dataset::parse_sidecar(Path::new("d.json"), text.as_bytes())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("d.json") && e.contains("(at `n_samples`)"),
            "{e}"
        );
        assert_eq!(
            json_key_before("{\"a\": 1, \"b\" : x", 1, 15),
            Some("b".into())
        );
        assert_eq!(json_key_before("[1, 2", 1, 5), None);
        assert_eq!(json_key_before("", 9, 9), None);
    }

    #[test]
    fn names_too_long_for_the_archive_are_errors() {
        let dir = tempfile::tempdir().unwrap();
        let mut d = sample();
        d.experiments[0].name = "x".repeat(70_000);
        let e = d.write(dir.path()).unwrap_err().to_string();
        assert!(
            e.contains("experiment name") && e.contains("70000 bytes"),
            "{e}"
        );
        assert!(check_channel_name(&"g".repeat(300)).is_err());
        assert!(check_channel_name(&"g".repeat(MAX_NAME_LEN)).is_ok());
    }

    #[test]
    fn csv_accepts_bom_crlf_and_quotes() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("d.csv");
        std::fs::write(&p, "\u{feff}\"t\",o1\r\n0,\"1.5\"\r\n0.5, 2 \r\n").unwrap();
        let t = read_csv(&p).unwrap();
        assert_eq!(t.names, vec!["t", "o1"]);
        assert_eq!(t.columns, vec![vec![0.0, 0.5], vec![1.5, 2.0]]);
        assert_eq!(t.lines, vec![2, 3]);
        assert_eq!(t.sample_rate().unwrap(), Some(2.0));
        for (text, want) in [
            ("t,o1\n0,\"1,5\"\n", "line 2: 3 values for 2 columns"),
            ("t,o1\n0,\"1.5\n", "line 2, column `o1`: unbalanced"),
            ("t,o1\r0,1\r", "line 1: a carriage return"),
            ("t,o1\n0,\u{feff}1\n", "line 2, column `o1`"),
        ] {
            let e = parse_csv(&p, text.as_bytes()).unwrap_err().to_string();
            assert!(e.contains("d.csv") && e.contains(want), "{text:?}: {e}");
        }
        let e = parse_csv(&p, b"t,o1\n0,1\n\xff,2\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 3: not UTF-8"), "{e}");
    }

    #[test]
    fn old_sidecar_without_channels_loads() {
        let dir = tempfile::tempdir().unwrap();
        let d = sample();
        let (_, json) = d.write(dir.path()).unwrap();
        let mut v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        let e = v["experiments"][0].as_object_mut().unwrap();
        assert!(e.remove("channels").is_some() && e.remove("noise_channels").is_some());
        std::fs::write(&json, serde_json::to_string_pretty(&v).unwrap()).unwrap();
        assert_eq!(Dataset::read(dir.path()).unwrap(), d);
    }

    /// Writes `d`, applies `edit` to its sidecar, and returns the read error.
    fn mismatch(d: &Dataset, edit: impl Fn(&mut serde_json::Value)) -> String {
        let dir = tempfile::tempdir().unwrap();
        let (_, json) = d.write(dir.path()).unwrap();
        let mut v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        edit(&mut v);
        std::fs::write(&json, serde_json::to_string_pretty(&v).unwrap()).unwrap();
        let e = Dataset::read(dir.path()).unwrap_err().to_string();
        assert!(
            e.contains("dataset.json") && e.contains("dataset.npz") && e.contains("disagree"),
            "{e}"
        );
        e
    }

    #[test]
    fn sidecar_and_archive_must_agree() {
        let d = with_extras();
        let e = mismatch(&d, |v| v["experiments"][0]["n_samples"] = 60.into());
        assert!(
            e.contains("n_samples = 60") && e.contains("64 samples"),
            "{e}"
        );
        let e = mismatch(&d, |v| v["experiments"][0]["n_noise_samples"] = 31.into());
        assert!(e.contains("n_noise_samples = 31"), "{e}");
        let e = mismatch(&d, |v| v["experiments"][0]["fs"] = 20.0.into());
        assert!(e.contains("fs = 20 Hz") && e.contains("inv1.fs"), "{e}");
        let e = mismatch(&d, |v| v["experiments"][0]["name"] = "inv2".into());
        assert!(e.contains("inv2."), "{e}");
        let e = mismatch(&d, |v| {
            v["experiments"].as_array_mut().unwrap().clear();
        });
        assert!(e.contains("experiment `inv1`"), "{e}");
        let e = mismatch(&d, |v| {
            v["experiments"][0]["channels"] = serde_json::json!(["g1"])
        });
        assert!(e.contains("inv1.g2"), "{e}");
        let e = mismatch(&d, |v| {
            v["experiments"][0]["channels"] = serde_json::json!(["g1", "g2", "g3"])
        });
        assert!(e.contains("inv1.g3"), "{e}");
        let e = mismatch(&d, |v| {
            v["experiments"][0]["noise_channels"] = serde_json::json!([])
        });
        assert!(e.contains("inv1.noise_g1"), "{e}");
        let e = mismatch(&d, |v| v["truth"]["d21"] = 2.5.into());
        assert!(e.contains("truth"), "{e}");
        let e = mismatch(&d, |v| v["truth"] = serde_json::Value::Null);
        assert!(e.contains("`truth`"), "{e}");
    }

    #[test]
    fn nonexistent_paths_are_errors() {
        let dir = tempfile::tempdir().unwrap();
        sample().write(dir.path()).unwrap();
        // a typo below a dataset directory must not load the parent's dataset
        for p in [
            dir.path().join("typo"),
            dir.path().join("typo/dataset.json"),
            dir.path().join("datset.npz"),
        ] {
            let e = Dataset::read(&p).unwrap_err().to_string();
            assert!(e.contains(&p.display().to_string()), "{e}");
            assert!(e.contains("cannot open the dataset"), "{e}");
        }
        // an existing file that is not a dataset, a directory without one
        let other = dir.path().join("notes.txt");
        std::fs::write(&other, "x").unwrap();
        let e = Dataset::read(&other).unwrap_err().to_string();
        assert!(
            e.contains("notes.txt") && e.contains("not a dataset"),
            "{e}"
        );
        let empty = dir.path().join("empty");
        std::fs::create_dir(&empty).unwrap();
        let e = Dataset::read(&empty).unwrap_err().to_string();
        assert!(
            e.contains("empty/dataset.json") && e.contains("no such file"),
            "{e}"
        );
        std::fs::remove_file(dir.path().join("dataset.npz")).unwrap();
        let e = Dataset::read(dir.path()).unwrap_err().to_string();
        assert!(
            e.contains("dataset.npz") && e.contains("no such file"),
            "{e}"
        );
    }

    #[test]
    fn check_names_lists_missing_and_surplus() {
        let d = sample();
        d.check_names(&["inv1".to_string()]).unwrap();
        let e = d
            .check_names(&["inv1".to_string(), "inv2".to_string()])
            .unwrap_err()
            .to_string();
        assert!(e.contains("missing from the dataset: `inv2`"), "{e}");
        let e = d.check_names(&["x".to_string()]).unwrap_err().to_string();
        assert!(
            e.contains("missing from the dataset: `x`") && e.contains("not in the study: `inv1`"),
            "{e}"
        );
    }

    #[test]
    fn validate_extra_channels() {
        let dir = tempfile::tempdir().unwrap();
        let p = Path::new("x.npz");
        let mut d = with_extras();
        d.experiments[0].extra.insert("g3".into(), vec![0.0; 63]);
        let e = d.write(dir.path()).unwrap_err().to_string();
        assert!(e.contains("`g3` has 63 samples") && e.contains("64"), "{e}");
        let mut e = with_extras().experiments.remove(0);
        e.noise_extra.insert("g9".into(), vec![0.0; 32]);
        let m = e.validate(p).unwrap_err().to_string();
        assert!(m.contains("`g9`") && m.contains("no fit-stretch"), "{m}");
        let mut e = with_extras().experiments.remove(0);
        e.extra.insert("noise_x".into(), vec![0.0; 64]);
        assert!(e.validate(p).unwrap_err().to_string().contains("reserved"));
        let mut e = with_extras().experiments.remove(0);
        e.extra.insert("o1".into(), vec![0.0; 64]);
        assert!(e.validate(p).unwrap_err().to_string().contains("fixed"));
        let mut e = with_extras().experiments.remove(0);
        e.noise_extra.get_mut("g1").unwrap()[3] = f64::INFINITY;
        let m = e.validate(p).unwrap_err().to_string();
        assert!(m.contains("`noise_g1` sample 3"), "{m}");
        // an absent fixed channel is fine, and not reported as present
        let mut e = with_extras().experiments.remove(0);
        e.i[1].clear();
        e.validate(p).unwrap();
        assert_eq!(e.channel("i12"), None);
        assert_eq!(e.channel_names(), vec!["o1", "o12", "i1", "g1", "g2"]);
    }
}
