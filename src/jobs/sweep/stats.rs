//! A grid point's numbers over its noise realisations: per estimator the median ln B and its
//! 16–84 % band, how often each model is picked, how often the estimators agree.

use super::record::{Outcome, TaskRecord};
use serde::Serialize;

/// The name of the pseudo-estimator that takes, in each realisation, that realisation's
/// reference row (the first row with a number in select's reference order).
pub const REFERENCE: &str = "reference";

/// Quantile `q` of sorted finite values by linear interpolation between order statistics
/// (Hyndman–Fan type 7, numpy's default).
pub fn quantile(sorted: &[f64], q: f64) -> f64 {
    let n = sorted.len();
    assert!(n > 0);
    let h = (n - 1) as f64 * q;
    let lo = h.floor() as usize;
    let hi = (lo + 1).min(n - 1);
    sorted[lo] + (h - lo as f64) * (sorted[hi] - sorted[lo])
}

/// One estimator at one point.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EstimatorStats {
    pub method: String,
    /// Realisations in which the estimator gave a number.
    pub n: usize,
    pub median: Option<f64>,
    pub q16: Option<f64>,
    pub q84: Option<f64>,
    /// Fraction of those realisations with ln B_XY > 0 (X favoured).
    pub favours_x: Option<f64>,
    /// Fraction of those realisations that favour the sweep's true model (when it is X or Y).
    pub favours_truth: Option<f64>,
}

/// One pair at one point.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PairStats {
    pub x: String,
    pub y: String,
    /// The reference pseudo-estimator first, then every estimator in select's row order.
    pub estimators: Vec<EstimatorStats>,
    /// Fraction of realisations whose statistical estimators agree within their errors.
    pub agree: f64,
    /// Fraction whose Laplace-type estimates agree with the reference (of those judged).
    pub systematic_agree: Option<f64>,
}

/// One grid point.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PointStats {
    pub index: usize,
    pub values: Vec<f64>,
    pub realisations: usize,
    /// Realisations without numbers, and the first one's reason.
    pub failed: usize,
    pub first_error: Option<String>,
    /// Fraction of realisations in which each model has the highest posterior probability.
    pub picks: Vec<f64>,
    /// `picks` of the sweep's true model.
    pub correct: Option<f64>,
    pub rho_opt_median: Option<f64>,
    pub pairs: Vec<PairStats>,
}

fn fraction(k: usize, n: usize) -> Option<f64> {
    (n > 0).then(|| k as f64 / n as f64)
}

fn estimator(method: &str, values: &[f64], truth_sign: Option<f64>) -> EstimatorStats {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    v.sort_by(f64::total_cmp);
    let q = |p: f64| (!v.is_empty()).then(|| quantile(&v, p));
    EstimatorStats {
        method: method.into(),
        n: v.len(),
        median: q(0.5),
        q16: q(0.16),
        q84: q(0.84),
        favours_x: fraction(v.iter().filter(|x| **x > 0.0).count(), v.len()),
        favours_truth: truth_sign
            .and_then(|s| fraction(v.iter().filter(|x| **x * s > 0.0).count(), v.len())),
    }
}

/// The statistics of point `index` from its records (one per realisation); `models` and
/// `methods[k]` (pair k's row names) fix the order, `truth` names the true model.
pub fn point_stats(
    index: usize,
    values: &[f64],
    records: &[&TaskRecord],
    models: &[String],
    methods: &[Vec<String>],
    truth: Option<&str>,
) -> PointStats {
    let ok: Vec<&Outcome> = records.iter().filter_map(|r| r.outcome.as_ref()).collect();
    let failed = records.len() - ok.len();
    let first_error = records.iter().find_map(|r| r.error.clone());
    let mut picks = vec![0usize; models.len()];
    let mut picked = 0;
    for o in &ok {
        if let Some(k) = o.pick()
            && k < picks.len()
        {
            picks[k] += 1;
            picked += 1;
        }
    }
    let picks: Vec<f64> = picks
        .iter()
        .map(|&k| fraction(k, picked).unwrap_or(f64::NAN))
        .collect();
    let correct = truth
        .and_then(|t| models.iter().position(|m| m == t))
        .map(|k| picks[k]);
    let mut rho: Vec<f64> = ok
        .iter()
        .filter_map(|o| o.rho_opt)
        .filter(|v| v.is_finite())
        .collect();
    rho.sort_by(f64::total_cmp);
    let pairs = methods
        .iter()
        .enumerate()
        .map(|(k, names)| {
            let pair = |o: &&Outcome| o.pairs.get(k).cloned();
            let ps: Vec<_> = ok.iter().filter_map(pair).collect();
            let (x, y) = ps
                .first()
                .map(|p| (p.x.clone(), p.y.clone()))
                .unwrap_or_default();
            let truth_sign = truth.and_then(|t| {
                if t == x {
                    Some(1.0)
                } else if t == y {
                    Some(-1.0)
                } else {
                    None
                }
            });
            let reference: Vec<f64> = ps
                .iter()
                .map(|p| p.reference_ln_b().unwrap_or(f64::NAN))
                .collect();
            let mut estimators = vec![estimator(REFERENCE, &reference, truth_sign)];
            for name in names {
                let v: Vec<f64> = ps
                    .iter()
                    .map(|p| {
                        p.estimates
                            .iter()
                            .find(|e| &e.method == name)
                            .and_then(|e| e.ln_b)
                            .unwrap_or(f64::NAN)
                    })
                    .collect();
                estimators.push(estimator(name, &v, truth_sign));
            }
            let judged: Vec<bool> = ps.iter().filter_map(|p| p.systematic_agree).collect();
            PairStats {
                x,
                y,
                estimators,
                agree: fraction(ps.iter().filter(|p| p.all_agree).count(), ps.len())
                    .unwrap_or(f64::NAN),
                systematic_agree: fraction(judged.iter().filter(|b| **b).count(), judged.len()),
            }
        })
        .collect();
    PointStats {
        index,
        values: values.to_vec(),
        realisations: records.len(),
        failed,
        first_error,
        picks,
        correct,
        rho_opt_median: (!rho.is_empty()).then(|| quantile(&rho, 0.5)),
        pairs,
    }
}

/// On a 1-D sweep with a known true model: the smallest axis value from which on, at every
/// point, the reference's median ln B favours the truth by at least "positive evidence"
/// (Kass–Raftery, |ln B| > 1) and the statistical estimators agree in at least half the
/// realisations (the paper's "SNR above which the estimators agree and the right model
/// wins"). `None` if the last point already fails.
pub fn threshold(points: &[PointStats], pair: usize, truth: &str) -> Option<f64> {
    let good = |p: &PointStats| {
        let Some(ps) = p.pairs.get(pair) else {
            return false;
        };
        let sign = if ps.x == truth {
            1.0
        } else if ps.y == truth {
            -1.0
        } else {
            return false;
        };
        ps.estimators[0].median.is_some_and(|m| m * sign > 1.0) && ps.agree >= 0.5
    };
    let mut idx: Vec<usize> = (0..points.len()).collect();
    idx.sort_by(|&a, &b| points[a].values[0].total_cmp(&points[b].values[0]));
    let mut from = None;
    for &i in idx.iter().rev() {
        if good(&points[i]) {
            from = Some(points[i].values[0]);
        } else {
            break;
        }
    }
    from
}

#[cfg(test)]
mod tests {
    use super::super::record::{Estimate, Pair, TaskId};
    use super::*;
    use crate::jobs::select::EstimateKind;

    #[test]
    fn quantiles_match_numpy() {
        // numpy.quantile([1, 2, 4, 8, 16], [0.16, 0.5, 0.84]) = [1.64, 4.0, 10.88]
        let v = [1.0, 2.0, 4.0, 8.0, 16.0];
        assert!((quantile(&v, 0.16) - 1.64).abs() < 1e-12);
        assert_eq!(quantile(&v, 0.5), 4.0);
        assert!((quantile(&v, 0.84) - 10.88).abs() < 1e-12);
        assert_eq!(quantile(&[3.0], 0.84), 3.0);
    }

    fn record(r: usize, ref_lnb: Option<f64>, lf: Option<f64>, agree: bool) -> TaskRecord {
        let est = |m: &str, v: Option<f64>| Estimate {
            method: m.into(),
            kind: EstimateKind::Statistical,
            ln_b: v,
            std_err: Some(0.1),
            agrees: None,
        };
        let p_x = ref_lnb.map(|l| 1.0 / (1.0 + (-l).exp()));
        TaskRecord {
            id: TaskId {
                study: "s".into(),
                keys: vec![],
                values: vec![],
                realisation: r,
                seed: r as u64,
            },
            outcome: Some(Outcome {
                models: vec!["X".into(), "Y".into()],
                pairs: vec![Pair {
                    x: "X".into(),
                    y: "Y".into(),
                    reference: "bridge".into(),
                    preferred: String::new(),
                    kass_raftery: String::new(),
                    all_agree: agree,
                    systematic_agree: Some(true),
                    estimates: vec![est("bridge", ref_lnb), est("LF", lf)],
                }],
                posterior_model_probabilities: p_x.map(|p| vec![p, 1.0 - p]),
                rho_opt: Some(10.0 + r as f64),
                rho_opt_simulated: None,
                rj_visits: None,
                warnings: vec![],
            }),
            error: None,
        }
    }

    #[test]
    fn a_point_over_realisations_with_gaps_and_failures() {
        let mut recs = vec![
            record(0, Some(-2.0), Some(-1.0), true),
            record(1, Some(1.0), None, false),
            record(2, Some(-4.0), Some(-3.0), true),
            record(3, Some(-3.0), None, true),
        ];
        recs.push(TaskRecord {
            id: recs[0].id.clone(),
            outcome: None,
            error: Some("loop unstable".into()),
        });
        let refs: Vec<&TaskRecord> = recs.iter().collect();
        let methods = vec![vec!["bridge".to_string(), "LF".to_string()]];
        let models = vec!["X".to_string(), "Y".to_string()];
        let s = point_stats(3, &[20.0], &refs, &models, &methods, Some("Y"));
        assert_eq!((s.realisations, s.failed), (5, 1));
        assert_eq!(s.first_error.as_deref(), Some("loop unstable"));
        assert_eq!(s.picks, vec![0.25, 0.75]);
        assert_eq!(s.correct, Some(0.75));
        let p = &s.pairs[0];
        assert_eq!(p.agree, 0.75);
        let r = &p.estimators[0];
        assert_eq!(r.method, REFERENCE);
        assert_eq!(r.n, 4);
        assert_eq!(r.median, Some(-2.5));
        assert_eq!(r.favours_x, Some(0.25));
        assert_eq!(r.favours_truth, Some(0.75));
        let lf = &p.estimators[2];
        assert_eq!((lf.n, lf.median), (2, Some(-2.0)));
        assert_eq!(s.rho_opt_median, Some(11.5));
    }

    #[test]
    fn threshold_is_where_the_truth_wins_from_then_on() {
        let models = vec!["X".to_string(), "Y".to_string()];
        let methods = vec![vec!["bridge".to_string()]];
        let mk = |i: usize, v: f64, lnb: f64, agree: bool| {
            let recs = [record(0, Some(lnb), None, agree)];
            let refs: Vec<&TaskRecord> = recs.iter().collect();
            point_stats(i, &[v], &refs, &models, &methods, Some("Y"))
        };
        // truth Y: ln B_XY < 0 wins; disagreement at 40 breaks the run above 20
        let pts = vec![
            mk(0, 5.0, 0.5, true),
            mk(1, 10.0, -1.5, true),
            mk(2, 20.0, -3.0, true),
            mk(3, 40.0, -9.0, false),
            mk(4, 80.0, -20.0, true),
        ];
        assert_eq!(threshold(&pts, 0, "Y"), Some(80.0));
        let mut fixed = pts.clone();
        fixed[3] = mk(3, 40.0, -9.0, true);
        assert_eq!(threshold(&fixed, 0, "Y"), Some(10.0));
        fixed[1] = mk(1, 10.0, -0.9, true);
        assert_eq!(
            threshold(&fixed, 0, "Y"),
            Some(20.0),
            "a bare mention is no win"
        );
        fixed[4] = mk(4, 80.0, 2.0, true);
        assert_eq!(threshold(&fixed, 0, "Y"), None);
    }
}
