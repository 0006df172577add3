//! Parameters that change between stretches of data: a model's parameter shared by every
//! stretch (the default), free per stretch, or drifting linearly in a covariate of the stretch
//! (its time, or a telemetry value such as a temperature).
//!
//! ```toml
//! [[stretch]]
//! name = "s1"
//! time = 0.0                          # s: the covariate `time`
//! covariates = { temperature = 21.3 }
//!
//! [[model]]
//! kind = "drift"
//! name = "drifting"
//! of = "ltp"                          # any model defined before this one
//! linear = { w1sq = "time" }          # w1sq(t) = w1sq + (t − t̄)·dw1sq_dtime
//! per_stretch = ["w2sq"]              # w2sq_s1, w2sq_s2, …: one value per stretch
//! ```
//!
//! A linear parameter keeps its name for its value at the covariate's mean over the stretches
//! `x̄` (so that value and slope are uncorrelated when the stretches weigh alike) and gains a
//! slope `d<param>_d<covariate>` in the parameter's unit per unit of the covariate (per second
//! for `time`). A per-stretch parameter is replaced by `<param>_<stretch>`, one per stretch,
//! each with the parent parameter's default prior. Every parameter stays a plain parameter of
//! the model: fixing, priors, Fisher matrices, samplers and evidences are those of any model,
//! and the constant model is the drifting one with its slopes fixed at zero.
//!
//! The likelihood specialises the model to each experiment ([`Model::specialise`]): the
//! experiment's stretch and covariates turn the drift into a [`ReparamModel`] onto the parent.

use super::bin::Bin;
use super::covariates::Covariates;
use super::reparam::{Reparam, ReparamModel};
use super::traits::Model;
use num_complex::{Complex, Complex64};
use num_dual::Dual64;
use std::sync::Arc;

/// How one parent parameter changes between stretches.
#[derive(Debug, Clone, PartialEq)]
pub enum DriftRule {
    /// Linear in the named covariate of the stretch (`time` or a telemetry value).
    Linear(String),
    /// One free value per stretch.
    PerStretch,
}

/// How one parent parameter is formed from this model's θ.
#[derive(Debug, Clone, PartialEq)]
enum Slot {
    Shared(usize),
    /// This model's index of the parameter's value in each stretch, in the stretches' order.
    PerStretch(Vec<usize>),
    Linear {
        base: usize,
        slope: usize,
        covariate: String,
        reference: f64,
    },
}

/// A model whose parameters change between stretches (see the module docs).
#[derive(Debug, Clone)]
pub struct DriftModel {
    name: String,
    parent: Arc<dyn Model>,
    names: Vec<String>,
    units: Vec<String>,
    stretches: Vec<Covariates>,
    slots: Vec<Slot>,
    /// The model in each stretch, in order.
    in_stretch: Vec<ReparamModel>,
}

impl DriftModel {
    /// `parent` with `rules` (parent parameter, rule) over `stretches` (each with its name and
    /// covariates). Every stretch must have every covariate a rule names, and the covariate
    /// must vary between stretches.
    pub fn new(
        name: &str,
        parent: Arc<dyn Model>,
        stretches: Vec<Covariates>,
        rules: &[(String, DriftRule)],
    ) -> Result<Self, String> {
        let pn = parent.param_names();
        let pu = parent.param_units();
        if rules.is_empty() {
            return Err(
                "no parameter drifts: give `linear = { <param> = \"time\" }` or `per_stretch = [\"<param>\"]`"
                    .into(),
            );
        }
        let snames: Vec<&str> = stretches
            .iter()
            .map(|s| s.stretch.as_deref().unwrap_or(""))
            .collect();
        if stretches.len() < 2 || snames.iter().any(|s| s.is_empty()) {
            return Err(format!(
                "a drifting model needs at least two named [[stretch]] tables (the study has {})",
                stretches.len()
            ));
        }
        for (p, _) in rules {
            if !pn.contains(p) {
                return Err(format!(
                    "`{p}` is not a parameter of model `{}`; its parameters are {pn:?}",
                    parent.name()
                ));
            }
            if rules.iter().filter(|(q, _)| q == p).count() > 1 {
                return Err(format!("`{p}` has two drift rules; give it one"));
            }
        }
        let (mut names, mut units, mut slots) = (Vec::new(), Vec::new(), Vec::new());
        for (i, p) in pn.iter().enumerate() {
            let unit = pu.get(i).cloned().unwrap_or_default();
            match rules.iter().find(|(q, _)| q == p).map(|(_, r)| r) {
                None => {
                    slots.push(Slot::Shared(names.len()));
                    names.push(p.clone());
                    units.push(unit);
                }
                Some(DriftRule::PerStretch) => {
                    let first = names.len();
                    slots.push(Slot::PerStretch((first..first + snames.len()).collect()));
                    for s in &snames {
                        names.push(format!("{p}_{s}"));
                        units.push(unit.clone());
                    }
                }
                Some(DriftRule::Linear(cov)) => {
                    let mut xs = Vec::with_capacity(stretches.len());
                    for (s, c) in snames.iter().zip(&stretches) {
                        xs.push(c.get(cov).ok_or_else(|| {
                            format!(
                                "`{p}` drifts in `{cov}`, which stretch `{s}` does not give: add `{cov} = …` to its `covariates` (or use \"time\", the stretch's `time`)"
                            )
                        })?);
                    }
                    let lo = xs.iter().cloned().fold(f64::INFINITY, f64::min);
                    let hi = xs.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
                    if lo >= hi {
                        return Err(format!(
                            "`{p}` drifts in `{cov}`, which is {lo} in every stretch: a slope in it cannot be measured"
                        ));
                    }
                    let reference = xs.iter().sum::<f64>() / xs.len() as f64;
                    slots.push(Slot::Linear {
                        base: names.len(),
                        slope: names.len() + 1,
                        covariate: cov.clone(),
                        reference,
                    });
                    names.push(p.clone());
                    units.push(unit.clone());
                    names.push(format!("d{p}_d{cov}"));
                    units.push(match (cov.as_str(), unit.is_empty()) {
                        ("time", true) => "s⁻¹".into(),
                        ("time", false) => format!("{unit}/s"),
                        (_, true) => format!("per {cov}"),
                        (_, false) => format!("{unit} per {cov}"),
                    });
                }
            }
        }
        for (k, n) in names.iter().enumerate() {
            if names[..k].contains(n) {
                return Err(format!(
                    "two parameters of the drifting model are called `{n}`: rename a stretch or a parameter"
                ));
            }
        }
        let mut m = Self {
            name: name.into(),
            parent,
            names,
            units,
            stretches,
            slots,
            in_stretch: Vec::new(),
        };
        m.in_stretch = m
            .stretches
            .iter()
            .map(|c| m.at(c))
            .collect::<Result<_, _>>()?;
        Ok(m)
    }

    /// The parent's parameter names (the order of [`DriftModel::values_from_stretches`]'s
    /// input).
    pub fn parent_names(&self) -> &[String] {
        self.parent.param_names()
    }

    /// The stretches' names, in order.
    pub fn stretch_names(&self) -> Vec<String> {
        self.stretches
            .iter()
            .filter_map(|c| c.stretch.clone())
            .collect()
    }

    /// The parent's θ for this model's θ in the experiment with covariates `cov`; an error
    /// when `cov` names no stretch of the model or lacks a covariate it drifts in.
    pub fn parent_values(&self, theta: &[f64], cov: &Covariates) -> Result<Vec<f64>, String> {
        Ok(self.at(cov)?.expand(theta))
    }

    /// This model's θ from the parent's values in each stretch (`per_stretch[s]` in the
    /// parent's order, stretches in this model's order; NaN where unknown): a per-stretch
    /// parameter takes its stretch's value, a linear one the least-squares line through the
    /// stretches (exact when the values are linear in the covariate), a shared one the mean.
    /// What the truth of a simulation with a stretch-dependent truth is in this model's terms.
    pub fn values_from_stretches(&self, per_stretch: &[Vec<f64>]) -> Vec<f64> {
        let mut th = vec![f64::NAN; self.names.len()];
        if per_stretch.len() != self.stretches.len() {
            return th;
        }
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        for (p, slot) in self.slots.iter().enumerate() {
            let y: Vec<f64> = per_stretch.iter().map(|v| v[p]).collect();
            match slot {
                Slot::Shared(i) => th[*i] = mean(&y),
                Slot::PerStretch(idx) => {
                    for (&i, &v) in idx.iter().zip(&y) {
                        th[i] = v;
                    }
                }
                Slot::Linear {
                    base,
                    slope,
                    covariate,
                    reference,
                } => {
                    let x: Vec<f64> = self
                        .stretches
                        .iter()
                        .map(|c| c.get(covariate).unwrap_or(f64::NAN) - reference)
                        .collect();
                    let ym = mean(&y);
                    let sxy: f64 = x.iter().zip(&y).map(|(a, b)| a * (b - ym)).sum();
                    let sxx: f64 = x.iter().map(|a| a * a).sum();
                    // the reference is the covariates' mean: the line passes through ȳ there
                    th[*base] = ym;
                    th[*slope] = sxy / sxx;
                }
            }
        }
        th
    }

    /// The map onto the parent for an experiment with covariates `cov`.
    fn at(&self, cov: &Covariates) -> Result<ReparamModel, String> {
        let stretch = || -> Result<usize, String> {
            let s = cov.stretch.as_deref().ok_or_else(|| {
                format!(
                    "model `{}` gives a parameter one value per stretch, and the experiment is in no stretch: give its [[experiment]] `stretch = …`",
                    self.name
                )
            })?;
            self.stretches
                .iter()
                .position(|c| c.stretch.as_deref() == Some(s))
                .ok_or_else(|| format!("stretch `{s}` is not one of model `{}`'s", self.name))
        };
        let mut terms = Vec::with_capacity(self.slots.len());
        for slot in &self.slots {
            terms.push(match slot {
                Slot::Shared(i) => (*i, None),
                Slot::PerStretch(idx) => (idx[stretch()?], None),
                Slot::Linear {
                    base,
                    slope,
                    covariate,
                    reference,
                } => {
                    let x = cov.get(covariate).ok_or_else(|| {
                        format!(
                            "model `{}` drifts in `{covariate}`, which the experiment does not give: put it in a [[stretch]] with that covariate",
                            self.name
                        )
                    })?;
                    (*base, Some((*slope, x - reference)))
                }
            });
        }
        ReparamModel::affine(
            &self.name,
            self.parent.clone(),
            self.names.clone(),
            self.units.clone(),
            Reparam::new(terms),
        )
    }

    /// The model in the first stretch: what [`Model::coefficients`] evaluates outside a
    /// likelihood, which specialises the model to every experiment.
    fn first(&self) -> &ReparamModel {
        &self.in_stretch[0]
    }
}

impl Model for DriftModel {
    fn name(&self) -> &str {
        &self.name
    }

    fn param_names(&self) -> &[String] {
        &self.names
    }

    fn param_units(&self) -> Vec<String> {
        self.units.clone()
    }

    /// A shared value, each stretch's value and a line's value at its reference keep the
    /// parent's limits; a slope has none.
    fn physical_limits(&self) -> Vec<[Option<f64>; 2]> {
        let base = self.slots.iter().enumerate().flat_map(|(p, s)| match s {
            Slot::Shared(j) | Slot::Linear { base: j, .. } => vec![(p, *j)],
            Slot::PerStretch(js) => js.iter().map(|&j| (p, j)).collect(),
        });
        super::reparam::carried_limits(self.names.len(), &self.parent.physical_limits(), base)
    }

    fn data_channels(&self) -> &[String] {
        self.parent.data_channels()
    }

    fn residual_channels(&self) -> &[String] {
        self.parent.residual_channels()
    }

    fn channel_units(&self) -> Vec<String> {
        self.parent.channel_units()
    }

    fn n_consts(&self) -> usize {
        self.parent.n_consts()
    }

    fn bin_consts(&self, f: f64, fs: f64, out: &mut [Complex64]) {
        self.parent.bin_consts(f, fs, out)
    }

    fn coefficients(&self, theta: &[f64], bin: &Bin, out: &mut [Complex64]) {
        self.first().coefficients(theta, bin, out)
    }

    fn coefficients_dual(&self, theta: &[Dual64], bin: &Bin, out: &mut [Complex<Dual64>]) {
        self.first().coefficients_dual(theta, bin, out)
    }

    fn data_noise_csd(&self, theta: &[f64], bin: &Bin, out: &mut [Complex64]) -> bool {
        self.first().data_noise_csd(theta, bin, out)
    }

    /// As the coefficients: the first stretch's (a glitch model over a drifting one asks
    /// here whether it can carry glitches; the likelihood uses the specialised models).
    fn force_response(&self, theta: &[f64], bin: &Bin, out: &mut [Complex64]) -> bool {
        self.first().force_response(theta, bin, out)
    }

    fn force_response_dual(
        &self,
        theta: &[Dual64],
        bin: &Bin,
        out: &mut [Complex<Dual64>],
    ) -> bool {
        self.first().force_response_dual(theta, bin, out)
    }

    /// Stable in every stretch.
    fn is_stable(&self, theta: &[f64]) -> bool {
        self.in_stretch.iter().all(|m| m.is_stable(theta))
    }

    /// Valid in every stretch.
    fn check(&self, theta: &[f64]) -> Result<(), String> {
        for (m, c) in self.in_stretch.iter().zip(&self.stretches) {
            m.check(theta)
                .map_err(|e| format!("in stretch `{}`: {e}", c.stretch.as_deref().unwrap_or("")))?;
        }
        Ok(())
    }

    fn specialise(&self, cov: &Covariates) -> Result<Option<Arc<dyn Model>>, String> {
        let m = self.at(cov)?;
        // a parent that drifts itself drifts too
        let m = match self.parent.specialise(cov)? {
            Some(p) => m.on(p),
            None => m,
        };
        Ok(Some(Arc::new(m)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::LtpModel;
    use crate::model::coefficients_at;

    fn stretches() -> Vec<Covariates> {
        (0..3)
            .map(|k| {
                Covariates::new(
                    Some(&format!("s{k}")),
                    &[("time", k as f64 * 1e5), ("temperature", 20.0 + k as f64)],
                )
            })
            .collect()
    }

    fn rule(p: &str, r: DriftRule) -> (String, DriftRule) {
        (p.to_string(), r)
    }

    fn ltp() -> Arc<dyn Model> {
        Arc::new(LtpModel::new("ltp", Default::default()))
    }

    #[test]
    fn names_units_and_the_map_in_each_stretch() {
        let m = DriftModel::new(
            "d",
            ltp(),
            stretches(),
            &[
                rule("w1sq", DriftRule::Linear("time".into())),
                rule("w2sq", DriftRule::PerStretch),
            ],
        )
        .unwrap();
        assert_eq!(
            m.param_names(),
            [
                "w1sq",
                "dw1sq_dtime",
                "w2sq_s0",
                "w2sq_s1",
                "w2sq_s2",
                "dt1",
                "dt2",
                "a_df",
                "a_sus",
                "d21"
            ]
        );
        assert_eq!(m.param_units()[1], "s⁻²/s");
        let th = [
            -1.3e-6, 1e-12, -1.8e-6, -1.9e-6, -2.0e-6, 0.2, 0.2, 0.82, 1.08, 4e-4,
        ];
        let s2 = &stretches()[2];
        // t̄ = 1e5: stretch 2 is 1e5 s after it
        let want = [-1.3e-6 + 1e-12 * 1e5, -2.0e-6, 0.2, 0.2, 0.82, 1.08, 4e-4];
        assert_eq!(m.parent_values(&th, s2).unwrap(), want);
        let sp = m.specialise(s2).unwrap().unwrap();
        assert_eq!(sp.param_names(), m.param_names());
        for f in [1e-3, 2e-2] {
            assert_eq!(
                coefficients_at(sp.as_ref(), &th, f, 10.0),
                coefficients_at(ltp().as_ref(), &want, f, 10.0)
            );
        }
    }

    /// A linear drift of the truth comes back exactly; per-stretch values as they are.
    #[test]
    fn values_from_stretches_invert_the_map() {
        let m = DriftModel::new(
            "d",
            ltp(),
            stretches(),
            &[
                rule("w1sq", DriftRule::Linear("time".into())),
                rule("w2sq", DriftRule::PerStretch),
            ],
        )
        .unwrap();
        let th = [
            -1.3e-6, 1e-12, -1.8e-6, -1.9e-6, -2.0e-6, 0.2, 0.2, 0.82, 1.08, 4e-4,
        ];
        let per: Vec<Vec<f64>> = stretches()
            .iter()
            .map(|c| m.parent_values(&th, c).unwrap())
            .collect();
        let back = m.values_from_stretches(&per);
        for (a, b) in back.iter().zip(&th) {
            assert!((a - b).abs() <= 1e-12 * b.abs(), "{back:?} vs {th:?}");
        }
    }

    #[test]
    fn drift_in_a_telemetry_covariate() {
        let m = DriftModel::new(
            "d",
            ltp(),
            stretches(),
            &[rule("a_df", DriftRule::Linear("temperature".into()))],
        )
        .unwrap();
        assert_eq!(m.param_names()[5], "da_df_dtemperature");
        assert_eq!(m.param_units()[5], "per temperature");
        let th = [-1.3e-6, -1.9e-6, 0.2, 0.2, 0.82, 0.01, 1.08, 4e-4];
        // stretch 0 is at 20 °C, one below the mean
        let v = m.parent_values(&th, &stretches()[0]).unwrap();
        assert!((v[4] - (0.82 - 0.01)).abs() < 1e-15, "{v:?}");
    }

    #[test]
    fn bad_drifts_are_refused_with_the_reason() {
        let e = |st: Vec<Covariates>, r: &[(String, DriftRule)]| {
            DriftModel::new("d", ltp(), st, r).unwrap_err()
        };
        assert!(e(stretches(), &[]).contains("no parameter drifts"));
        assert!(e(stretches(), &[rule("w9", DriftRule::PerStretch)]).contains("not a parameter"));
        assert!(
            e(
                stretches()[..1].to_vec(),
                &[rule("w1sq", DriftRule::PerStretch)]
            )
            .contains("at least two")
        );
        assert!(
            e(
                stretches(),
                &[rule("w1sq", DriftRule::Linear("pressure".into()))]
            )
            .contains("does not give")
        );
        let same: Vec<Covariates> = (0..2)
            .map(|k| Covariates::new(Some(&format!("s{k}")), &[("time", 5.0)]))
            .collect();
        assert!(
            e(same, &[rule("w1sq", DriftRule::Linear("time".into()))])
                .contains("cannot be measured")
        );
        assert!(
            e(
                stretches(),
                &[
                    rule("w1sq", DriftRule::PerStretch),
                    rule("w1sq", DriftRule::Linear("time".into()))
                ]
            )
            .contains("two drift rules")
        );
        let m = DriftModel::new(
            "d",
            ltp(),
            stretches(),
            &[rule("w1sq", DriftRule::PerStretch)],
        )
        .unwrap();
        let lost = m.specialise(&Covariates::default()).unwrap_err();
        assert!(lost.contains("in no stretch"), "{lost}");
        let other = Covariates::new(Some("s9"), &[]);
        assert!(m.specialise(&other).unwrap_err().contains("not one of"));
    }
}
