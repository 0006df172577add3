//! Spectral windows for Welch estimates and windowed DFTs.
//!
//! **Periodic ("DFT-even") by default.** [`Window::values`] returns the periodic form,
//! `w[n] = Σ_j (−1)^j a_j cos(2πjn/N)`: the window is one period of a sequence with period `N`,
//! so its DFT has exactly the sidelobe structure tabulated by Harris (1978) and the Hann
//! overlap-correlation at 50 % is exactly 1/6. This is what spectral estimation wants (SciPy's
//! `get_window` default). [`Window::values_symmetric`] gives the symmetric form (period
//! `N − 1`, `w[0] = w[N−1]`, MATLAB's `hann(N)`), used for FIR design, not here.

use std::f64::consts::PI;
use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use super::error::SignalError;

/// Cosine-sum coefficients `a_j` of the 4-term Blackman–Harris window with −92 dB sidelobes
/// (Harris 1978, Table 1; LTPDA `specwin` "BH92").
const BH92: [f64; 4] = [0.35875, 0.48829, 0.14128, 0.01168];

/// A spectral window. Serialised as `"rectangular"`, `"hann"` or `"bh92"`.
///
/// # Example
/// ```
/// use occam::signal::Window;
///
/// let w = Window::Hann.values(4);
/// assert_eq!(w.len(), 4);
/// assert!((w[0] - 0.0).abs() < 1e-15 && (w[2] - 1.0).abs() < 1e-15); // periodic Hann
/// assert_eq!("bh92".parse::<Window>().unwrap(), Window::Bh92);
/// assert_eq!(Window::Hann.recommended_overlap(), 0.5);
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Window {
    /// No taper, `w = 1`. The likelihood's default (ltp-model.md §8.2).
    #[default]
    Rectangular,
    /// Hann (raised cosine): first sidelobe −31.5 dB, recommended overlap 50 %.
    Hann,
    /// 4-term Blackman–Harris, −92 dB sidelobes, recommended overlap 66.1 %.
    Bh92,
}

impl Window {
    /// Every window, for iteration in tests and help texts.
    pub const ALL: [Window; 3] = [Window::Rectangular, Window::Hann, Window::Bh92];

    /// The serialised name: `"rectangular"`, `"hann"` or `"bh92"`.
    pub fn name(self) -> &'static str {
        match self {
            Window::Rectangular => "rectangular",
            Window::Hann => "hann",
            Window::Bh92 => "bh92",
        }
    }

    /// Periodic window of length `n` (see the module docs for why periodic).
    pub fn values(self, n: usize) -> Vec<f64> {
        self.cosine_sum(n, n)
    }

    /// Symmetric window of length `n` (`w[k] = w[n−1−k]`); `[1.0]` for `n = 1`.
    pub fn values_symmetric(self, n: usize) -> Vec<f64> {
        if n == 1 {
            return vec![1.0];
        }
        self.cosine_sum(n, n.saturating_sub(1))
    }

    /// Overlap fraction that keeps Welch segments nearly independent while using the data
    /// fully (Harris 1978 Table 1, LTPDA `specwin` ROV): 0 (rectangular), 0.5 (Hann),
    /// 0.661 (BH92).
    pub fn recommended_overlap(self) -> f64 {
        match self {
            Window::Rectangular => 0.0,
            Window::Hann => 0.5,
            Window::Bh92 => 0.661,
        }
    }

    /// `Σ_n w[n]` of the periodic window of length `n` (coherent gain × `n`).
    pub fn sum(self, n: usize) -> f64 {
        self.values(n).iter().sum()
    }

    /// `Σ_n w[n]²` of the periodic window of length `n` (the Welch normalisation).
    pub fn sum_sq(self, n: usize) -> f64 {
        self.values(n).iter().map(|w| w * w).sum()
    }

    /// Equivalent noise bandwidth in Hz, `fs Σw² / (Σw)²`, of the periodic window of length
    /// `n` at sampling frequency `fs` (the LTPDA `welchscale` ENBW).
    pub fn enbw(self, n: usize, fs: f64) -> f64 {
        let w = self.values(n);
        let s1: f64 = w.iter().sum();
        let s2: f64 = w.iter().map(|v| v * v).sum();
        fs * s2 / (s1 * s1)
    }

    /// `w[k] = Σ_j (−1)^j a_j cos(2πjk/period)` for `k < n`.
    fn cosine_sum(self, n: usize, period: usize) -> Vec<f64> {
        let coeffs: &[f64] = match self {
            Window::Rectangular => return vec![1.0; n],
            Window::Hann => &[0.5, 0.5],
            Window::Bh92 => &BH92,
        };
        (0..n)
            .map(|k| {
                let t = 2.0 * PI * k as f64 / period as f64;
                coeffs
                    .iter()
                    .enumerate()
                    .map(|(j, a)| {
                        let sign = if j % 2 == 0 { 1.0 } else { -1.0 };
                        sign * a * (j as f64 * t).cos()
                    })
                    .sum()
            })
            .collect()
    }
}

impl fmt::Display for Window {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Window {
    type Err = SignalError;

    /// Parses the serialised name, case-insensitively.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Window::ALL
            .into_iter()
            .find(|w| w.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| SignalError::UnknownWindow { name: s.to_owned() })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hann_and_bh92_shapes() {
        let n = 64;
        let h = Window::Hann.values(n);
        assert!(h[0].abs() < 1e-15);
        assert!((h[n / 2] - 1.0).abs() < 1e-15);
        // Periodic: w[k] = w[n−k], not w[n−1−k].
        for k in 1..n {
            assert!((h[k] - h[n - k]).abs() < 1e-14);
        }
        let b = Window::Bh92.values(n);
        // a0 − a1 + a2 − a3 at k = 0, Σ a_j at the centre.
        assert!((b[0] - (0.35875 - 0.48829 + 0.14128 - 0.01168)).abs() < 1e-15);
        assert!((b[n / 2] - 1.0).abs() < 1e-12);
        let s = Window::Hann.values_symmetric(5);
        assert_eq!(s.len(), 5);
        assert!(s[0].abs() < 1e-15 && s[4].abs() < 1e-15 && (s[2] - 1.0).abs() < 1e-15);
        assert_eq!(Window::Bh92.values_symmetric(1), vec![1.0]);
        assert!(Window::Hann.values(0).is_empty());
    }

    #[test]
    fn sums_match_closed_forms() {
        // Periodic cosine sums: Σw = N a0, Σw² = N (a0² + Σ_{j≥1} a_j²/2) exactly for N > 2·3.
        let n = 1000;
        let nf = n as f64;
        assert_eq!(Window::Rectangular.sum(n), nf);
        assert_eq!(Window::Rectangular.sum_sq(n), nf);
        assert!((Window::Hann.sum(n) - nf / 2.0).abs() < 1e-9);
        assert!((Window::Hann.sum_sq(n) - 3.0 * nf / 8.0).abs() < 1e-9);
        let a = BH92;
        let s2 = a[0] * a[0] + (a[1] * a[1] + a[2] * a[2] + a[3] * a[3]) / 2.0;
        assert!((Window::Bh92.sum(n) - nf * a[0]).abs() < 1e-9);
        assert!((Window::Bh92.sum_sq(n) - nf * s2).abs() < 1e-9);
        // ENBW in bins: 1.5 for Hann, ≈ 2.0044 for BH92 (Harris 1978 Table 1: 2.00).
        assert!((Window::Hann.enbw(n, nf) - 1.5).abs() < 1e-12);
        assert!((Window::Bh92.enbw(n, nf) - 2.0044).abs() < 1e-4);
    }

    #[test]
    fn names_serde_and_parse() {
        for w in Window::ALL {
            let json = serde_json::to_string(&w).unwrap();
            assert_eq!(json, format!("\"{}\"", w.name()));
            assert_eq!(serde_json::from_str::<Window>(&json).unwrap(), w);
            assert_eq!(w.to_string().parse::<Window>().unwrap(), w);
        }
        assert_eq!("Hann".parse::<Window>().unwrap(), Window::Hann);
        assert!(matches!(
            "hanning".parse::<Window>(),
            Err(SignalError::UnknownWindow { .. })
        ));
        assert_eq!(Window::Bh92.recommended_overlap(), 0.661);
    }
}
