//! Checks of two validation examples' own helpers. They were `#[test]`s inside `examples/`,
//! which `cargo test` never runs (issue 49). The examples are compiled here as modules; their
//! `main` is not called.

#[allow(dead_code)]
#[path = "../examples/evidence_validation.rs"]
mod evidence_validation;
#[allow(dead_code)]
#[path = "../examples/tempering_calibration.rs"]
mod tempering_calibration;

use nalgebra::DMatrix;
use occam::config::Study;
use occam::linalg::SpdOptions;
use std::path::Path;

/// Block C of `evidence_validation`, D = 8, w = 0.2, seed 17: the full model's pilot chain
/// never leaves the corner (before the fix RJ and PT both failed on this run's rank-1 proposal
/// covariance).
#[test]
fn a_pilot_stuck_on_the_corner_still_gives_positive_definite_proposals() {
    use evidence_validation::*;
    let c = Case {
        d: 8,
        snr_idx: 0,
        seed: 17,
    };
    let h = C_WIDTHS[c.snr_idx] * SIGMA / (N_DATA as f64).sqrt();
    let lg = corner_problem(c.d, h, c.problem_seed(5));
    let p = Pair::new(&lg, c.d, c.problem_seed(35));
    for (mean, cov) in corner_chains(&p, h, &c) {
        SpdOptions::default()
            .factor(&cov)
            .expect("in-model chain covariance");
        assert!(mean.iter().all(|m| m.abs() < h), "{mean:?}");
    }
}

/// The pilot of that run in small: its kept window, 1 000 copies of the corner. Their
/// covariance is 1.13e-31 in every entry (rank 1), and nalgebra factors it (so does
/// `SpdOptions::factor`): only the count of moves tells that the pilot never moved.
#[test]
fn a_pilot_that_never_moved_is_not_used() {
    use evidence_validation::*;
    let h = C_WIDTHS[0] * SIGMA / (N_DATA as f64).sqrt();
    let kept = vec![vec![h; 8]; 1_000];
    let (_, cov) = moments(&kept);
    assert!(cov.clone().cholesky().is_some());
    assert!(!pilot_usable(&cov, 0));
    let moved = DMatrix::<f64>::identity(8, 8) * 1e-4;
    assert!(pilot_usable(&moved, 8) && !pilot_usable(&moved, 7));
}

/// `tempering_calibration`'s pulls: a stated error of 0.01 against a scatter of 0.012 is a
/// ratio of 1.2; one run has no calibration.
#[test]
fn calibration_of_pulls_with_known_spread() {
    use tempering_calibration::calibrate;
    let d: Vec<(f64, f64)> = [-1.0, 1.0, -1.0, 1.0]
        .iter()
        .map(|&s| (s * 0.012 * (3.0f64 / 4.0).sqrt(), 0.01))
        .collect();
    let c = calibrate(&d).unwrap();
    assert!((c.ratio - 1.2).abs() < 1e-12, "{c:?}");
    assert_eq!(c.offset, 0.0);
    assert_eq!((c.beyond2, c.beyond3), (0.0, 0.0));
    assert!(calibrate(&d[..1]).is_none());
}

/// `tempering_calibration`'s study text sets what it says, and both forms load.
#[test]
fn the_study_text_changes_what_it_says() {
    use tempering_calibration::study_text;
    let base = std::fs::read_to_string("examples/guidance-delays.toml").unwrap();
    let s = study_text(&base, 60.0, 7, false);
    assert!(s.contains("target_snr = 60.0") && s.contains("seed = 7\n"));
    let r = study_text(&base, 60.0, 7, true);
    assert!(r.contains("pt_temperatures = 0") && r.contains("rj_iterations = 1600000"));
    Study::from_toml(&s, "guidance-delays.toml", Path::new("examples")).unwrap();
    Study::from_toml(&r, "guidance-delays.toml", Path::new("examples")).unwrap();
}
