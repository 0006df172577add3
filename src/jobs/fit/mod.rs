//! `occam fit`: MAP, Fisher matrix and Metropolis–Hastings parameter estimation of one model,
//! with the paper's Table I layout, chains on disk, plots and a JSON summary.

mod console;
mod job;
mod output;
mod run;
mod summary;

pub use crate::jobs::chains_npz::chains_arrays;
pub use console::console;
pub use job::{Fit, Fitted};
pub use output::{LEGACY_OUTPUTS, fmt_rhat, table, write_chains_npz, write_outputs};
pub use run::{
    CHECKPOINT_FILE, LOG_AXIS_WIDTHS, fix_hint, log_axes, near_singular_warning, run,
    singular_message,
};
pub use summary::{FitError, FitOutcome, FitSummary, ParamRow, non_finite_warnings};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::LikelihoodKind;

    /// Drawn in logarithm: a glitch's decay and amplitude 5 or more widths from 0; not a
    /// decay the data hardly constrain (width above a fifth of it), an amplitude near 0, a
    /// loop parameter far from 0, or a glitch's start.
    #[test]
    fn log_axes_are_the_well_measured_glitch_decays_and_amplitudes() {
        let names: Vec<String> = ["w1sq", "g1_t0", "g1_tau", "g1_a", "g2_tau", "g2_a"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        let free = [0, 1, 2, 3, 4, 5];
        let centre = [-1.3e-6, 3146.0, 37.0, -5.3e-14, 10.0, 2.0e-15];
        let sd = [5e-10, 3.0, 6.0, 5.5e-15, 860.0, 1.0e-15];
        assert_eq!(run::log_axes(&names, &free, &centre, &sd), vec![2, 3]);
        // at exactly five widths, and positions counted in `free`
        let sd = [5e-10, 3.0, 7.4, 5.5e-15, 2.0, 3.9e-16];
        assert_eq!(
            run::log_axes(&names, &free[1..], &centre[1..], &sd[1..]),
            vec![1, 2, 3, 4]
        );
        assert!(run::log_axes(&names, &free, &[0.0; 6], &[1.0; 6]).is_empty());
    }

    /// `[fit] independence` as given; unset, none for a model without modelled glitches.
    /// (With them, 0.8: [`crate::model::glitch::carries_glitches`] is tested on the glitch
    /// model.)
    #[test]
    fn the_independence_share_is_the_study_s_or_the_model_s_default() {
        let ltp = crate::model::LtpModel::new("ltp", Default::default());
        let mut f = crate::config::FitOptions::default();
        assert_eq!(run::independence_share(&f, &ltp), 0.0);
        f.independence = Some(0.3);
        assert_eq!(run::independence_share(&f, &ltp), 0.3);
    }
    use nalgebra::DMatrix;

    fn summary(rows: Vec<ParamRow>) -> FitSummary {
        FitSummary {
            valid: true,
            invalid_reasons: Vec::new(),
            origin: "test".into(),
            model: "m".into(),
            statistic: crate::likelihood::Statistic::Whittle,
            likelihood: LikelihoodKind::Exact,
            noise_averages: None,
            glitch_gates: vec![],
            glitch_count: None,
            missing_injection_bias: None,
            n_bins: 1,
            n_coarse_bins: None,
            rho_opt_at_map: f64::NAN,
            map_ln_posterior: -1.0,
            map_iterations: 1,
            independence: None,
            rows,
            acceptance: vec![0.0],
            non_finite: vec![0],
            warnings: vec![],
            notes: vec![],
            chains: 1,
            converged_at: None,
            kept_per_chain: 10,
            burn_in: 5,
            thin: 1,
            seconds_map: 0.0,
            seconds_mcmc: 0.0,
            iterations_per_second: 0.0,
            fisher: vec![vec![1.0]],
        }
    }

    fn row(name: &str, sd: f64, rhat: f64, ess: f64) -> ParamRow {
        ParamRow {
            name: name.into(),
            unit: String::new(),
            truth: Some(1.0),
            map: 1.0,
            mean: 1.0,
            sd,
            cramer_rao: 0.1,
            sandwich: None,
            rhat,
            ess,
            pull: Some(0.0 / sd),
        }
    }

    #[test]
    fn the_table_spells_out_stuck_chains_and_huge_numbers() {
        let s = summary(vec![
            row("ok", 0.1, 1.0012, 1234.4),
            row("stuck", 0.3, f64::INFINITY, 2.0),
            row("flat", 0.0, f64::INFINITY, 0.0),
            row("huge", 1e300, 1.5, 1e20),
        ]);
        let t = table(&s).to_text();
        let line = |n: &str| t.lines().find(|l| l.starts_with(n)).unwrap().to_string();
        assert!(
            line("ok").contains("1.0012") && line("ok").contains("1234"),
            "{t}"
        );
        assert!(line("stuck").contains("∞ (stuck)"), "{t}");
        assert!(line("flat").contains("∞ (stuck, sd 0)"), "{t}");
        // σ/CR = 1e301 and ESS = 1e20 in short form
        assert!(
            line("huge").contains("1.000e301") && line("huge").contains("1e20"),
            "{t}"
        );
        assert!(!t.contains("inf"), "{t}");
        assert!(t.lines().all(|l| l.chars().count() < 200), "{t}");
        // the flat row's pull is NaN (0/0): a warning names it
        let w = non_finite_warnings(&s);
        assert!(
            w.iter()
                .any(|m| m.starts_with("`flat`: pull is NaN (written as null")),
            "{w:?}"
        );
        assert_eq!(w.len(), 1, "{w:?}");
    }

    #[test]
    fn the_fix_hint_lists_the_lines_to_write() {
        let free: Vec<String> = ["w1sq", "a1", "f_o1"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        let named = vec!["a1".to_string(), "f_o1".to_string()];
        let h = fix_hint(&free, &named, &|n| (n == "a1").then_some(1.05));
        assert_eq!(
            h,
            "Fix them, e.g. [fit] free = [\"w1sq\"] and fixed = { a1 = 1.05, f_o1 = <value> } (values of the search; use known values where you have them), or add an experiment that excites them"
        );
        // every free parameter unconstrained: nothing to keep free
        let h = fix_hint(&named, &named, &|_| None);
        assert!(h.starts_with("Add an experiment that excites them"), "{h}");
        // the whole message from a matrix with a zero column
        let f = DMatrix::from_row_slice(3, 3, &[1.0, 0.0, 0.2, 0.0, 0.0, 0.0, 0.2, 0.0, 1.0]);
        let m = singular_message(&f, &free, "MAP", &|_| Some(0.5));
        assert!(
            m.starts_with("the Fisher matrix at the MAP is singular: the data do not constrain `a1`: ln L does not depend on `a1` (zero Fisher column). Fix it, e.g. [fit] free = [\"w1sq\", \"f_o1\"] and fixed = { a1 = 0.5 }"),
            "{m}"
        );
    }

    /// The sandwich warning names the parameter whose errors are shortest, stays silent within
    /// 5 %, is a note up to 10 % (the default Welch estimate's routine 8 %) and a warning
    /// beyond, and says so when the variance has no finite value (a Welch ν ≤ 4).
    #[test]
    fn the_sandwich_warning_names_the_worst_parameter_or_an_infinite_variance() {
        use run::Shortfall;
        let names: Vec<String> = ["a", "b"].map(String::from).to_vec();
        let w = run::sandwich_warning(
            &[1.1, 2.6],
            &[1.0, 2.0],
            &[1.0, 2.1],
            &names,
            &[0, 1],
            "why",
        );
        assert!(
            matches!(&w, Some(Shortfall::Warning(w)) if w.contains("24 %") && w.contains("`b`") && w.contains("but why:")),
            "{w:?}"
        );
        let n = run::sandwich_warning(&[1.08, 2.0], &[1.0, 2.0], &[1.0, 2.0], &names, &[0, 1], "");
        assert!(
            matches!(&n, Some(Shortfall::Note(n)) if n.contains("8 %") && n.contains("`a`")),
            "{n:?}"
        );
        let w = run::sandwich_warning(&[1.11, 2.0], &[1.0, 2.0], &[1.0, 2.0], &names, &[0, 1], "");
        assert!(matches!(&w, Some(Shortfall::Warning(_))), "{w:?}");
        assert!(
            run::sandwich_warning(&[1.04, 2.0], &[1.0, 2.0], &[1.0, 2.0], &names, &[0, 1], "")
                .is_none()
        );
        let w = run::sandwich_warning(
            &[f64::INFINITY, 2.0],
            &[1.0, 2.0],
            &[1.0, 2.0],
            &names,
            &[0, 1],
            "",
        );
        assert!(
            matches!(&w, Some(Shortfall::Warning(w)) if w.contains("not finite") && w.contains("`a`")),
            "{w:?}"
        );
    }
}
