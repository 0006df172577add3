//! The design search: candidate frequencies, the Asimov proxy of a design and the coordinate
//! search over segments.

use crate::config::design::{Baseline, Candidates, DesignOptions, MAX_CANDIDATES};
use crate::config::{NoiseSynthesis, Study};
use crate::evidence::{LaplaceOptions, laplace_fisher};
use crate::experiment::{ExperimentDesign, SineSegment, Waveform, ladder_freqs};
use crate::jobs::prepare::{default_start, likelihood_of, load_data};
use crate::likelihood::{NoiseSource, fisher_exact, fisher_scoring, fisher_scoring_unbounded};
use crate::nested::SubModel;
use serde::Serialize;

/// Errors of the design search, naming the field or stage and the fix.
#[derive(Debug, thiserror::Error)]
pub enum DesignError {
    #[error("{file}: `design.{field}`: {msg}")]
    Config {
        file: String,
        field: String,
        msg: String,
    },
    #[error("{0}")]
    Proxy(String),
    #[error("{0}")]
    Io(String),
}

/// A validated `[design]` with the index of the true model.
#[derive(Debug, Clone, PartialEq)]
pub struct DesignPlan {
    pub options: DesignOptions,
    /// Index of `true_model` in `study.select_models`.
    pub true_index: usize,
    pub candidates: Vec<f64>,
}

impl DesignOptions {
    /// Checks every field against the study; errors name the field and the fix.
    pub fn validate(&self, study: &Study) -> Result<DesignPlan, DesignError> {
        let bad = |field: &str, msg: String| DesignError::Config {
            file: study.source.clone(),
            field: field.into(),
            msg,
        };
        if study.select_models.len() < 2 {
            return Err(bad(
                "true_model",
                "a design separates competing models: add at least two [[select.model]] tables"
                    .into(),
            ));
        }
        let true_index = study
            .select_models
            .iter()
            .position(|m| m.name == self.true_model)
            .ok_or_else(|| {
                bad(
                    "true_model",
                    format!(
                        "`{}` is not a [[select.model]] name; the names are {:?}",
                        self.true_model,
                        study
                            .select_models
                            .iter()
                            .map(|m| &m.name)
                            .collect::<Vec<_>>()
                    ),
                )
            })?;
        if self.channels.is_empty() {
            return Err(bad(
                "channels",
                "name at least one guidance channel (\"x1\", \"x12\")".into(),
            ));
        }
        for (k, c) in self.channels.iter().enumerate() {
            if c != "x1" && c != "x12" {
                return Err(bad(
                    "channels",
                    format!("`{c}`: the guidance channels are \"x1\" and \"x12\""),
                ));
            }
            if self.channels[..k].contains(c) {
                return Err(bad("channels", format!("`{c}` is listed twice")));
            }
        }
        if !(1..=64).contains(&self.segments) {
            return Err(bad(
                "segments",
                format!("must be in 1..=64 (got {})", self.segments),
            ));
        }
        let fs = 10.0;
        if !(self.segment_duration.is_finite() && self.segment_duration * fs >= 64.0) {
            return Err(bad(
                "segment_duration",
                format!(
                    "must be a duration of at least 6.4 s (64 samples at 10 Hz); got {}",
                    self.segment_duration
                ),
            ));
        }
        if !(self.gap.is_finite() && self.gap >= 0.0) {
            return Err(bad(
                "gap",
                format!("must be a duration ≥ 0 s (got {})", self.gap),
            ));
        }
        if !(self.amplitude.is_finite() && self.amplitude > 0.0) {
            return Err(bad(
                "amplitude",
                format!("must be an amplitude > 0 m (got {})", self.amplitude),
            ));
        }
        if let Some(a) = self.max_accel
            && !(a.is_finite() && a > 0.0)
        {
            return Err(bad(
                "max_accel",
                format!("must be an acceleration > 0 m s⁻² (got {a})"),
            ));
        }
        if self.max_passes == 0 {
            return Err(bad("max_passes", "must be at least 1".into()));
        }
        if let Candidates::LogGrid { from, to, points } = &self.candidates
            && !(*points >= 1 && from.is_finite() && *from > 0.0 && to.is_finite() && to >= from)
        {
            return Err(bad(
                "candidates",
                format!(
                    "`{{ from, to, points }}` needs 0 < from ≤ to and points ≥ 1 (got from = {from}, to = {to}, points = {points})"
                ),
            ));
        }
        if let Candidates::LogGrid { points, .. } = &self.candidates
            && *points > MAX_CANDIDATES
        {
            return Err(bad(
                "candidates",
                format!(
                    "`points` must be at most {MAX_CANDIDATES} (got {points}): every candidate is scored in every pass"
                ),
            ));
        }
        let candidates = self.candidates.freqs();
        let [lo, hi] = study.analysis.band;
        let nyq = 0.5 * fs;
        for &f in &candidates {
            if !(f.is_finite() && f > 0.0 && f < nyq) {
                return Err(bad(
                    "candidates",
                    format!("{f} Hz: every frequency must be in (0, {nyq}) Hz"),
                ));
            }
            if f < lo || f > hi {
                return Err(bad(
                    "candidates",
                    format!(
                        "{f} Hz is outside the fit band [{lo}, {hi}] Hz (`analysis.band`): the likelihood would not see it"
                    ),
                ));
            }
            if f * self.segment_duration < 1.0 {
                return Err(bad(
                    "candidates",
                    format!(
                        "{f} Hz makes less than one cycle in a segment of {} s: lengthen `segment_duration` or raise the frequency",
                        self.segment_duration
                    ),
                ));
            }
        }
        if candidates.is_empty() {
            return Err(bad("candidates", "give at least one frequency".into()));
        }
        if !self.allow_repeat && candidates.len() < self.segments {
            return Err(bad(
                "candidates",
                format!(
                    "{} candidates cannot fill {} segments without repeating a frequency: add candidates or set allow_repeat = true",
                    candidates.len(),
                    self.segments
                ),
            ));
        }
        if self.baseline == Baseline::Tn3045 && self.segments > 7 {
            return Err(bad(
                "segments",
                format!(
                    "the TN3045 baseline has 7 segments per channel; a budget of {} cannot be compared with it",
                    self.segments
                ),
            ));
        }
        if study.simulation.target_snr.is_some() {
            return Err(DesignError::Proxy(format!(
                "{}: `simulation.target_snr` would rescale every design to the same SNR, which defeats the amplitude budget of `[design]`: remove it",
                study.source
            )));
        }
        if study.analysis.dataset.is_some() || !study.data_sources.is_empty() {
            return Err(bad(
                "true_model",
                "a design is scored on simulated data: remove `analysis.dataset` and `[[experiment]] data`".into(),
            ));
        }
        Ok(DesignPlan {
            options: self.clone(),
            true_index,
            candidates,
        })
    }
}

impl DesignPlan {
    /// The amplitude a segment at `f` gets: the budget's cap, lowered by `max_accel`.
    pub fn amplitude_cap(&self, f: f64) -> f64 {
        let a = self.options.amplitude;
        match self.options.max_accel {
            Some(m) => a.min(m / (2.0 * std::f64::consts::PI * f).powi(2)),
            None => a,
        }
    }

    /// The experiments of a design: one per channel, `segs[c]` the (frequency, amplitude) of
    /// channel `c`'s segments; a channel with no segment gets no experiment.
    pub fn experiments(&self, segs: &[Vec<(f64, f64)>]) -> Vec<ExperimentDesign> {
        let o = &self.options;
        self.options
            .channels
            .iter()
            .zip(segs)
            .filter(|(_, s)| !s.is_empty())
            .map(|(ch, s)| {
                let train = Waveform::SineTrain {
                    segments: s
                        .iter()
                        .map(|&(freq, amplitude)| SineSegment {
                            freq,
                            amplitude,
                            duration: o.segment_duration,
                        })
                        .collect(),
                    gap: o.gap,
                };
                let mut d = ExperimentDesign::tn3045_x1();
                d.name = format!("design_{ch}");
                d.x1 = Waveform::None;
                d.x12 = Waveform::None;
                if ch == "x1" {
                    d.x1 = train;
                } else {
                    d.x12 = train;
                }
                d
            })
            .collect()
    }

    /// The baseline's segments per channel: the TN3045 ladder, its frequencies and its
    /// amplitude profile scaled from TN3045's 1 µm to the budget's `amplitude` (each then at
    /// most the cap), subsampled evenly to `segments` steps when the budget has fewer than 7.
    pub fn baseline(&self) -> Vec<Vec<(f64, f64)>> {
        let f = ladder_freqs();
        let n = self.options.segments;
        let idx: Vec<usize> = if n == 1 {
            vec![0]
        } else {
            (0..n)
                .map(|j| ((j * 6) as f64 / (n - 1) as f64).round() as usize)
                .collect()
        };
        self.options
            .channels
            .iter()
            .map(|ch| {
                let d = if ch == "x1" {
                    ExperimentDesign::tn3045_x1()
                } else {
                    ExperimentDesign::tn3045_x12()
                };
                let w = if ch == "x1" { &d.x1 } else { &d.x12 };
                let amps: Vec<f64> = match w {
                    Waveform::SineTrain { segments, .. } => {
                        segments.iter().map(|s| s.amplitude).collect()
                    }
                    _ => unreachable!("the TN3045 designs are sine trains"),
                };
                let k = self.options.amplitude / 1e-6;
                idx.iter()
                    .map(|&j| (f[j], (k * amps[j]).min(self.amplitude_cap(f[j]))))
                    .collect()
            })
            .collect()
    }
}

/// The proxy's value for one design.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ProxyScore {
    /// `min` over the other models of `ln B(true, other)`: the design's decisiveness against
    /// its hardest competitor.
    pub ln_b: f64,
    /// `ln B(true, other)` per other model, by name.
    pub per_model: Vec<(String, f64)>,
    /// `ln Z` per model (Asimov Laplace–Fisher), in the `[[select.model]]` order.
    pub ln_z: Vec<f64>,
    /// Which Laplace variant each model used (`box` or `raw`).
    pub laplace: Vec<String>,
    /// ρ_opt of the design under the noise model (all experiments).
    pub rho_opt: f64,
}

/// The study with its experiments replaced by `experiments` (simulation seed and settings
/// kept); `noiseless` also switches to noiseless data analysed with the model noise CSD.
pub fn study_with(study: &Study, experiments: Vec<ExperimentDesign>, noiseless: bool) -> Study {
    let mut s = study.clone();
    s.experiment_names = experiments.iter().map(|e| e.name.clone()).collect();
    s.experiments = experiments;
    s.data_sources.clear();
    s.commanded.clear();
    if noiseless {
        s.simulation.noise = NoiseSynthesis::None;
        s.analysis.noise = NoiseSource::Model;
    }
    s
}

/// The Asimov proxy of a design (module docs): every competing model's Laplace–Fisher evidence
/// on noiseless data at the truth, and `ln B` of the true model against each other model.
pub fn asimov_score(
    study: &Study,
    plan: &DesignPlan,
    experiments: Vec<ExperimentDesign>,
) -> Result<ProxyScore, DesignError> {
    if experiments.is_empty() {
        return Err(DesignError::Proxy(
            "the design has no injection: give at least one segment".into(),
        ));
    }
    let s = study_with(study, experiments, true);
    let (dataset, _) = load_data(&s).map_err(|e| DesignError::Proxy(e.to_string()))?;
    let mut ln_z = Vec::new();
    let mut laplace = Vec::new();
    let mut rho = 0.0;
    for (k, m) in s.select_models.iter().enumerate() {
        let lik = likelihood_of(&s, m.spec.model, &dataset)
            .map_err(|e| DesignError::Proxy(format!("model `{}`: {e}", m.name)))?;
        let free = &m.spec.free;
        // start at the truth where the model has the true value (the MAP on Asimov data of
        // the true model), else at the study's default start
        let mut start = default_start(&s, &m.spec);
        let truth = crate::jobs::prepare::reference_point(&s, m.spec.model);
        for &i in free {
            let p = &s.models.priors[m.spec.model];
            let (lo, hi) = p.kinds()[i].bounds();
            if truth[i] >= lo && truth[i] <= hi {
                start[i] = truth[i];
            }
        }
        if k == plan.true_index {
            rho = lik.snr(&start);
        }
        let why = |e: String| DesignError::Proxy(format!("model `{}`: {e}", m.name));
        let map = fisher_scoring(&lik, &start, free, 1e-4, 200).map_err(|e| why(e.to_string()))?;
        let sub =
            SubModel::new(&lik, free.clone(), map.theta.clone()).map_err(|e| why(e.to_string()))?;
        let fv = |th: &[f64]| free.iter().map(|&i| th[i]).collect::<Vec<f64>>();
        let boxed = fisher_scoring_unbounded(&lik, &map.theta, free, 1e-4, 200)
            .ok()
            .and_then(|u| {
                let f = fisher_exact(&lik, &u.theta, free);
                laplace_fisher(&sub, &fv(&u.theta), &f, &LaplaceOptions::default()).ok()
            });
        let (z, kind) = match boxed {
            Some(e) => (e.ln_z, "box"),
            None => {
                let f = fisher_exact(&lik, &map.theta, free);
                let e = laplace_fisher(
                    &sub,
                    &fv(&map.theta),
                    &f,
                    &LaplaceOptions {
                        box_correction: false,
                        ..Default::default()
                    },
                )
                .map_err(|e| {
                    why(format!(
                        "Laplace–Fisher at the MAP: {e}; the design does not constrain this model's parameters: add segments or candidates"
                    ))
                })?;
                (e.ln_z, "raw")
            }
        };
        ln_z.push(z);
        laplace.push(kind.to_string());
    }
    let t = plan.true_index;
    let per_model: Vec<(String, f64)> = s
        .select_models
        .iter()
        .enumerate()
        .filter(|(k, _)| *k != t)
        .map(|(k, m)| (m.name.clone(), ln_z[t] - ln_z[k]))
        .collect();
    let ln_b = per_model
        .iter()
        .map(|(_, b)| *b)
        .fold(f64::INFINITY, f64::min);
    Ok(ProxyScore {
        ln_b,
        per_model,
        ln_z,
        laplace,
        rho_opt: rho,
    })
}

/// One move of the search: the design it tried and its proxy.
#[derive(Debug, Clone, Serialize)]
pub struct Trial {
    pub channel: String,
    pub slot: usize,
    pub freq: f64,
    pub amplitude: f64,
    /// The proxy, or why it could not be computed.
    pub ln_b: Option<f64>,
    pub note: Option<String>,
}

/// The search's result.
#[derive(Debug, Clone, Serialize)]
pub struct SearchResult {
    /// Chosen segments per channel (frequency Hz, amplitude m).
    pub chosen: Vec<Vec<(f64, f64)>>,
    pub chosen_score: ProxyScore,
    /// The start: the baseline's frequencies at the budget-cap amplitudes.
    pub start: Vec<Vec<(f64, f64)>>,
    pub start_score: ProxyScore,
    pub trials: Vec<Trial>,
    pub passes: usize,
}

/// Coordinate exchange on the proxy from the baseline's frequencies at the cap (module docs).
pub fn search(study: &Study, plan: &DesignPlan) -> Result<SearchResult, DesignError> {
    let start: Vec<Vec<(f64, f64)>> = plan
        .baseline()
        .into_iter()
        .map(|c| {
            c.into_iter()
                .map(|(f, _)| (f, plan.amplitude_cap(f)))
                .collect()
        })
        .collect();
    let start_score = asimov_score(study, plan, plan.experiments(&start)).map_err(|e| {
        DesignError::Proxy(format!(
            "the search starts from the baseline frequencies, whose proxy cannot be computed: {e}"
        ))
    })?;
    let mut cur = start.clone();
    let mut best = start_score.clone();
    let mut trials = Vec::new();
    let mut passes = 0;
    for _ in 0..plan.options.max_passes {
        passes += 1;
        let mut moved = false;
        for c in 0..cur.len() {
            for slot in 0..cur[c].len() {
                for &f in &plan.candidates {
                    if f == cur[c][slot].0 {
                        continue;
                    }
                    if !plan.options.allow_repeat
                        && cur[c]
                            .iter()
                            .enumerate()
                            .any(|(j, s)| j != slot && s.0 == f)
                    {
                        continue;
                    }
                    let mut trial = cur.clone();
                    trial[c][slot] = (f, plan.amplitude_cap(f));
                    // keep each train in ascending frequency (the order does not change the
                    // Fisher information much, and a canonical order avoids re-trying permutations)
                    trial[c].sort_by(|a, b| a.0.total_cmp(&b.0));
                    let r = asimov_score(study, plan, plan.experiments(&trial));
                    let (ln_b, note) = match &r {
                        Ok(s) => (Some(s.ln_b), None),
                        Err(e) => (None, Some(e.to_string())),
                    };
                    trials.push(Trial {
                        channel: plan.options.channels[c].clone(),
                        slot,
                        freq: f,
                        amplitude: plan.amplitude_cap(f),
                        ln_b,
                        note,
                    });
                    if let Ok(s) = r
                        && s.ln_b > best.ln_b + 1e-6
                    {
                        best = s;
                        cur = trial;
                        moved = true;
                    }
                }
            }
        }
        if !moved {
            break;
        }
    }
    Ok(SearchResult {
        chosen: cur,
        chosen_score: best,
        start,
        start_score,
        trials,
        passes,
    })
}

/// The seed of noise realisation `r` of a study with seed `seed`: SplitMix64 of
/// `seed + (r + 1)·0x9E3779B97F4A7C15`, so realisations are independent streams and
/// realisation `r` is the same whichever others run.
pub fn realisation_seed(seed: u64, r: usize) -> u64 {
    // the (r+1)-th output of a SplitMix64 stream started at `seed`
    crate::jobs::sweep::grid::mix(seed.wrapping_add((r as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)))
}
