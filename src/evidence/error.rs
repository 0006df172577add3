//! [`EvidenceError`]: why an evidence computation could not produce a number.

/// Why an evidence computation could not produce a number.
#[derive(Debug, PartialEq, thiserror::Error)]
pub enum EvidenceError {
    /// A vector or matrix has the wrong size.
    #[error("{what}: expected {expected} entries, got {got}")]
    Dimension {
        what: String,
        expected: usize,
        got: usize,
    },
    /// An input is NaN or infinite where a finite number is needed.
    #[error("{what} is not finite ({value}); {fix}")]
    NonFinite {
        what: String,
        value: f64,
        fix: String,
    },
    /// A matrix that must be symmetric positive definite is not (found outside a
    /// factorisation: a pivot of the reordered MVN integral, a Hessian diagonal).
    #[error("{what} is not symmetric positive definite ({detail}); {fix}")]
    NotPositiveDefinite {
        what: String,
        detail: String,
        fix: String,
    },
    /// A matrix that must be symmetric positive definite failed its factorisation: `source`
    /// says why (naming the least-constrained direction when it is not positive definite).
    #[error("{what}: {source}; {fix}")]
    Matrix {
        what: String,
        source: crate::linalg::LinalgError,
        fix: String,
    },
    /// The expansion point is on or outside the prior support and no box correction was asked.
    #[error(
        "θ̂ of `{param}` = {value} is on or outside its prior bounds [{lo}, {hi}]: the plain Laplace formula does not apply at a bound; the box-corrected form (expanded at the unconstrained maximum, times the Gaussian's mass inside the box) does"
    )]
    OnBoundary {
        param: String,
        value: f64,
        lo: f64,
        hi: f64,
    },
    /// The Gaussian approximation puts no representable mass inside the prior box.
    #[error(
        "the Gaussian approximation N(θ̂, Σ) has no representable mass inside the prior box (ln P = {ln_p}); the Laplace estimate is not applicable here"
    )]
    BoxMassUnderflow { ln_p: f64 },
    /// Too few samples for a robust covariance.
    #[error(
        "{what}: {n} samples for {dim} parameters; at least {min} (5·(p+1)) are needed, run a longer chain"
    )]
    TooFewSamples {
        what: String,
        n: usize,
        dim: usize,
        min: usize,
    },
    /// Too few distinct samples (a chain that barely moves) for a robust covariance.
    #[error(
        "{what}: only {distinct} distinct samples among {n} for {dim} parameters (at least {min}, 10·(p+1), are needed): the chain barely moves; run longer chains or use a better proposal (a smaller scale, or the posterior covariance) so more proposals are accepted"
    )]
    TooFewDistinct {
        what: String,
        n: usize,
        distinct: usize,
        dim: usize,
        min: usize,
    },
    /// The samples do not span all dimensions.
    #[error(
        "{what}: the covariance is singular ({detail}); check for constant or collinear parameters"
    )]
    SingularCovariance { what: String, detail: String },
    /// A prior kind the method cannot handle.
    #[error("prior of `{param}`: {why}")]
    UnsupportedPrior { param: String, why: String },
    /// An option value is out of range.
    #[error("option `{field}` = {value}: {fix}")]
    InvalidOption {
        field: String,
        value: String,
        fix: String,
    },
    /// The prior could not be built.
    #[error(transparent)]
    Prior(#[from] crate::prior::PriorError),
    /// A checkpoint cannot be read or written.
    #[error(transparent)]
    CheckpointFile(#[from] crate::data::checkpoint::CheckpointError),
    /// A readable checkpoint that belongs to another run.
    #[error("checkpoint `{path}`: {problem}")]
    Checkpoint {
        /// The checkpoint file.
        path: String,
        /// What does not match, and what to do.
        problem: String,
    },
}

impl EvidenceError {
    pub(crate) fn option(field: &str, value: impl std::fmt::Display, fix: &str) -> Self {
        EvidenceError::InvalidOption {
            field: field.to_string(),
            value: value.to_string(),
            fix: fix.to_string(),
        }
    }

    pub(crate) fn non_finite(what: impl Into<String>, value: f64, fix: &str) -> Self {
        EvidenceError::NonFinite {
            what: what.into(),
            value,
            fix: fix.to_string(),
        }
    }

    /// The context of a [`crate::linalg::LinalgError`], for `map_err`: the matrix's name and
    /// what to do about it.
    pub(crate) fn matrix<'a>(
        what: impl Into<String>,
        fix: &'a str,
    ) -> impl FnOnce(crate::linalg::LinalgError) -> Self + 'a {
        let what = what.into();
        move |source| EvidenceError::Matrix {
            what,
            source,
            fix: fix.to_string(),
        }
    }

    pub(crate) fn dimension(what: impl Into<String>, expected: usize, got: usize) -> Self {
        EvidenceError::Dimension {
            what: what.into(),
            expected,
            got,
        }
    }
}
