//! The bounds a study's numbers must keep (delays, noise levels, corner frequencies, SNR, name
//! lengths), and the checks of single numbers against them.

/// Largest delay (s) anywhere in a study: `[truth]` `dt1`, `dt2`, `oms_delay`, actuator and
/// thruster delays, delay parameters' `fixed` and `start` values and model options. LPF's
/// delays are tenths of a second; 1000 s is 5000× the guidance delay and at a 5 Hz Nyquist
/// frequency a phase of 3·10⁴ rad, where `e^{−i2πfτ}` keeps 12 digits (1e300 s keeps none).
pub const MAX_DELAY: f64 = 1000.0;

/// Largest source ASD of `[noise]` (m/√Hz, m s⁻²/√Hz or N/√Hz): 1, eleven orders above
/// LPF's read-out and acceleration noise and seven above its thruster noise. Larger levels
/// overflow the squared, loop-filtered CSD (1e150 made every CSD infinite).
pub const MAX_ASD: f64 = 1.0;

/// Smallest non-zero source ASD of `[noise]`: 1e-30, fifteen orders below LPF's; below it
/// `ρ² = |h|²/S` of an injection within [`MAX_AMPLITUDE`] can overflow, and near 1e-154 the
/// squared level underflows to a singular CSD. Use 0 to switch a source off.
///
/// [`MAX_AMPLITUDE`]: crate::experiment::options::MAX_AMPLITUDE
pub const MIN_ASD: f64 = 1e-30;

/// Largest noise corner frequency (`readout_corner`, `tm_corner`, Hz): 1 kHz, far above any
/// sample rate of the mission.
pub const MAX_CORNER: f64 = 1e3;

/// Largest `simulation.target_snr`: 10⁶, three orders above LPF's loudest experiments; the
/// amplitude factor it implies must also keep every amplitude within [`MAX_AMPLITUDE`]
/// (checked when the study is simulated).
///
/// [`MAX_AMPLITUDE`]: crate::experiment::options::MAX_AMPLITUDE
pub const MAX_TARGET_SNR: f64 = 1e6;

/// Names of the delay parameters (s) of the built-in models (`ltp`, `accel` and tied models
/// of them): their `fixed` and `start` values must be delays in `[0, MAX_DELAY]`.
pub const DELAY_PARAMS: [&str; 5] = ["dt1", "dt2", "tau_df", "tau_c1", "tau_c2"];

/// Longest experiment or model name: 64 characters. Names become array names in the npz
/// dataset and keys of the output tables (a 70 000-character name overflowed the zip
/// format's 16-bit name length).
pub const MAX_NAME_LEN: usize = 64;

/// A finite number above zero.
pub(super) fn finite_pos(v: f64) -> bool {
    v.is_finite() && v > 0.0
}

/// Checks a delay (s): finite, ≥ 0 and ≤ [`MAX_DELAY`].
pub(super) fn check_delay(v: f64) -> Result<(), String> {
    if v.is_finite() && (0.0..=MAX_DELAY).contains(&v) {
        Ok(())
    } else {
        Err(format!(
            "must be a delay ≥ 0 and ≤ {MAX_DELAY} s (got {v}); LPF's delays are tenths of a second"
        ))
    }
}
