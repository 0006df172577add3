//! The model part of the study file: `[[model]]` definitions, the `[prior]` table keyed by
//! parameter name, and the (sub-)models that `[fit]` and `[[select.model]]` pick from them.
//!
//! ```toml
//! [[model]]                 # a built-in closed loop with a thruster pole (K14 §IV.A)
//! kind = "ltp"
//! name = "pole"
//! thruster = "pole"         # adds parameter f_df (Hz)
//! [prior]
//! f_df = { kind = "uniform", lo = 0.1, hi = 10.0 }
//! [fit]
//! model = "pole"
//! ```
//!
//! The built-in closed loop is always available as the model `ltp` (the study's masses and
//! OMS delay, no thruster response). The other kinds are `accel` (the acceleration domain,
//! [`crate::model::accel`]), `tied` (any model defined earlier with tied parameters,
//! [`crate::model::tied`]), `user` ([`crate::model::user`]), and `state_space` and
//! `transfer_matrix` ([`crate::model::state_space`]).

use super::error::ConfigError;
use super::limits::{DELAY_PARAMS, MAX_DELAY, MAX_NAME_LEN, check_delay};
use crate::model::state_space::{StateSpaceDef, StateSpaceModel, TransferMatrixDef};
use crate::model::user::{UserModel, UserModelDef};
use crate::model::{LoopResponse, LtpModel, LtpModelOptions, Model, ThrusterResponse};
use crate::prior::{Prior, PriorKind};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::sync::Arc;

/// The name of the built-in closed loop.
pub const BUILTIN_LTP: &str = "ltp";

/// A `[[model]]` table of kind `ltp`: the built-in closed loop with options.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LtpModelEntry {
    pub name: String,
    /// Extra factor on the drag-free actuation: `none`, `delay` (parameter `tau_df`) or `pole`
    /// (parameter `f_df`).
    #[serde(default)]
    pub thruster: ThrusterResponse,
    /// `continuous` (default) or `discrete`: the response of the digital loop at the data's
    /// sample rate (ZOH plant, Tustin controllers), for data from a discrete-time system such
    /// as `[simulation] method = "time"`.
    #[serde(default)]
    pub response: LoopResponse,
}

/// A `[[model]]` table of kind `accel`: the acceleration-domain model
/// ([`crate::model::accel`]). Unset keys take the study's values: `d21` from `[truth]`,
/// `tau_ifo` from `oms_delay`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AccelModelEntry {
    pub name: String,
    /// Actuators with a pole (parameters `f_o1`, `f_o2`); default true.
    pub pole: Option<bool>,
    /// Actuators with a delay (parameters `tau_c1`, `tau_c2`); default false.
    pub delay: Option<bool>,
    /// `exact` (default) or `fpsder` (LTPDA's stencil, with its error).
    pub derivative: Option<crate::model::accel::Derivative>,
    /// The five-point stencil's `m` (default 2/7).
    pub fpsder_m: Option<f64>,
    /// Known cross-talk δ21.
    pub d21: Option<f64>,
    /// Read-out delay τ_ifo (s), `o(t) = x(t − τ_ifo)`.
    pub tau_ifo: Option<f64>,
}

/// A `[[model]]` table of kind `tied`: model `of` with parameters tied together
/// ([`crate::model::tied`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TiedModelEntry {
    pub name: String,
    /// The parent model (defined earlier in the file, or `ltp`).
    pub of: String,
    /// Tied parameter = the parameter whose value it takes.
    pub tie: BTreeMap<String, String>,
}

/// A `[[model]]` table of kind `drift`: model `of` with parameters that change between
/// stretches ([`crate::model::drift`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DriftModelEntry {
    pub name: String,
    /// The parent model (defined earlier in the file, or `ltp`).
    pub of: String,
    /// Parameter = the covariate it is linear in (`"time"` or one of the stretches'
    /// `covariates`).
    #[serde(default)]
    pub linear: BTreeMap<String, String>,
    /// Parameters with one free value per stretch.
    #[serde(default)]
    pub per_stretch: Vec<String>,
}

/// A model's default prior per parameter name.
type DefaultPriors = Vec<(String, PriorKind)>;

/// A built model, its default priors and, for a drifting model, the model as such.
type Built = (
    Arc<dyn Model>,
    DefaultPriors,
    Option<Arc<crate::model::DriftModel>>,
);

/// A validated model definition (serialisable, so the resolved study can be written out).
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum ModelDef {
    /// The built-in closed loop.
    Ltp {
        name: String,
        options: LtpModelOptions,
    },
    /// The acceleration-domain model.
    Accel {
        name: String,
        options: crate::model::AccelOptions,
    },
    /// A model with tied parameters.
    Tied(TiedModelEntry),
    /// A model whose parameters change between stretches.
    Drift(DriftModelEntry),
    /// A model defined in the study file (see [`crate::model::user`]).
    User(UserModelDef),
    /// A state-space model defined in the study file (see [`crate::model::state_space`]).
    StateSpace(StateSpaceDef),
    /// A transfer matrix defined in the study file (see [`crate::model::state_space`]).
    TransferMatrix(TransferMatrixDef),
}

impl ModelDef {
    /// The model's name.
    pub fn name(&self) -> &str {
        match self {
            ModelDef::Ltp { name, .. } | ModelDef::Accel { name, .. } => name,
            ModelDef::Tied(t) => &t.name,
            ModelDef::Drift(d) => &d.name,
            ModelDef::User(d) => &d.name,
            ModelDef::StateSpace(d) => &d.name,
            ModelDef::TransferMatrix(d) => &d.name,
        }
    }

    /// Whether the model is written in the study file (`user`, `state_space`,
    /// `transfer_matrix`): its parameter names are the user's, with no built-in meaning (a
    /// `dt1` there is not the guidance delay), and it has no default priors.
    pub fn is_user_defined(&self) -> bool {
        matches!(
            self,
            ModelDef::User(_) | ModelDef::StateSpace(_) | ModelDef::TransferMatrix(_)
        )
    }

    /// The model and its default priors (none for user-defined models; a tied model's are its
    /// parent's; a drifting model's per-stretch values take the prior of the parent's
    /// parameter, from `[prior]` or the parent's defaults). `built` holds the models built so
    /// far, by name, for tied and drifting models' parents; `stretches` are the study's.
    fn build(
        &self,
        built: &[(String, Arc<dyn Model>, DefaultPriors)],
        prior: &BTreeMap<String, PriorKind>,
        stretches: &[crate::model::Covariates],
    ) -> Result<Built, String> {
        let parent_of = |of: &str| {
            built.iter().find(|(n, _, _)| *n == of).ok_or_else(|| {
                format!(
                    "`of = \"{of}\"` names no model defined before this one; the models so far are {:?}",
                    built.iter().map(|(n, _, _)| n).collect::<Vec<_>>()
                )
            })
        };
        Ok(match self {
            ModelDef::Ltp { name, options } => {
                let m = LtpModel::new(name, options.clone());
                let d = m.default_priors();
                (Arc::new(m), d, None)
            }
            ModelDef::Accel { name, options } => {
                options.validate()?;
                let m = crate::model::AccelModel::new(name, options.clone());
                let d = m.default_priors();
                (Arc::new(m), d, None)
            }
            ModelDef::Tied(t) => {
                let (_, parent, defaults) = parent_of(&t.of)?;
                let ties: Vec<(String, String)> =
                    t.tie.iter().map(|(a, b)| (a.clone(), b.clone())).collect();
                let m = crate::model::TiedModel::new(&t.name, parent.clone(), &ties)?;
                (Arc::new(m), defaults.clone(), None)
            }
            ModelDef::Drift(d) => {
                use crate::model::DriftRule;
                let (_, parent, defaults) = parent_of(&d.of)?;
                let mut rules: Vec<(String, DriftRule)> = d
                    .linear
                    .iter()
                    .map(|(p, c)| (p.clone(), DriftRule::Linear(c.clone())))
                    .collect();
                rules.extend(
                    d.per_stretch
                        .iter()
                        .map(|p| (p.clone(), DriftRule::PerStretch)),
                );
                let m = crate::model::DriftModel::new(
                    &d.name,
                    parent.clone(),
                    stretches.to_vec(),
                    &rules,
                )?;
                let mut own = defaults.clone();
                for p in &d.per_stretch {
                    let k = prior
                        .get(p)
                        .or_else(|| defaults.iter().find(|(x, _)| x == p).map(|(_, k)| k));
                    for s in m.stretch_names() {
                        if let Some(k) = k {
                            own.push((format!("{p}_{s}"), *k));
                        }
                    }
                }
                let m = Arc::new(m);
                (m.clone(), own, Some(m))
            }
            ModelDef::User(def) => (Arc::new(UserModel::new(def)?), Vec::new(), None),
            ModelDef::StateSpace(def) => (Arc::new(StateSpaceModel::new(def)?), Vec::new(), None),
            ModelDef::TransferMatrix(def) => {
                let user = crate::model::state_space::to_user_def(def)?;
                let m =
                    UserModel::new(&user).map_err(|e| crate::model::state_space::user_error(&e))?;
                (Arc::new(m), Vec::new(), None)
            }
        })
    }
}

/// Every model of a study with its validated prior.
#[derive(Debug, Clone, Serialize)]
pub struct ModelSet {
    pub defs: Vec<ModelDef>,
    #[serde(skip)]
    pub models: Vec<Arc<dyn Model>>,
    #[serde(skip)]
    pub priors: Vec<Prior>,
    /// The drifting models (`kind = "drift"`) as such, by index (`None` for the others): their
    /// truth is read from the stretches' ([`crate::model::DriftModel::values_from_stretches`]).
    #[serde(skip)]
    pub drifts: Vec<Option<Arc<crate::model::DriftModel>>>,
}

impl PartialEq for ModelSet {
    fn eq(&self, o: &Self) -> bool {
        self.defs == o.defs && self.priors == o.priors
    }
}

impl ModelSet {
    /// The index of the model called `name`.
    pub fn index(&self, name: &str) -> Option<usize> {
        self.defs.iter().position(|d| d.name() == name)
    }

    /// The names of all models.
    pub fn names(&self) -> Vec<String> {
        self.defs.iter().map(|d| d.name().to_string()).collect()
    }

    /// Every parameter name of every model, sorted, once each.
    pub fn all_param_names(&self) -> Vec<String> {
        let mut all: Vec<String> = self
            .models
            .iter()
            .flat_map(|m| m.param_names().iter().cloned())
            .collect();
        all.sort();
        all.dedup();
        all
    }

    /// Parses the `[[model]]` tables (plus the built-in `ltp` unless one is called that),
    /// builds every model and its prior from `[prior]` and the model's defaults.
    pub fn resolve(
        tables: &[toml::Table],
        prior: &BTreeMap<String, PriorKind>,
        ltp_defaults: &LtpModelOptions,
        accel_defaults: &crate::model::AccelOptions,
        (check_freqs, check_fs): (&[f64], f64),
        stretches: &[crate::model::Covariates],
        file: &str,
    ) -> Result<ModelSet, ConfigError> {
        let bad = |field: String, msg: String| ConfigError::Invalid {
            file: file.into(),
            field,
            msg,
        };
        let mut defs = Vec::new();
        for (k, t) in tables.iter().enumerate() {
            let at = format!("model[{k}]");
            let mut t = t.clone();
            let kind = match t.remove("kind") {
                Some(toml::Value::String(s)) => s,
                Some(v) => {
                    return Err(bad(
                        format!("{at}.kind"),
                        format!(
                            "must be a string such as \"ltp\", \"user\" or \"state_space\" (got {v})"
                        ),
                    ));
                }
                None => {
                    return Err(bad(
                        format!("{at}.kind"),
                        "missing: say kind = \"ltp\" (the built-in closed loop), kind = \"user\" or kind = \"state_space\" (a model defined in this file)".into(),
                    ));
                }
            };
            let parse_err = |e: toml::de::Error| bad(at.clone(), e.message().to_string());
            let def = match kind.as_str() {
                "ltp" => {
                    let e: LtpModelEntry = t.try_into().map_err(parse_err)?;
                    ModelDef::Ltp {
                        name: e.name,
                        options: LtpModelOptions {
                            thruster: e.thruster,
                            response: e.response,
                            ..ltp_defaults.clone()
                        },
                    }
                }
                "accel" => {
                    let e: AccelModelEntry = t.try_into().map_err(parse_err)?;
                    let d = accel_defaults;
                    ModelDef::Accel {
                        name: e.name,
                        options: crate::model::AccelOptions {
                            pole: e.pole.unwrap_or(d.pole),
                            delay: e.delay.unwrap_or(d.delay),
                            derivative: e.derivative.unwrap_or(d.derivative),
                            fpsder_m: e.fpsder_m.unwrap_or(d.fpsder_m),
                            d21: e.d21.unwrap_or(d.d21),
                            tau_ifo: e.tau_ifo.unwrap_or(d.tau_ifo),
                        },
                    }
                }
                "tied" => ModelDef::Tied(t.try_into().map_err(parse_err)?),
                "drift" => ModelDef::Drift(t.try_into().map_err(parse_err)?),
                "user" => ModelDef::User(t.try_into().map_err(parse_err)?),
                "state_space" => ModelDef::StateSpace(t.try_into().map_err(parse_err)?),
                "transfer_matrix" => ModelDef::TransferMatrix(t.try_into().map_err(parse_err)?),
                other => {
                    return Err(bad(
                        format!("{at}.kind"),
                        format!(
                            "unknown model kind `{other}`; the kinds are \"ltp\", \"accel\", \"tied\", \"drift\", \"user\", \"state_space\" and \"transfer_matrix\""
                        ),
                    ));
                }
            };
            check_name(def.name()).map_err(|m| bad(format!("{at}.name"), m))?;
            if defs.iter().any(|d: &ModelDef| d.name() == def.name()) {
                return Err(bad(
                    format!("{at}.name"),
                    format!("`{}` must be unique", def.name()),
                ));
            }
            if let ModelDef::Accel { options, .. } = &def
                && options.tau_ifo > MAX_DELAY
            {
                return Err(bad(
                    format!("{at}.tau_ifo"),
                    format!(
                        "must be a delay in [0, {}] s (got {})",
                        MAX_DELAY, options.tau_ifo
                    ),
                ));
            }
            defs.push(def);
        }
        if !defs.iter().any(|d| d.name() == BUILTIN_LTP) {
            defs.insert(
                0,
                ModelDef::Ltp {
                    name: BUILTIN_LTP.into(),
                    options: ltp_defaults.clone(),
                },
            );
        }
        let mut models = Vec::new();
        let mut priors = Vec::new();
        let mut drifts = Vec::new();
        let mut built: Vec<(String, Arc<dyn Model>, DefaultPriors)> = Vec::new();
        for d in &defs {
            let at = match tables
                .iter()
                .position(|t| t.get("name").and_then(|v| v.as_str()) == Some(d.name()))
            {
                Some(i) => format!("model[{i}]"),
                None => format!("model.{}", d.name()),
            };
            let (m, defaults, drift) = d
                .build(&built, prior, stretches)
                .map_err(|e| bad(at.clone(), e))?;
            drifts.push(drift);
            built.push((d.name().to_string(), m.clone(), defaults.clone()));
            crate::model::validate_shape(m.as_ref())
                .map_err(|e| bad(format!("model.{}", d.name()), e))?;
            let mut kinds = Vec::new();
            for n in m.param_names() {
                let k = prior
                    .get(n)
                    .copied()
                    .or_else(|| defaults.iter().find(|(x, _)| x == n).map(|(_, k)| *k))
                    .ok_or_else(|| {
                        bad(
                            format!("prior.{n}"),
                            format!(
                                "parameter `{n}` of model `{}` has no prior; add e.g. `{n} = {{ kind = \"uniform\", lo = …, hi = … }}` to [prior]",
                                d.name()
                            ),
                        )
                    })?;
                kinds.push(k);
            }
            if !d.is_user_defined() {
                for (n, k) in m.param_names().iter().zip(&kinds) {
                    if !DELAY_PARAMS.contains(&n.as_str()) {
                        continue;
                    }
                    let (lo, hi) = k.bounds();
                    if !(lo >= 0.0 && hi <= MAX_DELAY) {
                        return Err(bad(
                            format!("prior.{n}"),
                            format!(
                                "`{n}` is a delay: its prior must lie in [0, {}] s (got bounds [{lo}, {hi}]); use a uniform or log-uniform box there",
                                MAX_DELAY
                            ),
                        ));
                    }
                }
            }
            let p = Prior::new(m.param_names().to_vec(), kinds).map_err(|e| {
                let field = match &e {
                    crate::prior::PriorError::Invalid { name, .. } => format!("prior.{name}"),
                    _ => "prior".into(),
                };
                bad(field, e.to_string())
            })?;
            models.push(m);
            priors.push(p);
        }
        let set = ModelSet {
            defs,
            models,
            priors,
            drifts,
        };
        // every parameter of a user-defined model must act on some coefficient, and a
        // state-space model must be stable at the prior centre
        for (k, d) in set.defs.iter().enumerate() {
            if !d.is_user_defined() {
                continue;
            }
            let centre: Vec<f64> = set.priors[k]
                .kinds()
                .iter()
                .map(PriorKind::centre)
                .collect();
            if let ModelDef::StateSpace(_) = d {
                set.models[k].check(&centre).map_err(|e| {
                    bad(
                        format!("model.{}", d.name()),
                        format!(
                            "{e}; checked at the prior centre ({}): centre the priors on a \
                             stable system",
                            fmt_point(set.models[k].param_names(), &centre)
                        ),
                    )
                })?;
            }
            if let ModelDef::User(_) = d {
                // a delay or pole frequency that is impossible at the centre (the sampler
                // would start there)
                set.models[k].check(&centre).map_err(|e| {
                    bad(
                        format!("model.{}", d.name()),
                        format!(
                            "{e}; checked at the prior centre ({}): centre the priors where every block is possible",
                            fmt_point(set.models[k].param_names(), &centre)
                        ),
                    )
                })?;
            }
            crate::model::check_finite(set.models[k].as_ref(), &centre, check_freqs, check_fs)
                .and_then(|()| {
                    crate::model::check_identifiable(
                        set.models[k].as_ref(),
                        &centre,
                        check_freqs,
                        check_fs,
                    )
                })
                .map_err(|e| {
                    bad(
                        format!("model.{}", d.name()),
                        format!(
                            "{e} (checked at the prior centre over {:.1e}–{:.1e} Hz)",
                            check_freqs[0],
                            check_freqs[check_freqs.len() - 1]
                        ),
                    )
                })?;
        }
        for n in prior.keys() {
            if !set.models.iter().any(|m| m.param_names().contains(n)) {
                return Err(bad(
                    format!("prior.{n}"),
                    format!(
                        "`{n}` is not a parameter of any model; the parameters are {:?}",
                        set.all_param_names()
                    ),
                ));
            }
        }
        Ok(set)
    }
}

/// `a = 1, b = 2` for messages.
pub fn fmt_point(names: &[String], values: &[f64]) -> String {
    names
        .iter()
        .zip(values)
        .map(|(n, v)| format!("{n} = {v}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Checks a model name (`[[model]]`, `[[select.model]]`): 1 to
/// [`MAX_NAME_LEN`] letters, digits or `_ - . +`, because names become keys
/// and file names of the outputs.
pub fn check_name(name: &str) -> Result<(), String> {
    let max = MAX_NAME_LEN;
    if name.is_empty()
        || name.chars().count() > max
        || !name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "_-.+".contains(c))
    {
        let shown: String = name.chars().take(40).collect();
        let more = if name.chars().count() > 40 {
            format!("… ({} characters)", name.chars().count())
        } else {
            String::new()
        };
        return Err(format!(
            "`{shown}{more}`: a name is 1 to {max} letters, digits, `_`, `-`, `.` or `+`"
        ));
    }
    Ok(())
}

/// A (sub-)model as written: which model, which parameters are free and the values of the
/// others.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelEntry {
    /// The model (default: the built-in `ltp`).
    pub model: Option<String>,
    /// Free parameter names (default: all of the model's).
    pub free: Option<Vec<String>>,
    /// Values of the parameters that are not free.
    #[serde(default)]
    pub fixed: BTreeMap<String, f64>,
}

/// A validated (sub-)model: the model's index in the [`ModelSet`], the free indices and the
/// full base vector (fixed values; free entries 0).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModelSpec {
    pub model: usize,
    pub free: Vec<usize>,
    pub base: Vec<f64>,
}

impl ModelEntry {
    /// Checks names, duplicates and that every parameter is either free or fixed (finite).
    pub fn resolve(&self, set: &ModelSet, file: &str, at: &str) -> Result<ModelSpec, ConfigError> {
        let bad = |field: String, msg: String| ConfigError::Invalid {
            file: file.into(),
            field,
            msg,
        };
        let mname = self.model.as_deref().unwrap_or(BUILTIN_LTP);
        let mi = set.index(mname).ok_or_else(|| {
            bad(
                format!("{at}model"),
                format!("unknown model `{mname}`; the models are {:?}", set.names()),
            )
        })?;
        let names = set.models[mi].param_names();
        let idx = |n: &str, field: String| {
            names.iter().position(|p| p == n).ok_or_else(|| {
                bad(
                    field,
                    format!(
                        "unknown parameter `{n}` of model `{mname}`; its parameters are {names:?}"
                    ),
                )
            })
        };
        let mut free = Vec::new();
        match &self.free {
            // no list: every parameter that is not fixed
            None => free
                .extend((0..names.len()).filter(|&i| !self.fixed.contains_key(names[i].as_str()))),
            Some(list) => {
                for (k, n) in list.iter().enumerate() {
                    let i = idx(n, format!("{at}free[{k}]"))?;
                    if free.contains(&i) {
                        return Err(bad(
                            format!("{at}free[{k}]"),
                            format!("`{n}` is listed twice"),
                        ));
                    }
                    free.push(i);
                }
            }
        }
        if free.is_empty() {
            return Err(bad(
                format!("{at}free"),
                "at least one parameter must be free".into(),
            ));
        }
        let mut base = vec![f64::NAN; names.len()];
        for (n, &v) in &self.fixed {
            let i = idx(n, format!("{at}fixed.{n}"))?;
            if free.contains(&i) {
                return Err(bad(
                    format!("{at}fixed.{n}"),
                    format!("`{n}` is both free and fixed; remove it from one of the lists"),
                ));
            }
            if !v.is_finite() {
                return Err(bad(
                    format!("{at}fixed.{n}"),
                    format!("must be finite (got {v})"),
                ));
            }
            if !set.defs[mi].is_user_defined() && DELAY_PARAMS.contains(&n.as_str()) {
                check_delay(v).map_err(|m| bad(format!("{at}fixed.{n}"), m))?;
            }
            let kind = set.priors[mi].kinds()[i];
            let (lo, hi) = kind.bounds();
            if !(v >= lo && v <= hi) {
                return Err(bad(
                    format!("{at}fixed.{n}"),
                    format!(
                        "the fixed value {v} is outside the prior of `{n}` ([{lo}, {hi}]): a fixed parameter must lie where its prior is positive; change the value or widen [prior].{n}"
                    ),
                ));
            }
            base[i] = v;
        }
        for (i, n) in names.iter().enumerate() {
            if !free.contains(&i) && base[i].is_nan() {
                return Err(bad(
                    format!("{at}fixed"),
                    format!(
                        "`{n}` is neither free nor fixed: add it to `free` or give `fixed.{n}`"
                    ),
                ));
            }
            if free.contains(&i) {
                base[i] = 0.0;
            }
        }
        Ok(ModelSpec {
            model: mi,
            free,
            base,
        })
    }
}
