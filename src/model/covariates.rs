//! What tells one experiment from another beyond its data: the stretch it was taken in and its
//! covariates (the stretch's time, a telemetry value such as a temperature). A model whose
//! parameters change between stretches reads them ([`crate::model::Model::specialise`]).

/// The stretch of one experiment and its covariates, by name.
///
/// ```
/// use occam::model::Covariates;
/// let c = Covariates::new(Some("s2"), &[("time", 86400.0), ("temperature", 21.3)]);
/// assert_eq!(c.get("temperature"), Some(21.3));
/// assert_eq!(c.get("pressure"), None);
/// ```
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Covariates {
    /// The stretch's name (`None`: the study groups no experiments in stretches).
    pub stretch: Option<String>,
    /// Covariate values by name, in the stretch's order (`time` first, in seconds).
    pub values: Vec<(String, f64)>,
    /// The experiment's name (`None`: not known, as for a model evaluated on no experiment),
    /// which a model with parameters of single experiments reads (modelled glitches,
    /// [`crate::model::glitch`]).
    pub experiment: Option<String>,
}

impl Covariates {
    /// Covariates of stretch `stretch` with values `values`.
    pub fn new(stretch: Option<&str>, values: &[(&str, f64)]) -> Self {
        Self {
            stretch: stretch.map(str::to_string),
            values: values.iter().map(|(k, v)| (k.to_string(), *v)).collect(),
            experiment: None,
        }
    }

    /// The value of covariate `name`.
    pub fn get(&self, name: &str) -> Option<f64> {
        self.values.iter().find(|(k, _)| k == name).map(|(_, v)| *v)
    }

    /// Whether there is no stretch and no covariate value (whatever the experiment).
    pub fn is_empty(&self) -> bool {
        self.stretch.is_none() && self.values.is_empty()
    }
}
