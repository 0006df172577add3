//! Planned real FFT with the module's conventions, and a slow DFT oracle for tests.
//!
//! `realfft` destroys its input and needs scratch space; [`RealFft`] owns copies of both so a
//! transform allocates nothing and leaves the caller's data untouched.

use std::fmt;
use std::sync::Arc;

use num_complex::Complex64;
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};

use super::error::{SignalError, check_finite, check_fs};

/// A forward/inverse real FFT of one fixed length `n`, planned once, with its buffers.
///
/// `forward` computes `Y[k] = Σ_n x[n] e^{−2πikn/N}` for `k = 0 … n/2` (unnormalised);
/// `inverse` computes `x[n] = (1/N) Σ_k Y[k] e^{+2πikn/N}` from those `n/2 + 1` bins, so
/// `inverse(forward(x)) == x` to rounding. Neither call allocates.
///
/// # Example
/// ```
/// use num_complex::Complex64;
/// use occam::signal::RealFft;
///
/// let mut fft = RealFft::new(8).unwrap();
/// let x = [1.0, 2.0, 0.0, -1.0, 0.5, 0.0, 3.0, -2.0];
/// let mut spec = vec![Complex64::new(0.0, 0.0); fft.spectrum_len()];
/// fft.forward(&x, &mut spec).unwrap();
/// assert!((spec[0].re - x.iter().sum::<f64>()).abs() < 1e-12); // DC bin = sum
///
/// let mut back = vec![0.0; 8];
/// fft.inverse(&spec, &mut back).unwrap();
/// for (a, b) in x.iter().zip(&back) {
///     assert!((a - b).abs() < 1e-12);
/// }
/// ```
#[derive(Clone)]
pub struct RealFft {
    n: usize,
    fwd: Arc<dyn RealToComplex<f64>>,
    inv: Arc<dyn ComplexToReal<f64>>,
    real_buf: Vec<f64>,
    spec_buf: Vec<Complex64>,
    scratch: Vec<Complex64>,
}

impl fmt::Debug for RealFft {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("RealFft").field("n", &self.n).finish()
    }
}

/// Lengths whose plans a thread keeps ([`plans`]); beyond this many the cache starts afresh,
/// so a sweep over many lengths cannot grow it without bound.
const MAX_CACHED_PLANS: usize = 16;

type Plans = (Arc<dyn RealToComplex<f64>>, Arc<dyn ComplexToReal<f64>>);

thread_local! {
    static PLANS: std::cell::RefCell<std::collections::HashMap<usize, Plans>> =
        std::cell::RefCell::new(std::collections::HashMap::new());
}

/// The forward and inverse plans of length `n`, from this thread's cache: planning (the
/// twiddle factors of a 4·10⁵-point transform) was 3 % of a `select`, repeated for every
/// model, stretch and sweep task. The planner's choice depends only on `n` and the CPU, so a
/// cached plan computes exactly what a fresh one would.
fn plans(n: usize) -> Plans {
    PLANS.with(|cache| {
        let mut cache = cache.borrow_mut();
        if let Some(p) = cache.get(&n) {
            return p.clone();
        }
        if cache.len() >= MAX_CACHED_PLANS {
            cache.clear();
        }
        let mut planner = RealFftPlanner::<f64>::new();
        let p: Plans = (planner.plan_fft_forward(n), planner.plan_fft_inverse(n));
        cache.insert(n, p.clone());
        p
    })
}

impl RealFft {
    /// Plans forward and inverse transforms of length `n` (any `n ≥ 1`; fastest for smooth
    /// sizes such as powers of two).
    pub fn new(n: usize) -> Result<Self, SignalError> {
        if n == 0 {
            return Err(SignalError::TooShort {
                what: "FFT length",
                min: 1,
                got: n,
            });
        }
        let (fwd, inv) = plans(n);
        let scratch_len = fwd.get_scratch_len().max(inv.get_scratch_len());
        Ok(Self {
            n,
            fwd,
            inv,
            real_buf: vec![0.0; n],
            spec_buf: vec![Complex64::new(0.0, 0.0); n / 2 + 1],
            scratch: vec![Complex64::new(0.0, 0.0); scratch_len],
        })
    }

    /// The time-series length `N` of the plan.
    pub fn len(&self) -> usize {
        self.n
    }

    /// Always false: a plan has length at least 1 (present for API symmetry with `len`).
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Number of one-sided bins, `N/2 + 1`.
    pub fn spectrum_len(&self) -> usize {
        self.n / 2 + 1
    }

    /// Forward transform of `x` (length `N`) into `out` (length `N/2 + 1`).
    ///
    /// Errors on wrong buffer lengths or a non-finite sample; `x` is not modified.
    pub fn forward(&mut self, x: &[f64], out: &mut [Complex64]) -> Result<(), SignalError> {
        self.check_len("forward input", x.len(), self.n)?;
        self.check_len("forward output", out.len(), self.spectrum_len())?;
        check_finite("forward input", x)?;
        self.real_buf.copy_from_slice(x);
        self.fwd
            .process_with_scratch(&mut self.real_buf, out, &mut self.scratch)
            // Lengths were checked above, so realfft has nothing left to reject.
            .expect("realfft forward: buffer lengths already validated");
        Ok(())
    }

    /// Inverse transform of the one-sided spectrum `spec` (length `N/2 + 1`) into `out`
    /// (length `N`), including the `1/N` so that it undoes [`RealFft::forward`].
    ///
    /// The imaginary parts of the DC bin and (even `N`) of the Nyquist bin are ignored, as in
    /// numpy's `irfft`: no real series has them, and rounding leaves tiny ones behind.
    pub fn inverse(&mut self, spec: &[Complex64], out: &mut [f64]) -> Result<(), SignalError> {
        self.check_len("inverse input", spec.len(), self.spectrum_len())?;
        self.check_len("inverse output", out.len(), self.n)?;
        for (k, c) in spec.iter().enumerate() {
            if !c.re.is_finite() || !c.im.is_finite() {
                let value = if c.re.is_finite() { c.im } else { c.re };
                return Err(SignalError::NonFinite {
                    what: "inverse input",
                    index: k,
                    value,
                });
            }
        }
        self.spec_buf.copy_from_slice(spec);
        self.spec_buf[0].im = 0.0;
        if self.n.is_multiple_of(2) {
            self.spec_buf[self.n / 2].im = 0.0;
        }
        self.inv
            .process_with_scratch(&mut self.spec_buf, out, &mut self.scratch)
            .expect("realfft inverse: lengths validated and DC/Nyquist imaginary parts zeroed");
        let scale = 1.0 / self.n as f64;
        out.iter_mut().for_each(|v| *v *= scale);
        Ok(())
    }

    fn check_len(
        &self,
        what: &'static str,
        got: usize,
        expected: usize,
    ) -> Result<(), SignalError> {
        if got == expected {
            Ok(())
        } else {
            Err(SignalError::BufferLength {
                what,
                expected,
                got,
            })
        }
    }
}

/// Frequencies `f_k = k fs / n` of the `n/2 + 1` one-sided bins of a length-`n` real DFT.
pub fn rfft_freqs(n: usize, fs: f64) -> Result<Vec<f64>, SignalError> {
    if n == 0 {
        return Err(SignalError::TooShort {
            what: "FFT length",
            min: 1,
            got: n,
        });
    }
    check_fs(fs)?;
    Ok((0..=n / 2).map(|k| k as f64 * fs / n as f64).collect())
}

/// Slow O(N²) DFT of a real series, bins `0 … N/2`, straight from the definition.
///
/// It is the oracle for the fast paths (and for the sign convention); do not use it on long
/// series. The phase `2πkn/N` is reduced modulo `N` in integers so the oracle stays accurate
/// to rounding for large `k n`.
pub fn dft_naive(x: &[f64]) -> Vec<Complex64> {
    let n = x.len();
    (0..=n / 2)
        .map(|k| {
            x.iter()
                .enumerate()
                .map(|(j, &v)| {
                    let phase = -2.0 * std::f64::consts::PI * ((k * j) % n) as f64 / n as f64;
                    v * Complex64::from_polar(1.0, phase)
                })
                .sum()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};
    use rand_xoshiro::Xoshiro256PlusPlus;

    fn noise(n: usize, seed: u64) -> Vec<f64> {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        (0..n).map(|_| StandardNormal.sample(&mut rng)).collect()
    }

    #[test]
    fn forward_matches_naive_dft_even_and_odd() {
        for &n in &[1usize, 2, 7, 16, 45, 64, 127] {
            let x = noise(n, n as u64);
            let mut fft = RealFft::new(n).unwrap();
            let mut fast = vec![Complex64::new(0.0, 0.0); fft.spectrum_len()];
            fft.forward(&x, &mut fast).unwrap();
            let slow = dft_naive(&x);
            // Rounding of an O(N log N) and an O(N²) sum of N unit-variance terms: errors grow
            // like ε √N · log N at most; 1e-12 · N is a generous bound that still catches any
            // wrong sign, scale or bin.
            for (k, (a, b)) in fast.iter().zip(&slow).enumerate() {
                assert!((a - b).norm() < 1e-12 * n as f64, "n={n} k={k}: {a} vs {b}");
            }
        }
    }

    /// A plan from the thread's cache computes exactly what a freshly planned transform does,
    /// and the cache stays bounded however many lengths a thread plans.
    #[test]
    fn cached_plans_give_the_bits_of_fresh_ones_and_the_cache_is_bounded() {
        for n in [8usize, 1000, 4096, 1000] {
            let x = noise(n, n as u64);
            let mut cached = vec![Complex64::new(0.0, 0.0); n / 2 + 1];
            RealFft::new(n).unwrap().forward(&x, &mut cached).unwrap();
            let fresh = RealFftPlanner::<f64>::new().plan_fft_forward(n);
            let mut input = x.clone();
            let mut out = fresh.make_output_vec();
            fresh.process(&mut input, &mut out).unwrap();
            assert_eq!(cached, out, "n = {n}");
        }
        for n in 1..=3 * MAX_CACHED_PLANS {
            RealFft::new(n).unwrap();
        }
        PLANS.with(|c| assert!(c.borrow().len() <= MAX_CACHED_PLANS));
    }

    #[test]
    fn sign_convention_is_negative_exponent() {
        // x[n] = cos(2πn/N) + sin(2πn/N): with e^{−2πikn/N}, Y[1] = N/2 (1 − i).
        let n = 16;
        let x: Vec<f64> = (0..n)
            .map(|j| {
                let t = 2.0 * std::f64::consts::PI * j as f64 / n as f64;
                t.cos() + t.sin()
            })
            .collect();
        let mut fft = RealFft::new(n).unwrap();
        let mut y = vec![Complex64::new(0.0, 0.0); fft.spectrum_len()];
        fft.forward(&x, &mut y).unwrap();
        assert!((y[1] - Complex64::new(8.0, -8.0)).norm() < 1e-12);
        assert!(dft_naive(&x)[1].im < -7.9);
    }

    #[test]
    fn inverse_undoes_forward() {
        for &n in &[1usize, 2, 9, 32, 100] {
            let x = noise(n, 100 + n as u64);
            let mut fft = RealFft::new(n).unwrap();
            let mut y = vec![Complex64::new(0.0, 0.0); fft.spectrum_len()];
            fft.forward(&x, &mut y).unwrap();
            let mut back = vec![0.0; n];
            fft.inverse(&y, &mut back).unwrap();
            for (a, b) in x.iter().zip(&back) {
                assert!((a - b).abs() < 1e-13 * (n as f64).max(1.0), "n={n}");
            }
            // Input spectrum untouched (we copy before realfft scribbles on it).
            let again = {
                let mut z = vec![Complex64::new(0.0, 0.0); fft.spectrum_len()];
                fft.forward(&x, &mut z).unwrap();
                z
            };
            assert_eq!(again, y);
        }
    }

    #[test]
    fn inverse_ignores_imaginary_dc_and_nyquist() {
        let n = 8;
        let mut fft = RealFft::new(n).unwrap();
        let mut spec = vec![Complex64::new(0.0, 0.0); 5];
        spec[0] = Complex64::new(8.0, 3.0);
        spec[4] = Complex64::new(0.0, -2.0);
        let mut out = vec![0.0; n];
        fft.inverse(&spec, &mut out).unwrap();
        assert!(out.iter().all(|&v| (v - 1.0).abs() < 1e-14));
    }

    #[test]
    fn wrong_lengths_and_bad_values_are_errors() {
        assert!(matches!(
            RealFft::new(0),
            Err(SignalError::TooShort { min: 1, got: 0, .. })
        ));
        let mut fft = RealFft::new(8).unwrap();
        let mut out = vec![Complex64::new(0.0, 0.0); 5];
        assert_eq!(
            fft.forward(&[0.0; 7], &mut out),
            Err(SignalError::BufferLength {
                what: "forward input",
                expected: 8,
                got: 7
            })
        );
        assert!(matches!(
            fft.forward(&[0.0; 8], &mut out[..4]),
            Err(SignalError::BufferLength { expected: 5, .. })
        ));
        let mut x = [0.0; 8];
        x[3] = f64::NAN;
        assert!(matches!(
            fft.forward(&x, &mut out),
            Err(SignalError::NonFinite { index: 3, .. })
        ));
        let mut back = vec![0.0; 8];
        assert!(matches!(
            fft.inverse(&out[..4], &mut back),
            Err(SignalError::BufferLength { .. })
        ));
        out[2].im = f64::INFINITY;
        assert!(matches!(
            fft.inverse(&out, &mut back),
            Err(SignalError::NonFinite { index: 2, .. })
        ));
    }

    #[test]
    fn freqs_follow_k_fs_over_n() {
        let f = rfft_freqs(10, 10.0).unwrap();
        assert_eq!(f.len(), 6);
        assert_eq!(f[0], 0.0);
        assert!((f[5] - 5.0).abs() < 1e-15);
        assert!((f[1] - 1.0).abs() < 1e-15);
        assert_eq!(rfft_freqs(7, 1.0).unwrap().len(), 4);
        assert!(matches!(
            rfft_freqs(8, 0.0),
            Err(SignalError::InvalidParameter { name: "fs", .. })
        ));
        assert!(rfft_freqs(0, 1.0).is_err());
    }
}
