//! `occam.Likelihood`: a study's likelihood of one model over its free parameters, built by the
//! same library calls as `occam fit` and `occam select`, for samplers written in Python.

use crate::occam_error;
use anyhow::Context;
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use occam::config::{ModelSpec, Study};
use occam::density::LogDensity;
use occam::jobs::prepare::{default_start, likelihood_of, load_data_for, model_warnings, truth_of};
use occam::likelihood::{Likelihood, fisher_exact};
use occam::nested::SubModel;
use occam::prior::PriorKind;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// Where the reference point comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
enum ReferenceSource {
    /// The injected truth of every free parameter (simulated data with a known truth).
    Truth,
    /// `[fit] start`, else the prior centre: the start of the CLI's MAP search.
    Start,
}

/// The native likelihood; `occam.Likelihood` (python/occam/_likelihood.py) wraps it.
#[pyclass(frozen, module = "occam._occam", name = "_Likelihood")]
pub struct PyLikelihood {
    /// The model's exact likelihood with the fixed parameters held at their values: the very
    /// density the CLI's samplers run on when `[analysis] likelihood = "exact"`.
    sub: SubModel<Likelihood>,
    /// The `[[select.model]]` name, or the `[fit]` model's name.
    label: String,
    study: String,
    reference: Vec<f64>,
    reference_source: ReferenceSource,
    warnings: Vec<String>,
}

/// What [`build`] makes, before it becomes a Python object.
struct Built {
    sub: SubModel<Likelihood>,
    label: String,
    study: String,
    reference: Vec<f64>,
    reference_source: ReferenceSource,
    warnings: Vec<String>,
}

/// Loads the study, its data and the likelihood of `model` (`None`: the `[fit]` model),
/// with the CLI's error messages.
fn build(path: &Path, model: Option<&str>) -> anyhow::Result<Built> {
    let study = Study::load(path)?;
    let (spec, label): (ModelSpec, String) = match model {
        None => (
            study.fit_model.clone(),
            study.models.defs[study.fit_model.model].name().to_string(),
        ),
        Some(name) => {
            let m = study
                .select_models
                .iter()
                .find(|m| m.name == name)
                .ok_or_else(|| {
                    let names: Vec<&str> =
                        study.select_models.iter().map(|m| m.name.as_str()).collect();
                    if names.is_empty() {
                        anyhow::anyhow!(
                            "{}: `select.model`: there is no [[select.model]] named `{name}`: the study has no [[select.model]] tables; pass model=None for the [fit] model",
                            study.source
                        )
                    } else {
                        anyhow::anyhow!(
                            "{}: `select.model`: there is no [[select.model]] named `{name}`; the models are {names:?} (model=None is the [fit] model)",
                            study.source
                        )
                    }
                })?;
            (m.spec.clone(), m.name.clone())
        }
    };
    let context = || format!("preparing the data of {}", path.display());
    // only the channels this model reads
    let (dataset, _origin) = load_data_for(&study, &[spec.model]).with_context(context)?;
    let exact = likelihood_of(&study, spec.model, &dataset)
        .map_err(|e| anyhow::anyhow!("model `{}`: {e}", study.models.defs[spec.model].name()))
        .with_context(context)?;
    let truth = truth_of(&study, spec.model, &dataset).and_then(|t| {
        spec.free
            .iter()
            .map(|&i| t[i])
            .collect::<Option<Vec<f64>>>()
    });
    let (reference, reference_source) = match truth {
        Some(t) => (t, ReferenceSource::Truth),
        None => {
            let start = default_start(&study, &spec);
            (
                spec.free.iter().map(|&i| start[i]).collect(),
                ReferenceSource::Start,
            )
        }
    };
    let warnings = model_warnings(&study, spec.model, &dataset);
    let sub = SubModel::new(exact, spec.free.clone(), spec.base.clone())?;
    Ok(Built {
        sub,
        label,
        study: study.source.clone(),
        reference,
        reference_source,
        warnings,
    })
}

/// Which density a call evaluates.
#[derive(Clone, Copy)]
enum Density {
    Likelihood,
    Prior,
    Posterior,
}

impl PyLikelihood {
    fn names(&self) -> &[String] {
        self.sub.prior().names()
    }

    fn eval(&self, what: Density, theta: &[f64]) -> f64 {
        match what {
            Density::Likelihood => self.sub.ln_likelihood(theta),
            Density::Prior => self.sub.prior().ln_pdf(theta),
            Density::Posterior => self.sub.ln_posterior(theta),
        }
    }

    /// `theta` as (rows, one point per `dim` values), checked: 1-D of length P or 2-D (n, P),
    /// every value finite. `one` is true for a 1-D input.
    fn check(&self, theta: &PyReadonlyArrayDyn<'_, f64>) -> PyResult<(Vec<f64>, usize, bool)> {
        let p = self.names().len();
        let shape = theta.shape().to_vec();
        let shape_str = format!(
            "({})",
            shape
                .iter()
                .map(|s| s.to_string())
                .collect::<Vec<_>>()
                .join(", ")
                + if shape.len() == 1 { "," } else { "" }
        );
        let (n, one) = match shape.as_slice() {
            [len] => {
                if *len != p {
                    return Err(PyValueError::new_err(format!(
                        "theta has {len} values; model `{}` has {p} free parameters {:?} (in this order)",
                        self.label,
                        self.names()
                    )));
                }
                (1, true)
            }
            [rows, cols] => {
                if *cols != p {
                    return Err(PyValueError::new_err(format!(
                        "theta has shape {shape_str}: each row is one point and needs {p} values, one per free parameter {:?} of model `{}`",
                        self.names(),
                        self.label
                    )));
                }
                (*rows, false)
            }
            _ => {
                return Err(PyValueError::new_err(format!(
                    "theta must be 1-D (one point, {p} values) or 2-D (one row per point, shape (n, {p})); got a {}-D array of shape {shape_str}",
                    shape.len()
                )));
            }
        };
        // a copy: the evaluation runs without the GIL, while Python could write to the array
        let flat: Vec<f64> = theta.as_array().iter().copied().collect();
        if let Some(k) = flat.iter().position(|v| !v.is_finite()) {
            // p > 0 here: a model without free parameters has no values to check
            let (row, col) = (k / p, k % p);
            let at = if one {
                format!("theta[{col}]")
            } else {
                format!("theta[{row}, {col}]")
            };
            return Err(PyValueError::new_err(format!(
                "{at} (`{}`) is {}: parameters must be finite numbers",
                self.names()[col],
                flat[k]
            )));
        }
        Ok((flat, n, one))
    }

    /// One density at every point of `theta`: a float for 1-D input, an array for 2-D (rows
    /// evaluated in parallel, in order, without the GIL).
    fn evaluate<'py>(
        &self,
        py: Python<'py>,
        what: Density,
        theta: PyReadonlyArrayDyn<'py, f64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let (flat, n, one) = self.check(&theta)?;
        drop(theta);
        let p = self.names().len();
        if one {
            let v = py.detach(|| self.eval(what, &flat));
            return Ok(v.into_pyobject(py)?.into_any());
        }
        let out: Vec<f64> = py.detach(|| {
            if p == 0 {
                (0..n).map(|_| self.eval(what, &[])).collect()
            } else {
                flat.par_chunks(p).map(|row| self.eval(what, row)).collect()
            }
        });
        Ok(PyArray1::from_vec(py, out).into_any())
    }
}

#[pymethods]
impl PyLikelihood {
    /// Builds the likelihood of a study's model (see `occam.Likelihood.from_study`).
    #[staticmethod]
    #[pyo3(signature = (path, model=None))]
    fn from_study(py: Python<'_>, path: PathBuf, model: Option<String>) -> PyResult<Self> {
        let b = py
            .detach(|| build(&path, model.as_deref()))
            .map_err(occam_error)?;
        Ok(Self {
            sub: b.sub,
            label: b.label,
            study: b.study,
            reference: b.reference,
            reference_source: b.reference_source,
            warnings: b.warnings,
        })
    }

    /// `ln L(θ)`: float for one point (1-D), array for one row per point (2-D).
    fn ln_likelihood<'py>(
        &self,
        py: Python<'py>,
        theta: PyReadonlyArrayDyn<'py, f64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        self.evaluate(py, Density::Likelihood, theta)
    }

    /// `ln π(θ)`, the normalised prior of the free parameters (−inf outside its support).
    fn ln_prior<'py>(
        &self,
        py: Python<'py>,
        theta: PyReadonlyArrayDyn<'py, f64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        self.evaluate(py, Density::Prior, theta)
    }

    /// `ln L(θ) + ln π(θ)` (−inf outside the prior support, where ln L is not evaluated).
    fn ln_posterior<'py>(
        &self,
        py: Python<'py>,
        theta: PyReadonlyArrayDyn<'py, f64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        self.evaluate(py, Density::Posterior, theta)
    }

    /// The Fisher matrix of the (Gaussian, Whittle) `ln L` over the free parameters at `theta`.
    fn fisher<'py>(
        &self,
        py: Python<'py>,
        theta: PyReadonlyArrayDyn<'py, f64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let (flat, _, one) = self.check(&theta)?;
        if !one {
            return Err(PyValueError::new_err(format!(
                "fisher takes one point (a 1-D theta of {} values); got a 2-D array",
                self.names().len()
            )));
        }
        drop(theta);
        let p = flat.len();
        let f = py.detach(|| {
            fisher_exact(
                self.sub.parent(),
                &self.sub.embed(&flat),
                self.sub.free_indices(),
            )
        });
        let rows: Vec<f64> = (0..p)
            .flat_map(|i| (0..p).map(move |j| (i, j)))
            .map(|(i, j)| f[(i, j)])
            .collect();
        Ok(PyArray1::from_vec(py, rows).reshape([p, p])?.into_any())
    }

    /// Names of the free parameters, in the order of θ.
    #[getter]
    fn param_names(&self) -> Vec<String> {
        self.names().to_vec()
    }

    /// `[P, 2]`: each free parameter's prior support (lo, hi); (−inf, inf) for a Gaussian.
    #[getter]
    fn prior_bounds<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let b: Vec<f64> = self
            .sub
            .prior()
            .bounds()
            .into_iter()
            .flat_map(|(lo, hi)| [lo, hi])
            .collect();
        let p = b.len() / 2;
        Ok(PyArray1::from_vec(py, b).reshape([p, 2])?.into_any())
    }

    /// Each free parameter's prior as a dict: `name`, `kind` and its numbers.
    #[getter]
    fn priors<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        self.names()
            .iter()
            .zip(self.sub.prior().kinds())
            .map(|(n, k)| {
                let d = PyDict::new(py);
                d.set_item("name", n)?;
                match *k {
                    PriorKind::Uniform { lo, hi } => {
                        d.set_item("kind", "uniform")?;
                        d.set_item("lo", lo)?;
                        d.set_item("hi", hi)?;
                    }
                    PriorKind::LogUniform { lo, hi } => {
                        d.set_item("kind", "log_uniform")?;
                        d.set_item("lo", lo)?;
                        d.set_item("hi", hi)?;
                    }
                    PriorKind::Gaussian { mu, sigma } => {
                        d.set_item("kind", "gaussian")?;
                        d.set_item("mu", mu)?;
                        d.set_item("sigma", sigma)?;
                    }
                }
                Ok(d)
            })
            .collect()
    }

    /// The reference point of the free parameters (see `reference_source`).
    #[getter]
    fn reference<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_vec(py, self.reference.clone())
    }

    /// `"truth"` or `"start"`: where `reference` comes from.
    #[getter]
    fn reference_source(&self) -> &'static str {
        match self.reference_source {
            ReferenceSource::Truth => "truth",
            ReferenceSource::Start => "start",
        }
    }

    /// In-band frequency bins summed over the experiments.
    #[getter]
    fn n_bins(&self) -> usize {
        self.sub.parent().n_bins()
    }

    /// The `[[select.model]]` name, or the name of the `[fit]` model.
    #[getter]
    fn model(&self) -> &str {
        &self.label
    }

    /// The parent model (a `[[model]]` name, or `ltp`).
    #[getter]
    fn parent_model(&self) -> String {
        self.sub.parent().model().name().to_string()
    }

    /// The study file the likelihood was built from.
    #[getter]
    fn study(&self) -> &str {
        &self.study
    }

    /// `[analysis] statistic`: `whittle`, `student_t` or `log_periodogram`.
    #[getter]
    fn statistic(&self) -> &'static str {
        self.sub.parent().statistic().name()
    }

    /// The fixed parameters of the model and their values.
    #[getter]
    fn fixed(&self) -> Vec<(String, f64)> {
        let free = self.sub.free_indices();
        self.sub
            .parent()
            .model()
            .param_names()
            .iter()
            .zip(self.sub.base())
            .enumerate()
            .filter(|(i, _)| !free.contains(i))
            .map(|(_, (n, v))| (n.clone(), *v))
            .collect()
    }

    /// Warnings `occam fit`/`select` print about this model on these data.
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.warnings.clone()
    }
}
