//! What each competing model says about its own parameters: the MAP, the in-model chains'
//! posterior mean and standard deviation, and the Cramér–Rao (Fisher) σ at the MAP — what a
//! `fit` of that model would print, so that a select run answers "and what does each model
//! estimate?" without a second run.

use nalgebra::DMatrix;
use serde::{Deserialize, Serialize};

/// One free parameter's estimates under one model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ParamEstimate {
    pub name: String,
    /// SI unit (empty: dimensionless or not stated by the model).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub unit: String,
    /// The MAP (the search's start point when it found none: see the model's `map_found`).
    pub map: f64,
    /// Pooled posterior mean and standard deviation of the in-model chains (absent when they
    /// did not run).
    pub mean: Option<f64>,
    pub sd: Option<f64>,
    /// `√(F⁻¹)ᵢᵢ` at the MAP (absent when the Fisher matrix is singular there).
    pub fisher_sigma: Option<f64>,
}

/// The estimates of the free parameters `free` (indices into the full vector `map`, names
/// `names`, units `units` of the full vector), from the chains' pooled means and standard
/// deviations (over the free parameters, in order) and the inverse Fisher matrix (free × free).
pub(super) fn param_estimates(
    names: &[String],
    units: &[String],
    free: &[usize],
    map: &[f64],
    chains: Option<(&[f64], &[f64])>,
    fisher_cov: Option<&DMatrix<f64>>,
) -> Vec<ParamEstimate> {
    free.iter()
        .enumerate()
        .map(|(j, &i)| ParamEstimate {
            name: names[i].clone(),
            unit: units.get(i).cloned().unwrap_or_default(),
            map: map[i],
            mean: chains.and_then(|(m, _)| m.get(j).copied()),
            sd: chains.and_then(|(_, s)| s.get(j).copied()),
            fisher_sigma: fisher_cov
                .map(|c| c[(j, j)])
                .filter(|v| *v >= 0.0)
                .map(f64::sqrt),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn free_parameters_take_their_own_chain_column_and_fisher_diagonal() {
        let names: Vec<String> = ["a", "b", "c"].iter().map(|s| s.to_string()).collect();
        let units: Vec<String> = ["s", "", "s⁻²"].iter().map(|s| s.to_string()).collect();
        let (mean, sd) = ([1.5, -3.0], [0.1, 0.2]);
        let cov = DMatrix::from_row_slice(2, 2, &[0.04, 0.01, 0.01, 0.09]);
        let e = param_estimates(
            &names,
            &units,
            &[0, 2],
            &[1.4, 7.0, -2.9],
            Some((&mean[..], &sd[..])),
            Some(&cov),
        );
        assert_eq!(e.len(), 2);
        assert_eq!((e[0].name.as_str(), e[0].unit.as_str()), ("a", "s"));
        assert_eq!((e[1].name.as_str(), e[1].unit.as_str()), ("c", "s⁻²"));
        assert_eq!((e[0].map, e[1].map), (1.4, -2.9));
        assert_eq!((e[0].mean, e[1].sd), (Some(1.5), Some(0.2)));
        assert_eq!(e[0].fisher_sigma, Some(0.2));
        assert!((e[1].fisher_sigma.unwrap() - 0.3).abs() < 1e-15);
        // without chains or a Fisher inverse the MAP is all there is
        let e = param_estimates(&names, &units, &[1], &[1.4, 7.0, -2.9], None, None);
        assert_eq!(
            e[0],
            ParamEstimate {
                name: "b".into(),
                unit: String::new(),
                map: 7.0,
                mean: None,
                sd: None,
                fisher_sigma: None,
            }
        );
    }
}
