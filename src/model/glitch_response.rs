//! The read-outs' response to modelled glitches on a finite record, as a real instrument (and
//! the simulator) produces it: causal and cut at the record's end, not wrapped round it.
//!
//! # Why not `H(f_k) S(f_k)`
//! On the record's DFT grid `f_k = k fs/N`, the product of the loop's force response `H` and the
//! DFT `S` of a glitch's samples is the DFT of a *circular* convolution: the part of the response
//! that outlasts the record wraps round to its start. The loop's response to a force lasts
//! thousands of seconds (the suspension and the drag-free controller's slow poles), so on
//! `examples/glitches.toml`'s 19 120 s stretches the circular model at the true loop and glitch
//! parameters left a residual power of 40 for a glitch of 1e−13 m s⁻² starting at 70 % of its
//! stretch, 3.5e3 at 85 % and 1.4e5 (all of it) at 98 %, against 1e−3 in the record's first
//! half (`tests/glitches.rs`, `a_modelled_glitch_explains_noiseless_data_wherever_it_starts`):
//! fitted, that wrapped response pulled the loop's parameters by tens of σ (the pull spreads of
//! 7–22 of the glitch guide).
//!
//! # What is computed instead
//! The glitches' force, sampled as the simulator samples it (`Σ_g a_g s(m/fs − t0_g)`,
//! `m < N`), is zero-padded to `M ≥ 2N` samples, transformed, multiplied by `H_r(j fs/M; θ)`,
//! transformed back, cut to its first `N` samples and transformed on the record's grid:
//!
//! ```text
//! Y_r,k = DFT_N[ (IDFT_M[ H_r · DFT_M[g ⊕ 0] ])_{0…N−1} ]_k
//! ```
//!
//! which is the DFT of the causal (linear) convolution as long as the response of a force that
//! ends at the record's end has died within `M − N ≥ N` samples. `M` is the smallest
//! `2^a 3^b 5^c ≥ 2N` (a fast transform). The DC term `H(0)` is taken as zero: a constant in
//! the response only reaches the record's DC bin, which no band includes (the LTP loop's
//! integrators hold it at zero anyway). Everything is linear in the force, so derivatives
//! (dual numbers) go through the same transforms component by component.
//!
//! Five real transforms per evaluation and experiment (one of the force, two per residual
//! channel) replace the per-bin product: the price of a likelihood that is right wherever a
//! glitch starts.

use super::bin::Bin;
use super::traits::Model;
use crate::signal::RealFft;
use num_complex::{Complex, Complex64};
use num_dual::{Dual64, DualNum};

/// Below this a glitch's exponentials are dropped: their samples are below rounding of its peak.
const NEGLIGIBLE: f64 = 1e-18;

/// Seconds of padding at least: the loop's response to a force that ends with the record must
/// have died within the padding (else it wraps round). The LTP loop's slowest closed-loop pole
/// has a time constant of about 1200 s (ltp-model.md §4): 2.4e4 s leave e^{−20} of it.
pub const MIN_PAD_SECONDS: f64 = 2.4e4;

/// The padded length of a record of `n` samples at `fs`: the smallest `2^a 3^b 5^c` at least
/// `2n` and at least `n` plus [`MIN_PAD_SECONDS`].
pub(super) fn record_padding(n: usize, fs: f64) -> usize {
    let pad = (MIN_PAD_SECONDS * fs).ceil();
    let pad = if pad.is_finite() && pad < 1e9 {
        pad as usize
    } else {
        n
    };
    padded_len(n + n.max(pad))
}

/// The smallest `2^a 3^b 5^c ≥ want`.
pub(super) fn padded_len(want: usize) -> usize {
    let want = want.max(2);
    let mut best = usize::MAX;
    let mut p2 = 1usize;
    while p2 < 2 * want {
        let mut p3 = p2;
        while p3 < 2 * want {
            let mut p5 = p3;
            while p5 < want {
                p5 *= 5;
            }
            best = best.min(p5);
            p3 *= 3;
        }
        p2 *= 2;
    }
    best
}

/// The record's DFT bin of frequency `f` for a record of `n` samples at `fs`, or `None` off the
/// grid or above Nyquist.
pub fn grid_index(f: f64, fs: f64, n: usize) -> Option<usize> {
    let x = f * n as f64 / fs;
    let k = x.round();
    ((x - k).abs() < 1e-6 && k >= 0.0 && k <= (n / 2) as f64).then_some(k as usize)
}

/// Adds `a·s(m/fs − t0)` for `m < out.len()` to `out` (the simulator's sampled shape,
/// [`crate::experiment::Glitch`]): zero before `t0`, then `(e^{−u/τ} − e^{−u/τ_r})/c`, `c` its
/// peak. Exponentials by recurrence (one product per sample; the relative rounding grows by
/// 1e−16 per sample), stopped where both are negligible.
pub(super) fn add_samples(t0: f64, tau: f64, a: f64, rise: f64, fs: f64, out: &mut [f64]) {
    let n0 = (t0 * fs).ceil().max(0.0);
    if !(n0 < out.len() as f64) || a == 0.0 {
        return;
    }
    let start = n0 / fs - t0;
    let c = a / super::glitch_kernel::peak(tau, rise);
    let (mut e, mut er) = ((-start / tau).exp(), (-start / rise).exp());
    let (q, qr) = ((-1.0 / (fs * tau)).exp(), (-1.0 / (fs * rise)).exp());
    for o in &mut out[n0 as usize..] {
        if e < NEGLIGIBLE && er < NEGLIGIBLE {
            break;
        }
        *o += c * (e - er);
        e *= q;
        er *= qr;
    }
}

/// [`add_samples`] in dual numbers: the values into `re`, the derivatives into `eps`.
pub(super) fn add_samples_dual(
    t0: Dual64,
    tau: Dual64,
    a: Dual64,
    rise: f64,
    fs: f64,
    re: &mut [f64],
    eps: &mut [f64],
) {
    let n0 = (t0.re * fs).ceil().max(0.0);
    if !(n0 < re.len() as f64) {
        return;
    }
    let c = a / super::glitch_kernel::peak(tau, rise);
    for (m, (r, d)) in re
        .iter_mut()
        .zip(eps.iter_mut())
        .enumerate()
        .skip(n0 as usize)
    {
        let u = Dual64::from(m as f64 / fs) - t0;
        let (e, er) = ((-u / tau).exp(), (-u / rise).exp());
        if e.re < NEGLIGIBLE && er.re < NEGLIGIBLE {
            break;
        }
        let v = c * (e - er);
        *r += v.re;
        *d += v.eps;
    }
}

/// `H_r(j fs/m)` for `j = 0 … m/2`, `nr` channels (`out[j·nr + r]`), `H(0) = 0` (module docs).
pub(super) fn response_grid(
    parent: &dyn Model,
    p: &[f64],
    m: usize,
    fs: f64,
    out: &mut Vec<Complex64>,
) {
    let nr = parent.residual_channels().len();
    let zero = Complex64::new(0.0, 0.0);
    out.clear();
    out.resize((m / 2 + 1) * nr, zero);
    let mut consts = vec![zero; parent.n_consts()];
    for j in 1..=m / 2 {
        let f = j as f64 * fs / m as f64;
        parent.bin_consts(f, fs, &mut consts);
        let bin = Bin {
            f,
            fs,
            consts: &consts,
        };
        parent.force_response(p, &bin, &mut out[j * nr..(j + 1) * nr]);
    }
}

/// [`response_grid`] in dual numbers: values into `re`, derivatives into `eps`.
pub(super) fn response_grid_dual(
    parent: &dyn Model,
    p: &[Dual64],
    m: usize,
    fs: f64,
    re: &mut Vec<Complex64>,
    eps: &mut Vec<Complex64>,
) {
    let nr = parent.residual_channels().len();
    let zero = Complex64::new(0.0, 0.0);
    re.clear();
    re.resize((m / 2 + 1) * nr, zero);
    eps.clear();
    eps.resize((m / 2 + 1) * nr, zero);
    let mut consts = vec![zero; parent.n_consts()];
    let mut h = vec![Complex::new(Dual64::from(0.0), Dual64::from(0.0)); nr];
    for j in 1..=m / 2 {
        let f = j as f64 * fs / m as f64;
        parent.bin_consts(f, fs, &mut consts);
        let bin = Bin {
            f,
            fs,
            consts: &consts,
        };
        parent.force_response_dual(p, &bin, &mut h);
        for (r, v) in h.iter().enumerate() {
            re[j * nr + r] = Complex64::new(v.re.re, v.im.re);
            eps[j * nr + r] = Complex64::new(v.re.eps, v.im.eps);
        }
    }
}

/// The transforms of the module docs for one record length, with their buffers.
#[derive(Debug, Clone)]
pub(super) struct Causal {
    n: usize,
    fs: f64,
    m: usize,
    fft_m: RealFft,
    fft_n: RealFft,
    padded: Vec<f64>,
    q: Vec<Complex64>,
    y: Vec<Complex64>,
}

impl Causal {
    /// The transforms of a record of `n ≥ 2` samples at `fs`.
    pub(super) fn new(n: usize, fs: f64) -> Self {
        let m = record_padding(n, fs);
        Self {
            n,
            fs,
            m,
            fft_m: RealFft::new(m).expect("m ≥ 2"),
            fft_n: RealFft::new(n.max(1)).expect("n ≥ 1"),
            padded: vec![0.0; m],
            q: vec![Complex64::new(0.0, 0.0); m / 2 + 1],
            y: vec![Complex64::new(0.0, 0.0); n.max(1) / 2 + 1],
        }
    }

    /// The record's length `N`.
    pub(super) fn n(&self) -> usize {
        self.n
    }

    /// The sample rate it was made for.
    pub(super) fn fs(&self) -> f64 {
        self.fs
    }

    /// The padded length `M`.
    pub(super) fn m(&self) -> usize {
        self.m
    }

    /// `DFT_M[g ⊕ 0]` of `N` samples `g` into `out` (`M/2 + 1`). A non-finite sample gives NaN.
    pub(super) fn spectrum(&mut self, g: &[f64], out: &mut Vec<Complex64>) {
        out.resize(self.m / 2 + 1, Complex64::new(0.0, 0.0));
        self.padded[..self.n].copy_from_slice(g);
        self.padded[self.n..].fill(0.0);
        if self.fft_m.forward(&self.padded, out).is_err() {
            out.fill(Complex64::new(f64::NAN, f64::NAN));
        }
    }

    /// `Y_r = DFT_N[(IDFT_M[Σ_i H_i,r G_i])_{0…N−1}]` for each of `nr` channels, into
    /// `out[k·nr + r]` (`k = 0 … N/2`): `terms` are `(H_i, G_i)` pairs, `H_i` on the padded grid
    /// as [`response_grid`] lays it out, `G_i` from [`Causal::spectrum`] (a sum, so that a
    /// dual number's derivative `H'G + HG'` is one call).
    pub(super) fn apply(
        &mut self,
        terms: &[(&[Complex64], &[Complex64])],
        nr: usize,
        out: &mut [Complex64],
    ) {
        let nk = self.n / 2 + 1;
        for r in 0..nr {
            for (j, q) in self.q.iter_mut().enumerate() {
                *q = terms.iter().map(|(h, g)| h[j * nr + r] * g[j]).sum();
            }
            let ok = self.fft_m.inverse(&self.q, &mut self.padded).is_ok()
                && self
                    .fft_n
                    .forward(&self.padded[..self.n], &mut self.y)
                    .is_ok();
            for k in 0..nk {
                out[k * nr + r] = if ok {
                    self.y[k]
                } else {
                    Complex64::new(f64::NAN, f64::NAN)
                };
            }
        }
    }
}

/// The causal response of a unit glitch at every start on the record's sample times, for a
/// scan over starts (`jobs::glitch_model`'s grid): the response of a glitch at sample `n0` is
/// that of a glitch at sample 0 delayed by `n0` samples and cut at the record's end (causal and
/// time-invariant), so one set of transforms per decay time and one DFT per start.
#[derive(Debug, Clone)]
pub struct GlitchScan {
    causal: Causal,
    /// The force response on the padded grid.
    h: Vec<Complex64>,
    nr: usize,
    fs: f64,
    rise: f64,
    /// The response to a unit glitch at sample 0, per channel, `N` samples each.
    z: Vec<f64>,
    buf: Vec<f64>,
    spec: Vec<Complex64>,
}

impl GlitchScan {
    /// The scan of `model` (anything with a [`Model::force_response`]) at `theta` on a record
    /// of `n ≥ 2` samples at `fs`, glitches rising in `rise` s.
    pub fn new(model: &dyn Model, theta: &[f64], n: usize, fs: f64, rise: f64) -> Self {
        let causal = Causal::new(n, fs);
        let mut h = Vec::new();
        response_grid(model, theta, causal.m(), fs, &mut h);
        let nr = model.residual_channels().len();
        Self {
            causal,
            h,
            nr,
            fs,
            rise,
            z: vec![0.0; nr * n],
            buf: vec![0.0; n],
            spec: Vec::new(),
        }
    }

    /// The record's length in samples.
    pub fn len(&self) -> usize {
        self.causal.n()
    }

    /// Always false (a record has at least two samples).
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Sets the decay time `tau` (s) of the glitches [`GlitchScan::at_sample`] gives.
    pub fn set_tau(&mut self, tau: f64) {
        let n = self.causal.n();
        self.buf.fill(0.0);
        add_samples(0.0, tau, 1.0, self.rise, self.fs, &mut self.buf);
        let mut gs = Vec::new();
        self.causal.spectrum(&self.buf, &mut gs);
        let m = self.causal.m();
        let mut q = vec![Complex64::new(0.0, 0.0); m / 2 + 1];
        let mut t = vec![0.0; m];
        let mut fft = RealFft::new(m).expect("m ≥ 2");
        for r in 0..self.nr {
            for (j, v) in q.iter_mut().enumerate() {
                *v = self.h[j * self.nr + r] * gs[j];
            }
            if fft.inverse(&q, &mut t).is_err() {
                t.fill(f64::NAN);
            }
            self.z[r * n..(r + 1) * n].copy_from_slice(&t[..n]);
        }
    }

    /// `Y_r,k` (`out[k·nr + r]`, `k = 0 … N/2`) of a unit glitch starting at sample `n0`
    /// (`t0 = n0/fs`) with the decay of the last [`GlitchScan::set_tau`].
    pub fn at_sample(&mut self, n0: usize, out: &mut [Complex64]) {
        let n = self.causal.n();
        let nk = n / 2 + 1;
        let n0 = n0.min(n);
        for r in 0..self.nr {
            self.buf[..n0].fill(0.0);
            self.buf[n0..].copy_from_slice(&self.z[r * n..r * n + n - n0]);
            self.spec.resize(nk, Complex64::new(0.0, 0.0));
            if self
                .causal
                .fft_n
                .forward(&self.buf, &mut self.spec)
                .is_err()
            {
                self.spec.fill(Complex64::new(f64::NAN, f64::NAN));
            }
            for k in 0..nk {
                out[k * self.nr + r] = self.spec[k];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::experiment::Glitch;

    #[test]
    fn the_padded_length_is_the_smallest_fast_size_of_twice_the_record() {
        assert_eq!(padded_len(38240), 38400);
        assert_eq!(record_padding(19120, 1.0), 43200);
        assert_eq!(record_padding(400_000, 10.0), 800_000);
        assert_eq!(padded_len(16), 16);
        assert_eq!(padded_len(14), 15);
        for n in 1..300 {
            let m = padded_len(2 * n);
            assert!(m >= 2 * n);
            let mut r = m;
            for p in [2, 3, 5] {
                while r % p == 0 {
                    r /= p;
                }
            }
            assert_eq!(r, 1, "{m}");
            assert!(((2 * n)..m).all(|x| {
                let mut r = x;
                for p in [2, 3, 5] {
                    while r % p == 0 {
                        r /= p;
                    }
                }
                r != 1
            }));
        }
    }

    /// The samples are the simulator's, in `f64` and in dual numbers, and the dual derivatives
    /// are central differences'.
    #[test]
    fn the_samples_are_the_simulator_s() {
        let (fs, n, rise) = (2.0, 900, 2.0);
        for (t0, tau) in [(10.3, 60.0), (0.0, 5.0), (440.75, 3000.0), (-3.0, 20.0)] {
            let g = Glitch {
                t0,
                amplitude: -3e-13,
                decay: tau,
                rise,
                tm: 2,
            };
            let mut got = vec![0.0; n];
            add_samples(t0, tau, -3e-13, rise, fs, &mut got);
            for (m, v) in got.iter().enumerate() {
                let want = g.at(m as f64 / fs);
                assert!((v - want).abs() < 1e-12 * 3e-13, "{m}: {v} {want}");
            }
            for seed in 0..3 {
                let x = [Dual64::from(t0), Dual64::from(tau), Dual64::from(-3e-13)];
                let mut d = x;
                d[seed] = d[seed].derivative();
                let (mut re, mut eps) = (vec![0.0; n], vec![0.0; n]);
                add_samples_dual(d[0], d[1], d[2], rise, fs, &mut re, &mut eps);
                let h = [1e-4, 1e-4 * tau, 1e-16][seed];
                let at = |s: f64| {
                    let mut v = [t0, tau, -3e-13];
                    v[seed] += s;
                    let mut o = vec![0.0; n];
                    add_samples(v[0], v[1], v[2], rise, fs, &mut o);
                    o
                };
                let (p, q) = (at(h), at(-h));
                for m in 0..n {
                    assert!((re[m] - got[m]).abs() < 1e-12 * 3e-13);
                    // away from the kink at the first sample after t0
                    if (m as f64 / fs - t0).abs() > 0.01 {
                        let fd = (p[m] - q[m]) / (2.0 * h);
                        assert!(
                            (eps[m] - fd).abs() < 1e-6 * fd.abs().max(1e-3 * 3e-13 / h.max(1.0)),
                            "{seed} {m}: {} {fd}",
                            eps[m]
                        );
                    }
                }
            }
        }
    }

    /// The transform is the causal convolution: against the direct sum of a known impulse
    /// response (a decaying oscillation), for a force that ends with the record.
    #[test]
    fn apply_is_the_causal_convolution_cut_at_the_record() {
        let n = 200;
        let mut c = Causal::new(n, 1e-3);
        let m = c.m();
        // h[t] = e^{−t/5} cos(0.3 t): its DFT on the padded grid, computed directly (it has
        // died by m − n samples)
        assert_eq!(m, 400);
        let h: Vec<f64> = (0..m)
            .map(|t| (-(t as f64) / 5.0).exp() * (0.3 * t as f64).cos())
            .collect();
        let mut fft = RealFft::new(m).unwrap();
        let mut hs = vec![Complex64::new(0.0, 0.0); m / 2 + 1];
        fft.forward(&h, &mut hs).unwrap();
        let g: Vec<f64> = (0..n).map(|t| ((t * 7919) % 13) as f64 - 6.0).collect();
        let mut gs = Vec::new();
        c.spectrum(&g, &mut gs);
        let mut out = vec![Complex64::new(0.0, 0.0); n / 2 + 1];
        c.apply(&[(&hs, &gs)], 1, &mut out);
        let y: Vec<f64> = (0..n)
            .map(|t| (0..=t).map(|s| h[t - s] * g[s]).sum())
            .collect();
        let mut want = vec![Complex64::new(0.0, 0.0); n / 2 + 1];
        RealFft::new(n).unwrap().forward(&y, &mut want).unwrap();
        for (a, b) in out.iter().zip(&want) {
            assert!((a - b).norm() < 1e-9, "{a} {b}");
        }
    }

    /// A scanned start equals the full transform of a glitch there.
    #[test]
    fn a_scanned_start_is_the_glitch_transformed_there() {
        use crate::ltp::LtpParams;
        use crate::model::LtpModel;
        let m = LtpModel::new("ltp", Default::default());
        let th = LtpParams::default().to_array().to_vec();
        let (n, fs, rise, tau) = (3000, 1.0, 2.0, 80.0);
        let mut scan = GlitchScan::new(&m, &th, n, fs, rise);
        scan.set_tau(tau);
        let nr = 2;
        let mut got = vec![Complex64::new(0.0, 0.0); (n / 2 + 1) * nr];
        let mut want = got.clone();
        let mut c = Causal::new(n, fs);
        let mut h = Vec::new();
        response_grid(&m, &th, c.m(), fs, &mut h);
        let mut scale = 0.0;
        for n0 in [0, 1, 1234, 2990, 3000] {
            scan.at_sample(n0, &mut got);
            let mut g = vec![0.0; n];
            add_samples(n0 as f64 / fs, tau, 1.0, rise, fs, &mut g);
            let mut gs = Vec::new();
            c.spectrum(&g, &mut gs);
            c.apply(&[(&h, &gs)], nr, &mut want);
            // the scan shifts the response of the whole record: its rounding is relative to
            // that (the first start's)
            scale = want.iter().map(|v| v.norm()).fold(scale, f64::max);
            for (a, b) in got.iter().zip(&want) {
                assert!((a - b).norm() < 1e-8 * scale, "{n0}: {a} {b}");
            }
        }
    }
}
