//! `ln B_XY` of one pair by every estimator, the reference estimate and the verdict.
//!
//! # Three kinds of row
//! * **statistical** (reversible-jump visits, Rao-Blackwell and bridge; thermodynamic
//!   integration and stepping-stone): a Monte-Carlo estimate with a standard error. Two such
//!   rows agree when they differ by at most 2 combined standard errors.
//! * **systematic** (Laplace–Fisher raw and box-corrected, Laplace–Metropolis MVE and MCD):
//!   deterministic given their inputs; their error is the failure of a Gaussian assumption,
//!   which no error bar states. The row says what it assumes instead of a ± value, and they are
//!   judged separately: consistent with the reference when within 1 nat plus 2 of the
//!   reference's standard errors (1 nat is the Kass–Raftery "not worth more than a bare
//!   mention" half-width, |2 ln B| ≤ 2: a difference below it cannot change a decision).
//! * **criterion** (Schwarz): an asymptotic order-of-magnitude rule, reported and never judged.
//!
//! # The reference
//! The first row with a number in the order: RJ bridge, bridge sampling, stepping-stone,
//! thermodynamic integration, RJ Rao-Blackwell, RJ visit ratio, Laplace–Fisher box,
//! Laplace–Fisher raw. The RJ bridge comes first because it is the minimum-variance member of
//! the acceptance-ratio family; per-model bridge sampling and the tempering estimators need no
//! jump at all, so they take over when the jump chain is not informative.
//!
//! **When a model was never visited**, or never proposed the jump to the other (a model
//! entered in a sojourn or two: its visit ratio has a number, its jump rows no more
//! information; [`crate::evidence::RjPair::one_sided`]), the jump rows are one-sided: they
//! average the visited
//! model's reciprocal terms `g/(Lπ)`, which have no variance where its posterior is skewed, so
//! their error bars can fall short however long the run (measured against importance sampling
//! on `examples/accel-asymmetry.toml`: up to 4.3 stated σ; the estimators reference). Their rows
//! then say so and come last among the statistical rows: bridge sampling, whose terms are
//! bounded on any posterior, is the reference (then stepping-stone, thermodynamic integration).

use super::outcome::{Evidence, ModelOutcome};
use crate::evidence::{LnB, RjResult};
use crate::report::kass_raftery_named;
use serde::Serialize;

/// What kind of error an estimator's row carries (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EstimateKind {
    /// Monte-Carlo estimate with a standard error.
    Statistical,
    /// Deterministic approximation; its error is a bias the number cannot tell.
    Systematic,
    /// An information criterion, never part of the verdict.
    Criterion,
}

/// One estimator's `ln B_XY` for a pair.
#[derive(Debug, Clone, Serialize)]
pub struct PairEstimate {
    pub method: String,
    pub kind: EstimateKind,
    pub ln_b: Option<f64>,
    /// One-sigma Monte-Carlo error (statistical rows only).
    pub std_err: Option<f64>,
    /// Agreement with the reference (see the module docs); `None` for the reference itself,
    /// Schwarz and rows without a number.
    pub agrees: Option<bool>,
    /// What a systematic row assumes.
    pub assumes: Option<String>,
    /// Why there is no number, or a caveat.
    pub note: Option<String>,
}

/// Jump statistics between the two models of a pair.
#[derive(Debug, Clone, Serialize)]
pub struct JumpStats {
    /// Post- and pre-burn-in jump proposals X → Y and accepted ones.
    pub proposed_x_to_y: u64,
    pub accepted_x_to_y: u64,
    pub proposed_y_to_x: u64,
    pub accepted_y_to_x: u64,
    /// Accepted jumps between the two models after burn-in (both ways, all chains): the
    /// sojourns the visit ratio averages over.
    pub effective_jumps: u64,
    /// `Σα` over the post-burn-in proposals both ways: what Rao-Blackwell and the bridge
    /// average over.
    pub expected_jumps: f64,
    /// Set when the jumps are too few for the visit ratio's error bar to be trusted.
    pub warning: Option<String>,
    /// Set instead of `warning` when the jumps are few but the answer does not need them:
    /// the models are too far apart for any practical run to exchange jumps, and the
    /// reference is not a jump row. A fact, listed with the run's notes.
    pub note: Option<String>,
}

/// `ln B_XY` of one pair by every estimator.
#[derive(Debug, Clone, Serialize)]
pub struct PairResult {
    pub x: String,
    pub y: String,
    pub estimates: Vec<PairEstimate>,
    /// The estimator the others are compared with (the first with a number in the order of
    /// the module docs).
    pub reference: String,
    pub preferred: String,
    /// The Kass–Raftery grade of the reference `ln B`, naming the models.
    pub kass_raftery: String,
    /// Whether every statistical estimate with a number agrees with the reference within 2
    /// combined standard errors.
    pub all_agree: bool,
    /// Whether every systematic (Laplace) estimate is within 1 nat + 2σ of the reference;
    /// `None` when none has a number.
    pub systematic_agree: Option<bool>,
    pub jumps: JumpStats,
}

impl PairResult {
    /// The statistical rows that differ from the reference by more than
    /// [`DISAGREEMENT_LIMIT`](crate::jobs::validity::DISAGREEMENT_LIMIT) combined standard
    /// errors, as one line naming each: their error bars cannot all hold, so the run failed
    /// its own check (within 2σ is agreement; between 2σ and the limit the answer line says
    /// "DISAGREE" and the run stands). One-sided jump rows, whose notes say their error bar
    /// can fall short, are left out. `None` when none does.
    pub fn gross_disagreement(&self) -> Option<String> {
        use crate::jobs::validity::DISAGREEMENT_LIMIT;
        let r = self.estimates.iter().find(|e| e.method == self.reference)?;
        let (rv, re) = (r.ln_b?, r.std_err.unwrap_or(0.0));
        let off: Vec<String> = self
            .estimates
            .iter()
            // a one-sided jump row says its error bar can fall short: it is marked as
            // disagreeing, and does not void the run the reference stands for
            .filter(|e| {
                e.kind == EstimateKind::Statistical
                    && e.method != self.reference
                    && !is_one_sided(e)
            })
            .filter_map(|e| {
                // a row without an error bar promises nothing to break
                let (v, se) = (e.ln_b?, e.std_err?);
                let z = (v - rv).abs() / se.hypot(re);
                (z > DISAGREEMENT_LIMIT)
                    .then(|| format!("{} {v:.2} ± {se:.2} ({z:.1} σ)", e.method))
            })
            .collect();
        (!off.is_empty()).then(|| {
            format!(
                "{}/{}: {} against the reference {} {rv:.2} ± {re:.2} — more than {DISAGREEMENT_LIMIT} combined σ apart, so an error bar is wrong; run longer ([select] pt_iterations and pt_burn_in for the tempering rows, rj_iterations for the jump rows)",
                self.x,
                self.y,
                off.join(", "),
                self.reference
            )
        })
    }
}

/// The order in which rows are tried as the reference.
const REFERENCE_ORDER: [&str; 8] = [
    "RJMCMC bridge",
    "Bridge sampling",
    "Stepping-stone",
    "Thermodynamic integration",
    "RJMCMC Rao-Blackwell",
    "RJMCMC visits",
    "Laplace-Fisher box",
    "Laplace-Fisher raw",
];

/// The order when a model was never visited (the jump rows one-sided; module docs).
const ONE_SIDED_REFERENCE_ORDER: [&str; 7] = [
    "Bridge sampling",
    "Stepping-stone",
    "Thermodynamic integration",
    "RJMCMC bridge",
    "RJMCMC Rao-Blackwell",
    "Laplace-Fisher box",
    "Laplace-Fisher raw",
];

/// Whether a row is a one-sided jump row (its note starts with [`ONE_SIDED_CAVEAT`]).
pub(super) fn is_one_sided(e: &PairEstimate) -> bool {
    e.method.starts_with("RJMCMC")
        && e.note
            .as_deref()
            .is_some_and(|n| n.starts_with("one-sided"))
}

/// The one-sided caveat names bridge sampling as the reference; where that row had no number
/// and another took over, the caveat names that one.
fn name_the_reference(est: &mut [PairEstimate], reference: &str) {
    if reference == "Bridge sampling" {
        return;
    }
    for e in est.iter_mut().filter(|e| is_one_sided(e)) {
        if let Some(n) = e.note.as_mut() {
            *n = n.replace(
                "bridge sampling is the reference",
                &format!("the reference is {reference}"),
            );
        }
    }
}

/// The caveat on a one-sided jump row (module docs, "The reference").
const ONE_SIDED_CAVEAT: &str = "one-sided (no jump proposed out of one of the models): it averages the visited model's terms g/(Lπ), which have no variance where that posterior is skewed, so this error bar can fall short; bridge sampling is the reference";

fn from_lnb(name: &str, b: Option<LnB>, why: &str) -> PairEstimate {
    PairEstimate {
        method: name.into(),
        kind: EstimateKind::Statistical,
        ln_b: b.map(|b| b.ln_b),
        std_err: b.and_then(|b| b.std_err),
        agrees: None,
        assumes: None,
        note: b.is_none().then(|| why.to_string()),
    }
}

/// `ln Z_X − ln Z_Y` of two per-model evidences of one method.
fn difference(name: &str, kind: EstimateKind, a: &Evidence, b: &Evidence) -> PairEstimate {
    let (ln_b, std_err, note) = match (a.ln_z, b.ln_z) {
        (Some(x), Some(y)) => {
            let err = match (a.std_err, b.std_err) {
                (Some(p), Some(q)) => {
                    Some(match (a.discretisation_shift, b.discretisation_shift) {
                        // thermodynamic integration: the discretisation errors largely cancel in
                        // the difference, so they enter as one, the difference of the shifts
                        (Some(sa), Some(sb)) => {
                            let rest = |se: f64, d: f64| (se * se - d * d).max(0.0);
                            (rest(p, sa) + rest(q, sb) + (sa - sb).powi(2)).sqrt()
                        }
                        _ => p.hypot(q),
                    })
                }
                _ => None,
            };
            // a caveat on either model's number (a tempering run's failed self-check) stays
            let caveats: Vec<&str> = [&a.note, &b.note]
                .into_iter()
                .flatten()
                .map(String::as_str)
                .collect();
            (
                Some(x - y),
                err,
                (!caveats.is_empty()).then(|| caveats.join("; ")),
            )
        }
        _ => (None, None, a.note.clone().or_else(|| b.note.clone())),
    };
    let assumes = match (&a.assumes, &b.assumes) {
        (Some(p), Some(q)) if p != q => Some(format!("X: {p}; Y: {q}")),
        (Some(p), _) => Some(p.clone()),
        _ => None,
    };
    PairEstimate {
        method: name.into(),
        kind,
        ln_b,
        std_err: if kind == EstimateKind::Statistical {
            std_err
        } else {
            None
        },
        agrees: None,
        assumes: ln_b.and(assumes),
        note,
    }
}

/// Adds the two models' corrections from the fixed-noise to the exact θ-dependent evidence
/// (a residual noise that depends on θ, [`ModelOutcome::noise_correction`]) to every row with
/// a number but Schwarz's (whose `ln L` at the MAP needs none: the noise is evaluated
/// there), its error in quadrature on the statistical rows.
fn correct_for_noise(est: &mut [PairEstimate], mx: &ModelOutcome, my: &ModelOutcome) {
    let (cx, cy) = (mx.noise_correction, my.noise_correction);
    if cx.is_none() && cy.is_none() {
        return;
    }
    let shift = cx.map_or(0.0, |c| c.ln_z_shift) - cy.map_or(0.0, |c| c.ln_z_shift);
    let err = cx
        .map_or(0.0, |c| c.std_err)
        .hypot(cy.map_or(0.0, |c| c.std_err));
    let of = |m: &ModelOutcome| {
        m.noise_correction
            .map(|c| format!("{} {:+.3} ± {:.3}", m.name, c.ln_z_shift, c.std_err))
    };
    let what = [of(mx), of(my)].into_iter().flatten().collect::<Vec<_>>();
    let why = format!(
        "includes the correction from the noise held at each model's MAP to the exact θ-dependent likelihood ({}: ln Z shifts {})",
        if what.len() == 2 {
            "both models"
        } else {
            "one model"
        },
        what.join(", ")
    );
    for e in est.iter_mut().filter(|e| e.kind != EstimateKind::Criterion) {
        if let Some(v) = e.ln_b.as_mut() {
            *v += shift;
            if let Some(s) = e.std_err.as_mut() {
                *s = s.hypot(err);
            }
            e.note = Some(match e.note.take() {
                Some(n) => format!("{n}; {why}"),
                None => why.clone(),
            });
        }
    }
}

/// Every estimator's row for models `x`, `y`, the reference and the verdict.
pub(super) fn pair(
    models: &[ModelOutcome],
    rj: Option<&RjResult>,
    rj_note: Option<&str>,
    x: usize,
    y: usize,
) -> PairResult {
    let (mx, my) = (&models[x], &models[y]);
    let mut est = Vec::new();
    let rjp = rj.and_then(|r| r.pair(x, y));
    // without a jump chain every RJ row carries the reason
    let why = |w: &'static str| -> String { rj_note.map_or(w.to_string(), str::to_string) };
    est.push(from_lnb(
        "RJMCMC visits",
        rjp.as_ref().and_then(|p| p.visits),
        &why(
            "a model was never visited: the visit ratio is undefined (see Rao-Blackwell / bridge)",
        ),
    ));
    let mut rb = from_lnb(
        "RJMCMC Rao-Blackwell",
        rjp.as_ref().and_then(|p| p.rao_blackwell),
        &why("no jump proposals in either direction"),
    );
    let one_sided = rjp.as_ref().is_some_and(|p| p.one_sided());
    if rb.ln_b.is_some() && one_sided {
        rb.note = Some(format!(
            "{ONE_SIDED_CAVEAT}; the mean acceptance of the model that proposed no jump set to its bound 1 (exact when jumps out of it are always accepted)"
        ));
    }
    est.push(rb);
    let mut bridge = from_lnb(
        "RJMCMC bridge",
        rjp.as_ref().and_then(|p| p.bridge),
        &why("no in-box proposals between the two models"),
    );
    if bridge.ln_b.is_some() && one_sided {
        bridge.note = Some(ONE_SIDED_CAVEAT.into());
    }
    est.push(bridge);
    let stat = EstimateKind::Statistical;
    est.push(difference(
        "Thermodynamic integration",
        stat,
        &mx.thermodynamic,
        &my.thermodynamic,
    ));
    est.push(difference(
        "Stepping-stone",
        stat,
        &mx.stepping_stone,
        &my.stepping_stone,
    ));
    est.push(difference(
        "Bridge sampling",
        stat,
        &mx.bridge_sampling,
        &my.bridge_sampling,
    ));
    let sys = EstimateKind::Systematic;
    est.push(difference(
        "Laplace-Fisher raw",
        sys,
        &mx.laplace_fisher_raw,
        &my.laplace_fisher_raw,
    ));
    est.push(difference(
        "Laplace-Fisher box",
        sys,
        &mx.laplace_fisher_box,
        &my.laplace_fisher_box,
    ));
    est.push(difference(
        "Laplace-Metropolis MVE",
        sys,
        &mx.laplace_metropolis_mve,
        &my.laplace_metropolis_mve,
    ));
    est.push(difference(
        "Laplace-Metropolis MCD",
        sys,
        &mx.laplace_metropolis_mcd,
        &my.laplace_metropolis_mcd,
    ));
    est.push(PairEstimate {
        method: "Schwarz (SBIC)".into(),
        kind: EstimateKind::Criterion,
        ln_b: Some(mx.schwarz_ln_z - my.schwarz_ln_z),
        std_err: None,
        agrees: None,
        assumes: Some(
            "n → ∞ with every parameter measured; off by O(1) nats by construction".into(),
        ),
        note: None,
    });
    correct_for_noise(&mut est, mx, my);
    let (reference, all_agree, systematic_agree) = judge(&mut est, one_sided);
    name_the_reference(&mut est, &reference);
    let lb = est
        .iter()
        .find(|e| e.method == reference)
        .and_then(|e| e.ln_b)
        .unwrap_or(0.0);
    schwarz_distance(&mut est, &reference, lb);
    let count = |a: usize, b: usize| {
        (
            rj.and_then(|r| r.jumps_proposed.get(a)?.get(b).copied())
                .unwrap_or(0),
            rj.and_then(|r| r.jumps_accepted.get(a)?.get(b).copied())
                .unwrap_or(0),
        )
    };
    let few = rjp.as_ref().filter(|p| p.warning.is_some());
    let unreachable = one_sided && !reference.starts_with("RJMCMC");
    let warning = few
        .filter(|_| !unreachable)
        .and_then(|p| Some(p.warning.clone()? + &jump_advice(&[mx, my])));
    let note = few
        .filter(|_| unreachable)
        .map(|p| unreachable_jumps(p, &mx.name, &my.name, &reference));
    let (pxy, axy) = count(x, y);
    let (pyx, ayx) = count(y, x);
    PairResult {
        x: mx.name.clone(),
        y: my.name.clone(),
        estimates: est,
        reference,
        preferred: if lb >= 0.0 {
            mx.name.clone()
        } else {
            my.name.clone()
        },
        kass_raftery: kass_raftery_named(lb, &mx.name, &my.name),
        all_agree,
        systematic_agree,
        jumps: JumpStats {
            proposed_x_to_y: pxy,
            accepted_x_to_y: axy,
            proposed_y_to_x: pyx,
            accepted_y_to_x: ayx,
            effective_jumps: rjp.as_ref().map_or(0, |p| p.effective_jumps),
            expected_jumps: rjp.as_ref().map_or(0.0, |p| p.expected_jumps),
            warning,
            note,
        },
    }
}

/// The few-jumps note of a pair with a model never visited whose reference needs no jump:
/// how many jumps the run could expect (`Σα`) and how much longer a run would have to be for
/// the visit ratio, instead of advice to run longer (models that far apart exchange no jumps
/// at any practical length, and the answer does not need them).
fn unreachable_jumps(p: &crate::evidence::RjPair, x: &str, y: &str, reference: &str) -> String {
    use crate::evidence::MIN_EFFECTIVE_JUMPS;
    let longer = if p.expected_jumps > 0.0 {
        format!(
            "about {} times this run",
            crate::numfmt::fmt_sig(MIN_EFFECTIVE_JUMPS as f64 / p.expected_jumps, 2)
        )
    } else {
        "more than any run".into()
    };
    format!(
        "only {} accepted jumps between `{x}` and `{y}` after burn-in (< {MIN_EFFECTIVE_JUMPS}), and Σα = {:.3e} expected: the models are too far apart for the jump chain, and {MIN_EFFECTIVE_JUMPS} jumps would take {longer}. The answer does not need them: the reference is {reference}, and the jump rows are one-sided (their notes say what that costs)",
        p.effective_jumps, p.expected_jumps
    )
}

/// Beyond this many nats from the reference, the Schwarz row says so instead of promising
/// "O(1)": the term it drops is then far from a unit's worth.
const SCHWARZ_O1_NATS: f64 = 3.0;

/// Notes on the Schwarz row how far it is from the reference when that is more than O(1):
/// Schwarz drops `ln p(θ̂) + (d/2) ln 2π − ½ ln|F| + (d/2) ln n`, which is O(1) only for
/// priors about as wide as √n Fisher σ (a unit-information prior); for boxes far wider or
/// narrower it is many nats, and the row is then no more than an order-of-magnitude rule.
fn schwarz_distance(est: &mut [PairEstimate], reference: &str, ref_ln_b: f64) {
    if reference == "Schwarz (SBIC)" {
        return;
    }
    if let Some(e) = est.iter_mut().find(|e| e.method == "Schwarz (SBIC)")
        && let Some(v) = e.ln_b
        && (v - ref_ln_b).abs() > SCHWARZ_O1_NATS
    {
        e.note = Some(format!(
            "assumes n → ∞ with every parameter measured and a prior as wide as √n Fisher σ; here {} nats from the reference ({reference}), more than the O(1) it allows: the prior boxes of the parameters that differ are far from that width, and the term Schwarz drops for them (the prior volume against the likelihood width) is large — an order-of-magnitude rule, not judged",
            crate::report::fmt_fixed((v - ref_ln_b).abs(), 1)
        ));
    }
}

/// The part of the few-jumps advice that depends on where the jump proposals came from:
/// proposals centred on the in-model chains (the default, `jump_proposal = "chain"`) need
/// no advice; a model whose proposal fell back to the Fisher matrix or the prior is named.
fn jump_advice(models: &[&ModelOutcome]) -> String {
    let off: Vec<String> = models
        .iter()
        .filter(|m| m.jump_proposal != "in-model chains")
        .map(|m| format!("`{}`'s comes from the {}", m.name, m.jump_proposal))
        .collect();
    if off.is_empty() {
        String::new()
    } else {
        format!(
            "; the jump proposals are not centred on the in-model chains' mean and covariance, which land better: {} (see the model's notes)",
            off.join(", ")
        )
    }
}

/// Picks the reference and marks agreement (module docs); returns the reference's name, the
/// statistical verdict and the systematic one.
fn judge(est: &mut [PairEstimate], one_sided: bool) -> (String, bool, Option<bool>) {
    let order: &[&str] = if one_sided {
        &ONE_SIDED_REFERENCE_ORDER
    } else {
        &REFERENCE_ORDER
    };
    let r = order
        .iter()
        .find_map(|m| est.iter().position(|e| e.method == *m && e.ln_b.is_some()));
    let Some(r) = r else {
        return ("none".into(), false, None);
    };
    let (rv, re) = (est[r].ln_b.unwrap_or(0.0), est[r].std_err.unwrap_or(0.0));
    let mut all_agree = true;
    let mut sys: Option<bool> = None;
    for (i, e) in est.iter_mut().enumerate() {
        let Some(v) = e.ln_b else { continue };
        if i == r {
            continue;
        }
        match e.kind {
            EstimateKind::Statistical => {
                let ok = (v - rv).abs() <= 2.0 * e.std_err.unwrap_or(0.0).hypot(re);
                e.agrees = Some(ok);
                all_agree &= ok;
            }
            EstimateKind::Systematic => {
                let ok = (v - rv).abs() <= 1.0 + 2.0 * re;
                e.agrees = Some(ok);
                sys = Some(sys.unwrap_or(true) && ok);
            }
            EstimateKind::Criterion => {}
        }
    }
    (est[r].method.clone(), all_agree, sys)
}

/// Posterior model probabilities `P(k|y) ∝ P(k) Z_k` from the reference `ln B` of every pair
/// (0, k); `None` when a pair has no reference number.
pub(super) fn posterior_probabilities(
    models: &[ModelOutcome],
    pairs: &[PairResult],
) -> Option<Vec<f64>> {
    let mut ln_w = vec![models[0].prior_probability.ln()];
    for (k, m) in models.iter().enumerate().skip(1) {
        let p = pairs
            .iter()
            .find(|p| p.x == models[0].name && p.y == m.name)?;
        let lb = p
            .estimates
            .iter()
            .find(|e| e.method == p.reference)
            .and_then(|e| e.ln_b)?;
        assert_eq!(m.name, models[k].name);
        ln_w.push(m.prior_probability.ln() - lb);
    }
    let mx = ln_w.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let s: f64 = ln_w.iter().map(|w| (w - mx).exp()).sum();
    Some(ln_w.iter().map(|w| (w - mx).exp() / s).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(method: &str, kind: EstimateKind, v: Option<f64>, e: Option<f64>) -> PairEstimate {
        PairEstimate {
            method: method.into(),
            kind,
            ln_b: v,
            std_err: e,
            agrees: None,
            assumes: None,
            note: None,
        }
    }

    #[test]
    fn reference_falls_through_the_documented_order() {
        use EstimateKind::*;
        let mut est = vec![
            row("RJMCMC visits", Statistical, None, None),
            row("RJMCMC bridge", Statistical, None, None),
            row("Stepping-stone", Statistical, Some(-2.0), Some(0.05)),
            row(
                "Thermodynamic integration",
                Statistical,
                Some(-2.08),
                Some(0.05),
            ),
            row("Laplace-Fisher box", Systematic, Some(-2.9), None),
            row("Schwarz (SBIC)", Criterion, Some(-9.0), None),
        ];
        let (r, all, sys) = judge(&mut est, false);
        assert_eq!(r, "Stepping-stone");
        // 0.08 < 2·hypot(0.05, 0.05) = 0.141: agrees
        assert!(all);
        assert_eq!(est[3].agrees, Some(true));
        // 0.9 ≤ 1 + 2·0.05: the systematic row is consistent; Schwarz is never judged
        assert_eq!(sys, Some(true));
        assert_eq!(est[5].agrees, None);
        // a statistical row 0.2 nat away with tiny errors disagrees
        est[3].ln_b = Some(-2.2);
        est[3].std_err = Some(0.01);
        let (_, all, _) = judge(&mut est, false);
        assert!(!all);
        // nothing with a number: no reference, no verdict
        let mut none = vec![row("RJMCMC bridge", Statistical, None, None)];
        assert_eq!(judge(&mut none, false).0, "none");
    }

    /// Bridge sampling is the reference after a two-sided RJ bridge, and before it when a
    /// model was never visited (the jump rows one-sided); without it the tempering rows are.
    #[test]
    fn with_a_model_never_visited_bridge_sampling_is_the_reference() {
        use EstimateKind::*;
        let rows = || {
            vec![
                row(
                    "RJMCMC Rao-Blackwell",
                    Statistical,
                    Some(-16.84),
                    Some(0.05),
                ),
                row("RJMCMC bridge", Statistical, Some(-16.84), Some(0.05)),
                row("Stepping-stone", Statistical, Some(-16.5), Some(0.11)),
                row("Bridge sampling", Statistical, Some(-16.62), Some(0.012)),
            ]
        };
        let mut est = rows();
        let (r, all, _) = judge(&mut est, true);
        assert_eq!(r, "Bridge sampling");
        // the one-sided rows 4.3σ off are judged against it, and disagree
        assert!(!all);
        assert_eq!(est[1].agrees, Some(false));
        assert_eq!(est[2].agrees, Some(true));
        let mut est = rows();
        assert_eq!(judge(&mut est, false).0, "RJMCMC bridge");
        let mut est = rows();
        est.pop();
        assert_eq!(judge(&mut est, true).0, "Stepping-stone");
        let mut est = rows();
        est[1].ln_b = None;
        assert_eq!(judge(&mut est, false).0, "Bridge sampling");
        // one-sided rows alone still give a reference
        let mut est = rows();
        est.truncate(2);
        assert_eq!(judge(&mut est, true).0, "RJMCMC bridge");
        // the caveat names the reference that took over
        let mut est = rows();
        est.pop();
        est[1].note = Some(ONE_SIDED_CAVEAT.into());
        let (r, _, _) = judge(&mut est, true);
        name_the_reference(&mut est, &r);
        let n = est[1].note.as_deref().unwrap();
        assert!(n.ends_with("the reference is Stepping-stone"), "{n}");
        let mut est = rows();
        est[1].note = Some(ONE_SIDED_CAVEAT.into());
        name_the_reference(&mut est, "Bridge sampling");
        assert_eq!(est[1].note.as_deref(), Some(ONE_SIDED_CAVEAT));
    }

    /// Models too far apart for any jump (issue 52): the warning says how many jumps the run
    /// could expect and that the answer needs none, instead of advice to run longer.
    #[test]
    fn a_pair_too_far_apart_for_jumps_says_the_answer_needs_none() {
        let p = crate::evidence::RjPair {
            k: 0,
            l: 1,
            visits: None,
            rao_blackwell: None,
            bridge: None,
            proposals_k_to_l: 0,
            proposals_l_to_k: 48_000,
            accepted_k_to_l: 0,
            accepted_l_to_k: 0,
            effective_jumps: 0,
            expected_jumps: 0.048,
            warning: Some("only 0 accepted jumps".into()),
            note: None,
        };
        let w = unreachable_jumps(&p, "X", "Y", "Bridge sampling");
        assert!(
            w.starts_with("only 0 accepted jumps between `X` and `Y` after burn-in (< 30)")
                && w.contains("Σα = 4.800e-2 expected")
                && w.contains("30 jumps would take about 630 times this run")
                && w.contains("the reference is Bridge sampling")
                && !w.contains("run longer")
                && !w.contains("defensive"),
            "{w}"
        );
        let none = crate::evidence::RjPair {
            expected_jumps: 0.0,
            ..p
        };
        assert!(unreachable_jumps(&none, "X", "Y", "Stepping-stone").contains("more than any run"));
    }

    fn outcome(name: &str, ln_z: Option<f64>) -> ModelOutcome {
        let ev = |v: Option<f64>, se: Option<f64>| Evidence {
            ln_z: v,
            std_err: se,
            integration_err: None,
            discretisation_shift: None,
            assumes: v.map(|_| "a Gaussian".into()),
            note: v.is_none().then(|| "does not apply here".into()),
        };
        ModelOutcome {
            name: name.into(),
            model: "ltp".into(),
            params: vec!["a".into()],
            units: vec![String::new()],
            free: vec!["a".into()],
            prior_probability: 1.0,
            map: vec![0.0],
            map_found: true,
            missing_injection_bias: None,
            map_at_bound: vec![],
            estimates: vec![],
            relbin: None,
            ln_l_map: 0.0,
            unbounded_max: None,
            min_margin_sigma: 0.0,
            laplace_fisher_raw: ev(None, None),
            laplace_fisher_box: ev(ln_z, None),
            laplace_metropolis_mve: ev(ln_z, None),
            laplace_metropolis_mcd: ev(ln_z, None),
            thermodynamic: ev(ln_z.map(|v| v + 0.01), Some(0.02)),
            stepping_stone: ev(ln_z, Some(0.02)),
            // no number unless a test gives one: the tests below judge the other rows
            bridge_sampling: ev(None, None),
            tempering: None,
            schwarz_ln_z: 0.0,
            mcmc_acceptance: vec![],
            mcmc_max_rhat: None,
            mcmc_iterations: None,
            jump_proposal: "in-model chains".into(),
            unstable_evaluations: 0,
            noise_correction: None,
            notes: vec![],
        }
    }

    /// Thermodynamic integration's ln B error takes the difference of the two models'
    /// signed discretisation errors, not each in quadrature; the other rows are unchanged.
    #[test]
    fn the_ti_discretisation_error_enters_a_bayes_factor_once() {
        let mut models = [outcome("X", Some(-3.0)), outcome("Y", Some(-1.0))];
        // per model: Monte-Carlo 0.02, discretisation +0.05 and +0.04
        for (m, d) in models.iter_mut().zip([0.05, 0.04]) {
            m.thermodynamic.std_err = Some(0.02f64.hypot(d));
            m.thermodynamic.integration_err = Some(d);
            m.thermodynamic.discretisation_shift = Some(d);
        }
        let p = pair(&models, None, Some("no chain"), 0, 1);
        let row = |m: &str| p.estimates.iter().find(|e| e.method == m).unwrap().std_err;
        let ti = row("Thermodynamic integration").unwrap();
        let want = (2.0 * 0.02f64.powi(2) + 0.01f64.powi(2)).sqrt();
        assert!((ti - want).abs() < 1e-15, "{ti} vs {want}");
        // opposite signs add: the per-model quadrature would understate it
        models[1].thermodynamic.discretisation_shift = Some(-0.04);
        let p = pair(&models, None, Some("no chain"), 0, 1);
        let ti = p.estimates[3].std_err.unwrap();
        assert!((ti - (2.0 * 0.02f64.powi(2) + 0.09f64.powi(2)).sqrt()).abs() < 1e-15);
        assert_eq!(p.estimates[4].std_err, Some(0.02f64.hypot(0.02)));
    }

    /// A failed reversible-jump run leaves its reason on the three RJ rows; every other
    /// estimator still reports, and the reference falls through to stepping-stone.
    #[test]
    fn without_a_jump_chain_the_other_estimators_still_decide() {
        let models = [outcome("X", Some(-3.0)), outcome("Y", Some(-1.0))];
        let why = "the reversible-jump chain did not run: because";
        let p = pair(&models, None, Some(why), 0, 1);
        for m in ["RJMCMC visits", "RJMCMC Rao-Blackwell", "RJMCMC bridge"] {
            let e = p.estimates.iter().find(|e| e.method == m).unwrap();
            assert!(e.ln_b.is_none() && e.note.as_deref() == Some(why), "{e:?}");
        }
        assert_eq!(p.reference, "Stepping-stone");
        assert_eq!(p.preferred, "Y");
        assert_eq!(p.kass_raftery, "positive evidence for Y over X");
        assert!(p.all_agree);
        assert_eq!(p.systematic_agree, Some(true));
        // the raw Laplace row has no number and says why; Laplace rows carry no ± value
        let raw = p
            .estimates
            .iter()
            .find(|e| e.method == "Laplace-Fisher raw")
            .unwrap();
        assert!(raw.ln_b.is_none() && raw.note.is_some());
        let lf = p
            .estimates
            .iter()
            .find(|e| e.method == "Laplace-Fisher box")
            .unwrap();
        assert_eq!((lf.ln_b, lf.std_err), (Some(-2.0), None));
        assert!(lf.assumes.is_some());
        // posterior model probabilities from the reference: P(Y)/P(X) = e²
        let pp = posterior_probabilities(&models, &[p]).unwrap();
        assert!((pp[1] / pp[0] - 2f64.exp()).abs() < 1e-12);
    }

    /// Agreement within 2σ and a marginal 3σ disagreement leave the run valid; a row 6σ from
    /// the reference fails it, naming the row; Laplace rows (no error bar) never do.
    #[test]
    fn a_gross_disagreement_is_named_and_a_marginal_one_is_not() {
        let models = [outcome("X", Some(-3.0)), outcome("Y", Some(-1.0))];
        let mut p = pair(&models, None, Some("no RJ"), 0, 1);
        assert_eq!(p.gross_disagreement(), None);
        let set = |p: &mut PairResult, m: &str, v: f64, e: Option<f64>| {
            let row = p.estimates.iter_mut().find(|r| r.method == m).unwrap();
            (row.ln_b, row.std_err) = (Some(v), e);
        };
        set(&mut p, "Stepping-stone", 2.0, Some(0.3));
        set(
            &mut p,
            "Thermodynamic integration",
            2.0 + 3.0 * 0.5,
            Some(0.4),
        );
        set(&mut p, "Laplace-Fisher box", 40.0, None);
        assert_eq!(p.reference, "Stepping-stone");
        assert_eq!(p.gross_disagreement(), None, "3σ is marginal");
        set(&mut p, "RJMCMC visits", 40.0, None);
        assert_eq!(p.gross_disagreement(), None, "no error bar, no promise");
        set(
            &mut p,
            "Thermodynamic integration",
            2.0 + 6.0 * 0.5,
            Some(0.4),
        );
        // a one-sided jump row 6σ off is marked, and leaves the run standing
        set(&mut p, "RJMCMC bridge", 2.0 + 6.0 * 0.5, Some(0.4));
        p.estimates
            .iter_mut()
            .find(|r| r.method == "RJMCMC bridge")
            .unwrap()
            .note = Some(ONE_SIDED_CAVEAT.into());
        let why = p.gross_disagreement().expect("6σ fails");
        assert!(!why.contains("RJMCMC"), "{why}");
        assert!(
            why.starts_with("X/Y: Thermodynamic integration 5.00 ± 0.40 (6.0 σ)")
                && why.contains("reference Stepping-stone 2.00 ± 0.30")
                && !why.contains("Laplace"),
            "{why}"
        );
    }

    #[test]
    fn schwarz_says_when_it_is_more_than_o1_from_the_reference() {
        let schwarz = |models: &mut [ModelOutcome; 2], x: f64, y: f64| {
            models[0].schwarz_ln_z = x;
            models[1].schwarz_ln_z = y;
            let p = pair(models, None, Some("no RJ"), 0, 1);
            let e = p
                .estimates
                .into_iter()
                .find(|e| e.method == "Schwarz (SBIC)")
                .unwrap();
            (p.reference, e)
        };
        let mut models = [outcome("X", Some(-3.0)), outcome("Y", Some(-1.0))];
        // the reference (stepping-stone) says −2.0; Schwarz −2.5: within O(1), no note
        let (r, e) = schwarz(&mut models, -2.5, 0.0);
        assert_eq!(r, "Stepping-stone");
        assert!(e.note.is_none(), "{e:?}");
        assert!(e.assumes.unwrap().contains("O(1)"));
        // Schwarz −12.6: 10.6 nats from the reference, and the row says so
        let (_, e) = schwarz(&mut models, -12.6, 0.0);
        let n = e.note.expect("a note");
        assert!(
            n.contains("here 10.6 nats from the reference (Stepping-stone), more than the O(1)"),
            "{n}"
        );
        // just beyond the threshold on the other side
        let (_, e) = schwarz(&mut models, 1.01, 0.0);
        assert!(e.note.is_some());
        let (_, e) = schwarz(&mut models, 0.99, 0.0);
        assert!(e.note.is_none());
    }

    #[test]
    fn the_few_jumps_advice_names_only_proposals_that_are_not_the_chains() {
        let mut x = outcome("X", Some(0.0));
        let y = outcome("Y", Some(0.0));
        assert_eq!(jump_advice(&[&x, &y]), "");
        x.jump_proposal = "Fisher matrix at the MAP".into();
        let a = jump_advice(&[&x, &y]);
        assert!(
            a.contains("`X`'s comes from the Fisher matrix at the MAP") && !a.contains("`Y`"),
            "{a}"
        );
    }
}
