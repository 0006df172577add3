//! The native module `occam._occam` of the `occam` Python package: the study's likelihood
//! for Python samplers and the jobs of the command line, sharing the library's code paths.
//! The Python package (python/occam/) wraps it with documentation and numpy conversions.

mod jobs;
mod likelihood;

use pyo3::prelude::*;

pyo3::create_exception!(
    _occam,
    OccamError,
    pyo3::exceptions::PyRuntimeError,
    "An error of occam: the message is exactly the one the command line prints after `error: `."
);

/// An occam error as a Python exception with the CLI's message (every context, joined by `: `,
/// each cause once: [`occam::jobs::error_text`]).
pub(crate) fn occam_error(e: anyhow::Error) -> PyErr {
    OccamError::new_err(occam::jobs::error_text(&e))
}

#[pymodule]
fn _occam(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("OccamError", m.py().get_type::<OccamError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<likelihood::PyLikelihood>()?;
    m.add_function(wrap_pyfunction!(jobs::simulate, m)?)?;
    m.add_function(wrap_pyfunction!(jobs::fit, m)?)?;
    m.add_function(wrap_pyfunction!(jobs::select, m)?)?;
    m.add_function(wrap_pyfunction!(jobs::sweep, m)?)?;
    m.add_function(wrap_pyfunction!(jobs::design, m)?)?;
    m.add_function(wrap_pyfunction!(jobs::report, m)?)?;
    Ok(())
}
