//! Whether a run passed its own checks: the gross failures after which its numbers are not to
//! be used (chains that did not converge or barely moved, too few independent samples, a MAP
//! search that did not converge, an evidence correction that rests on a handful of samples,
//! two evidence estimators further apart than their error bars allow).
//! A failed run says so first — the first lines of the terminal, `summary.json`'s `valid`
//! and `invalid_reasons`, the report's headline — with what to change, before any table.
//! Marginal cases (R-hat between 1.01 and 1.1, say) stay warnings.

/// R-hat above this fails a run (the warning starts at 1.01).
pub const RHAT_LIMIT: f64 = 1.1;
/// Effective samples below this fail a run.
pub const ESS_LIMIT: f64 = 50.0;
/// A chain accepting less than this fraction of its proposals fails a run.
pub const ACCEPTANCE_LIMIT: f64 = 0.01;

/// A statistical `ln B` further than this many combined standard errors from its pair's
/// reference fails a run: two independent estimators cannot both be right with their error
/// bars (a Gaussian 5σ happens once in 1.7 million: an error bar is wrong, not unlucky).
pub const DISAGREEMENT_LIMIT: f64 = 5.0;

/// The first line of a failed run's output.
pub const INVALID_HEADLINE: &str =
    "RESULTS NOT VALID: this run failed its own checks; do not use the numbers below";

/// Where the chains' failures of one sampler are merged from: one line per kind of failure
/// (R-hat, ESS, acceptance), naming every parameter or chain it hit.
pub struct ChainChecks<'a> {
    /// Prefix of each line (e.g. "model `X`: in-model chains"), or "chains".
    pub scope: &'a str,
    pub names: &'a [String],
    pub rhat: &'a [f64],
    /// Effective sample sizes, where the sampler reports them.
    pub ess: Option<&'a [f64]>,
    /// Acceptance per chain.
    pub acceptance: &'a [f64],
    /// What to change, said once after the failures of this sampler (e.g. the study keys of
    /// its length).
    pub remedy: &'a str,
}

impl ChainChecks<'_> {
    /// The gross failures, merged (empty when the chains pass).
    pub fn failures(&self) -> Vec<String> {
        let mut out = Vec::new();
        let listed = |hits: Vec<String>| hits.join(", ");
        let over: Vec<String> = self
            .names
            .iter()
            .zip(self.rhat)
            .filter(|(_, r)| r.is_finite() && **r > RHAT_LIMIT)
            .map(|(n, r)| format!("`{n}` {r:.2}"))
            .collect();
        if !over.is_empty() {
            out.push(format!(
                "{}: R-hat above {RHAT_LIMIT} for {} — the chains have not converged to one distribution",
                self.scope,
                listed(over)
            ));
        }
        if let Some(ess) = self.ess {
            let few: Vec<String> = self
                .names
                .iter()
                .zip(ess)
                .filter(|(_, e)| e.is_finite() && **e < ESS_LIMIT)
                .map(|(n, e)| format!("`{n}` {e:.0}"))
                .collect();
            if !few.is_empty() {
                out.push(format!(
                    "{}: effective sample size below {ESS_LIMIT:.0} for {} — too few independent samples for a mean or a σ",
                    self.scope,
                    listed(few)
                ));
            }
        }
        let stuck: Vec<String> = self
            .acceptance
            .iter()
            .enumerate()
            .filter(|(_, a)| **a < ACCEPTANCE_LIMIT)
            .map(|(i, a)| format!("chain {} {:.1} %", i + 1, a * 100.0))
            .collect();
        if !stuck.is_empty() {
            out.push(format!(
                "{}: acceptance below {:.0} % in {} — the chains barely move",
                self.scope,
                ACCEPTANCE_LIMIT * 100.0,
                listed(stuck)
            ));
        }
        if !out.is_empty() && !self.remedy.is_empty() {
            let last = out.pop().expect("not empty");
            out.push(format!("{last}; {}", self.remedy));
        }
        out
    }
}

/// The lines a failed run leads with (empty for a valid one): the headline, then each reason.
pub fn invalid_lines(reasons: &[String]) -> Vec<String> {
    if reasons.is_empty() {
        return Vec::new();
    }
    let mut out = vec![INVALID_HEADLINE.to_string()];
    out.extend(reasons.iter().map(|r| format!("  - {r}")));
    out.push(String::new());
    out
}

/// `true`: what an old summary without the field was (serde's default).
pub fn valid_by_default() -> bool {
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names() -> Vec<String> {
        ["w1sq", "w2sq", "dt2"].map(String::from).to_vec()
    }

    #[test]
    fn passing_chains_give_no_failure() {
        let n = names();
        let c = ChainChecks {
            scope: "chains",
            names: &n,
            rhat: &[1.0, 1.02, 1.09],
            ess: Some(&[400.0, 60.0, 51.0]),
            acceptance: &[0.25, 0.011],
            remedy: "run longer",
        };
        assert!(c.failures().is_empty());
        assert!(invalid_lines(&[]).is_empty());
    }

    #[test]
    fn failures_merge_per_kind_and_name_every_parameter() {
        let n = names();
        let c = ChainChecks {
            scope: "chains",
            names: &n,
            rhat: &[1.64, 1.2, f64::NAN],
            ess: Some(&[6.0, 7.0, 900.0]),
            acceptance: &[0.01, 0.0, 0.0, 0.3],
            remedy: "run longer ([fit] iterations)",
        };
        let f = c.failures();
        assert_eq!(f.len(), 3, "{f:?}");
        assert!(f[0].contains("`w1sq` 1.64, `w2sq` 1.20"), "{}", f[0]);
        assert!(!f[0].contains("dt2"));
        assert!(f[1].contains("`w1sq` 6, `w2sq` 7"), "{}", f[1]);
        assert!(f[2].contains("chain 2 0.0 %, chain 3 0.0 %"), "{}", f[2]);
        assert!(f[2].ends_with("run longer ([fit] iterations)"), "{}", f[2]);
        let lines = invalid_lines(&f);
        assert_eq!(lines[0], INVALID_HEADLINE);
        assert_eq!(lines.len(), 5);
    }
}
