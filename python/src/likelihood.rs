//! `occam.Likelihood`: a study's likelihood of one model over its free parameters, built by the
//! same library calls as `occam fit` and `occam select`, for samplers written in Python: the
//! exact one, or (`binned=True`) the relative-binned one the command line's samplers run on.

use crate::occam_error;
use anyhow::Context;
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use occam::config::{ModelSpec, Study};
use occam::density::LogDensity;
use occam::jobs::own_noise::own_noise_likelihood;
use occam::jobs::prepare::{
    default_start, likelihood_at, likelihood_of, load_data_for, model_warnings, reference_point,
    truth_of,
};
use occam::jobs::sampled::{Role, relbin_as_sampled};
use occam::likelihood::theta_noise::{
    ln_likelihood_theta_noise, ln_likelihood_theta_noise_per_bin,
};
use occam::likelihood::{Likelihood, RelBinLikelihood, RelBinValidation, cramer_rao, fisher_exact};
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

/// The relative-binned likelihood of `binned=True` and how it was validated.
struct Binned {
    /// Over the free parameters, fixed ones at their values (as `sub`).
    sub: SubModel<RelBinLikelihood>,
    validation: RelBinValidation,
    /// The fiducial point (the MAP), free parameters only.
    fiducial: Vec<f64>,
}

/// The native likelihood; `occam.Likelihood` (python/occam/_likelihood.py) wraps it.
#[pyclass(frozen, module = "occam._occam", name = "_Likelihood")]
pub struct PyLikelihood {
    /// The model's exact likelihood with the fixed parameters held at their values: the very
    /// density the CLI's samplers run on when `[analysis] likelihood = "exact"`.
    sub: SubModel<Likelihood>,
    /// With `binned=True`: what `ln_likelihood` and `ln_posterior` evaluate instead.
    binned: Option<Binned>,
    /// The residual noise moves with the free parameters (`noise = "model"` through the
    /// model's own dynamics): `sub` holds it at the model's own MAP (as `fit` and `select`),
    /// and the unbinned `ln_likelihood` evaluates it at θ itself, exactly.
    theta_noise: bool,
    /// `[fit] map_starts`: the quasi-random starts of `map()`'s search, as `fit`'s.
    map_starts: usize,
    /// The command line's start of the MAP search (free parameters).
    start: Vec<f64>,
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
    binned: Option<Binned>,
    theta_noise: bool,
    map_starts: usize,
    start: Vec<f64>,
    label: String,
    study: String,
    reference: Vec<f64>,
    reference_source: ReferenceSource,
    warnings: Vec<String>,
}

/// Loads the study, its data and the likelihood of `model` (`None`: the `[fit]` model),
/// with the CLI's error messages; with `binned`, also the relative-binned likelihood the
/// command's samplers run on (`fit`'s for the `[fit]` model, `select`'s for a select model).
fn build(path: &Path, model: Option<&str>, binned: bool) -> anyhow::Result<Built> {
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
    // a residual noise that moves with θ: held at the model's own MAP (iterated), as `fit` and
    // `select` hold it, rather than at a reference point nobody chose
    let own = own_noise_likelihood(
        &study,
        &spec,
        &default_start(&study, &spec),
        reference_point(&study, spec.model),
        &|at: &[f64]| likelihood_at(&study, spec.model, &dataset, at),
    )
    .map_err(|e| anyhow::anyhow!("model `{label}`: {e}"))
    .with_context(context)?;
    let (exact, theta_noise, own_note) = match own {
        Some((lik, point)) => (lik, true, Some(point.fit_note())),
        None => (exact, false, None),
    };
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
    let mut warnings = model_warnings(&study, spec.model, &dataset);
    if let Some(n) = own_note {
        warnings.push(format!(
            "{n}; ln_likelihood, ln_posterior and ln_likelihood_per_bin evaluate the noise at θ itself (exact, slower), map(), fisher() and binned=True hold it at that MAP"
        ));
    }
    let binned = if binned {
        let role = if model.is_none() {
            Role::Fit
        } else {
            Role::Select
        };
        let b = relbin_as_sampled(&study, &spec, &exact, role).with_context(|| {
            format!(
                "{}: model `{label}`: the relative-binned likelihood",
                study.source
            )
        })?;
        let base = b.map.best().result.theta.clone();
        let fiducial = spec.free.iter().map(|&i| base[i]).collect();
        let validation = b.relbin.validation().clone();
        Some(Binned {
            // the chains embed their free parameters in the MAP, as `sub` in the base
            sub: SubModel::new(b.relbin, spec.free.clone(), spec.base.clone())?,
            validation,
            fiducial,
        })
    } else {
        None
    };
    let sub = SubModel::new(exact, spec.free.clone(), spec.base.clone())?;
    Ok(Built {
        sub,
        binned,
        theta_noise,
        map_starts: study.fit.map_starts,
        start: {
            let s = default_start(&study, &spec);
            spec.free.iter().map(|&i| s[i]).collect()
        },
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
        match (what, &self.binned) {
            (Density::Likelihood, None) if self.theta_noise => {
                ln_likelihood_theta_noise(self.sub.parent(), &self.full(theta))
            }
            (Density::Likelihood, None) => self.sub.ln_likelihood(theta),
            (Density::Likelihood, Some(b)) => b.sub.ln_likelihood(theta),
            (Density::Prior, _) => self.sub.prior().ln_pdf(theta),
            (Density::Posterior, None) if self.theta_noise => {
                let lp = self.sub.prior().ln_pdf(theta);
                if lp == f64::NEG_INFINITY {
                    lp
                } else {
                    lp + ln_likelihood_theta_noise(self.sub.parent(), &self.full(theta))
                }
            }
            (Density::Posterior, None) => self.sub.ln_posterior(theta),
            (Density::Posterior, Some(b)) => b.sub.ln_posterior(theta),
        }
    }

    /// The full parameter vector of the free values `theta` (fixed ones at their values).
    fn full(&self, theta: &[f64]) -> Vec<f64> {
        self.sub.embed(theta)
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
    #[pyo3(signature = (path, model=None, binned=false))]
    fn from_study(
        py: Python<'_>,
        path: PathBuf,
        model: Option<String>,
        binned: bool,
    ) -> PyResult<Self> {
        let b = py
            .detach(|| build(&path, model.as_deref(), binned))
            .map_err(occam_error)?;
        Ok(Self {
            sub: b.sub,
            binned: b.binned,
            theta_noise: b.theta_noise,
            map_starts: b.map_starts,
            start: b.start,
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

    /// `None` for the exact likelihood; with `binned=True` how the relative binning was
    /// validated against the exact `ln L` (as the command line reports it in `summary.json`).
    #[getter]
    fn binning<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let Some(b) = &self.binned else {
            return Ok(None);
        };
        let v = &b.validation;
        let d = PyDict::new(py);
        d.set_item("n_coarse", v.n_coarse)?;
        d.set_item("n_bins", self.sub.parent().n_bins())?;
        d.set_item("n_points", v.n_points)?;
        d.set_item("worst_abs_delta_ln_l", v.worst_abs_delta_ln_l)?;
        d.set_item("limit", v.limit)?;
        d.set_item("tolerance", v.tolerance)?;
        d.set_item("refinements", v.refinements)?;
        let names = self.sub.parent().model().param_names();
        let free = self.sub.free_indices();
        let worst: Vec<f64> = free.iter().map(|&i| v.worst_point[i]).collect();
        d.set_item("worst_point", PyArray1::from_vec(py, worst))?;
        let coverage = PyDict::new(py);
        for &i in free {
            coverage.set_item(&names[i], v.coverage[i])?;
        }
        d.set_item("coverage", coverage)?;
        d.set_item("box_params", v.box_params.clone())?;
        d.set_item("fiducial", PyArray1::from_vec(py, b.fiducial.clone()))?;
        Ok(Some(d))
    }

    /// The multi-start MAP search of `occam fit` (Fisher scoring on the exact Whittle
    /// `ln L + ln π`, bounded by the prior box) from `start` (free parameters; `None`: the
    /// command line's start) and `[fit] map_starts` quasi-random starts: a dict `theta`,
    /// `ln_posterior`, `sigma` (Cramér–Rao at the MAP, `None` if the Fisher matrix is
    /// singular), `fisher`, `converged`, `iterations`, `at_bound`, `n_maxima`.
    #[pyo3(signature = (start=None))]
    fn map<'py>(
        &self,
        py: Python<'py>,
        start: Option<PyReadonlyArrayDyn<'py, f64>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let start_full = match start {
            Some(s) => {
                let (flat, _, one) = self.check(&s)?;
                if !one {
                    return Err(PyValueError::new_err(
                        "start is one point: a 1-D array of the free parameters",
                    ));
                }
                self.full(&flat)
            }
            None => self.full(&self.start),
        };
        let free = self.sub.free_indices().to_vec();
        let exact = self.sub.parent();
        let found = py
            .detach(|| {
                let search =
                    occam::jobs::prepare::map_search(exact, &free, &start_full, self.map_starts)?;
                let best = search.best().result.clone();
                let f = fisher_exact(exact, &best.theta, &free);
                Ok::<_, occam::likelihood::MapError>((best, f, search.maxima.len()))
            })
            .map_err(|e| {
                crate::occam_error(anyhow::anyhow!("model `{}`: MAP search: {e}", self.label))
            })?;
        let (best, f, n_maxima) = found;
        let p = free.len();
        let d = PyDict::new(py);
        let theta: Vec<f64> = free.iter().map(|&i| best.theta[i]).collect();
        d.set_item("theta", PyArray1::from_vec(py, theta))?;
        d.set_item("ln_posterior", best.ln_posterior)?;
        d.set_item("sigma", cramer_rao(&f).map(|s| PyArray1::from_vec(py, s)))?;
        let rows: Vec<f64> = (0..p)
            .flat_map(|i| (0..p).map(move |j| (i, j)))
            .map(|(i, j)| f[(i, j)])
            .collect();
        d.set_item("fisher", PyArray1::from_vec(py, rows).reshape([p, p])?)?;
        d.set_item("converged", best.converged)?;
        d.set_item("iterations", best.iterations)?;
        d.set_item("at_bound", best.at_bound.clone())?;
        d.set_item("n_maxima", n_maxima)?;
        Ok(d)
    }

    /// The exact `ln L` bin by bin at each row of a 2-D `theta` (n, P): one array per
    /// experiment, shape (n, bins of that experiment), summing over bins and experiments to
    /// the exact `ln L` (rows in parallel, without the GIL).
    fn ln_likelihood_per_bin<'py>(
        &self,
        py: Python<'py>,
        theta: PyReadonlyArrayDyn<'py, f64>,
    ) -> PyResult<Vec<Bound<'py, PyAny>>> {
        let (flat, n, one) = self.check(&theta)?;
        drop(theta);
        if one {
            return Err(PyValueError::new_err(
                "ln_likelihood_per_bin takes one row per point: a 2-D theta (n, P)",
            ));
        }
        let p = self.names().len();
        let exact = self.sub.parent();
        let rows: Vec<Vec<Vec<f64>>> = py
            .detach(|| {
                let at = |row: &[f64]| {
                    if self.theta_noise {
                        Ok(ln_likelihood_theta_noise_per_bin(exact, &self.full(row)))
                    } else {
                        exact.ln_likelihood_per_bin(&self.full(row))
                    }
                };
                if p == 0 {
                    (0..n).map(|_| at(&[])).collect::<Result<Vec<_>, _>>()
                } else {
                    flat.par_chunks(p).map(at).collect()
                }
            })
            .map_err(|e| crate::occam_error(anyhow::anyhow!("model `{}`: {e}", self.label)))?;
        exact
            .spectra()
            .iter()
            .enumerate()
            .map(|(e, sp)| {
                let m = sp.len();
                let v: Vec<f64> = rows.iter().flat_map(|r| r[e].iter().copied()).collect();
                Ok(PyArray1::from_vec(py, v).reshape([n, m])?.into_any())
            })
            .collect()
    }

    /// Per experiment: its name, the frequencies of its in-band bins (Hz), its data channels
    /// and the magnitudes `|DFT|` of their data there, shape (bins, channels).
    #[getter]
    fn experiments<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, PyDict>>> {
        self.sub
            .parent()
            .spectra()
            .iter()
            .map(|sp| {
                let d = PyDict::new(py);
                d.set_item("name", &sp.name)?;
                d.set_item("freqs", PyArray1::from_vec(py, sp.freqs.clone()))?;
                d.set_item("channels", sp.channels.clone())?;
                let c = sp.channels.len();
                let mag: Vec<f64> = sp.data.iter().map(|z| z.norm()).collect();
                d.set_item(
                    "data_abs",
                    PyArray1::from_vec(py, mag).reshape([sp.len(), c])?,
                )?;
                Ok(d)
            })
            .collect()
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
