//! The scale a study's `target_snr` is written in (`[simulation] snr_definition`).
//!
//! occam's SNR is the optimal one, ρ_opt = √⟨h|h⟩ over `snr_band` (natural units: the
//! likelihood-ratio scale, ⟨h|h⟩ = 2 ln Λ at the truth for noiseless data). Other tools and
//! papers quote the same quantity on other scales; a study can name the scale its number is
//! in, and the simulator converts it to ρ_opt before it scales the injections. K14 does not
//! say which scale its "SNR ≈ 5 / 21 / 28" are on: none of these maps all three onto the
//! regimes occam finds (the book's "What was measured", "The SNR behind K14's numbers").

use serde::{Deserialize, Serialize};

/// How a `target_snr` is to be read.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum SnrDefinition {
    /// ρ_opt = √⟨h|h⟩ itself (the default).
    #[default]
    Optimal,
    /// √2·ρ_opt, the scale of LTPDA's `stnr` (ltp-model.md §10, item 3).
    LtpdaStnr,
    /// Decibels, 20·log10 ρ_opt (the old LTPDA `loglikelihood_matrix` printout).
    Db,
}

impl SnrDefinition {
    /// The ρ_opt a value on this scale stands for.
    ///
    /// ```
    /// use occam::experiment::SnrDefinition;
    /// assert_eq!(SnrDefinition::Optimal.to_optimal(28.0), 28.0);
    /// assert!((SnrDefinition::LtpdaStnr.to_optimal(28.0) - 28.0 / 2f64.sqrt()).abs() < 1e-12);
    /// assert!((SnrDefinition::Db.to_optimal(20.0) - 10.0).abs() < 1e-12);
    /// ```
    pub fn to_optimal(self, value: f64) -> f64 {
        match self {
            SnrDefinition::Optimal => value,
            SnrDefinition::LtpdaStnr => value / std::f64::consts::SQRT_2,
            SnrDefinition::Db => 10f64.powf(value / 20.0),
        }
    }

    /// A ρ_opt on this scale (the inverse of [`SnrDefinition::to_optimal`]).
    pub fn from_optimal(self, rho: f64) -> f64 {
        match self {
            SnrDefinition::Optimal => rho,
            SnrDefinition::LtpdaStnr => rho * std::f64::consts::SQRT_2,
            SnrDefinition::Db => 20.0 * rho.log10(),
        }
    }

    /// The name a study file writes.
    pub fn name(self) -> &'static str {
        match self {
            SnrDefinition::Optimal => "optimal",
            SnrDefinition::LtpdaStnr => "ltpda_stnr",
            SnrDefinition::Db => "db",
        }
    }

    /// Whether this is the default (so that a study file that does not set it writes nothing).
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_scale_inverts_and_a_study_file_names_it() {
        for d in [
            SnrDefinition::Optimal,
            SnrDefinition::LtpdaStnr,
            SnrDefinition::Db,
        ] {
            for rho in [0.3, 1.0, 5.0, 28.0, 450.0] {
                let x = d.from_optimal(rho);
                assert!((d.to_optimal(x) - rho).abs() < 1e-12 * rho, "{d:?} {rho}");
            }
        }
        assert_eq!(
            SnrDefinition::LtpdaStnr.from_optimal(5.0),
            5.0 * 2f64.sqrt()
        );
        // 0 dB is ρ_opt = 1, not 0
        assert_eq!(SnrDefinition::Db.to_optimal(0.0), 1.0);
        assert_eq!(SnrDefinition::Db.to_optimal(-20.0), 0.1);
        for d in [SnrDefinition::LtpdaStnr, SnrDefinition::Db] {
            let text = format!("snr_definition = \"{}\"", d.name());
            #[derive(serde::Deserialize)]
            struct T {
                snr_definition: SnrDefinition,
            }
            assert_eq!(toml::from_str::<T>(&text).unwrap().snr_definition, d);
        }
    }
}
