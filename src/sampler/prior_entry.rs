//! A prior as the `[prior]` entry that writes it, for messages that tell a person what to edit.

use crate::numfmt::fmt_roundtrip as r;
use crate::prior::PriorKind;

/// `{ kind = "uniform", lo = -0.001, hi = 0.001 }`: the entry's text, every number as its
/// shortest round-tripping form.
///
/// ```
/// use occam::prior::PriorKind;
/// let k = PriorKind::Uniform { lo: -1e-3, hi: 1e-3 };
/// assert_eq!(occam::sampler::prior_entry(&k), "{ kind = \"uniform\", lo = -0.001, hi = 0.001 }");
/// ```
pub fn prior_entry(k: &PriorKind) -> String {
    match *k {
        PriorKind::Uniform { lo, hi } => {
            format!("{{ kind = \"uniform\", lo = {}, hi = {} }}", r(lo), r(hi))
        }
        PriorKind::LogUniform { lo, hi } => {
            format!(
                "{{ kind = \"log_uniform\", lo = {}, hi = {} }}",
                r(lo),
                r(hi)
            )
        }
        PriorKind::Gaussian { mu, sigma } => {
            format!(
                "{{ kind = \"gaussian\", mu = {}, sigma = {} }}",
                r(mu),
                r(sigma)
            )
        }
    }
}
