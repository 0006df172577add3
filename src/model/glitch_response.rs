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
//! it was not, as first thought, the cause of the glitch guide's modelled pull spreads of 7–22
//! (re-measured with this causal response on 40 realisations, they stayed); regions holding
//! more than one glitch, fitted with one, were (`jobs::glitch_model`).
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

/// The peak of `e^{−u/τ} − e^{−u/τ_r}`, at `u* = ln(τ/τ_r) τ τ_r / (τ − τ_r)`.
pub(super) fn peak<T: DualNum<Primitive = f64> + Copy>(tau: T, rise: f64) -> T {
    let u = (tau / rise).ln() * tau * rise / (tau - rise);
    (-u / tau).exp() - (-u / rise).exp()
}

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
    let c = a / peak(tau, rise);
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
    let c = a / peak(tau, rise);
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

/// A model's θ-independent constants ([`Model::bin_consts`]) on the padded grid `j fs/m`,
/// `j = 0 … m/2`: made once per model and grid (for the LTP loop they cost more than its
/// force response).
#[derive(Debug, Clone)]
pub(super) struct GridConsts {
    m: usize,
    fs: f64,
    per: usize,
    data: Vec<Complex64>,
}

impl GridConsts {
    pub(super) fn new(model: &dyn Model, m: usize, fs: f64) -> Self {
        let per = model.n_consts();
        let mut data = vec![Complex64::new(0.0, 0.0); (m / 2 + 1) * per];
        for j in 1..=m / 2 {
            model.bin_consts(
                j as f64 * fs / m as f64,
                fs,
                &mut data[j * per..(j + 1) * per],
            );
        }
        Self { m, fs, per, data }
    }

    /// Whether these are the constants of grid `(m, fs)`.
    pub(super) fn is_for(&self, m: usize, fs: f64) -> bool {
        self.m == m && self.fs == fs
    }

    fn bin(&self, j: usize) -> Bin<'_> {
        Bin {
            f: j as f64 * self.fs / self.m as f64,
            fs: self.fs,
            consts: &self.data[j * self.per..(j + 1) * self.per],
        }
    }
}

/// `H_r(j fs/m)` for `j = 0 … m/2` on the grid of `g`, `nr` channels (`out[j·nr + r]`),
/// `H(0) = 0` (module docs).
pub(super) fn response_grid(
    parent: &dyn Model,
    p: &[f64],
    g: &GridConsts,
    out: &mut Vec<Complex64>,
) {
    let nr = parent.residual_channels().len();
    out.clear();
    out.resize((g.m / 2 + 1) * nr, Complex64::new(0.0, 0.0));
    for j in 1..=g.m / 2 {
        parent.force_response(p, &g.bin(j), &mut out[j * nr..(j + 1) * nr]);
    }
}

/// [`response_grid`] in dual numbers: values into `re`, derivatives into `eps`.
pub(super) fn response_grid_dual(
    parent: &dyn Model,
    p: &[Dual64],
    g: &GridConsts,
    re: &mut Vec<Complex64>,
    eps: &mut Vec<Complex64>,
) {
    let nr = parent.residual_channels().len();
    let zero = Complex64::new(0.0, 0.0);
    re.clear();
    re.resize((g.m / 2 + 1) * nr, zero);
    eps.clear();
    eps.resize((g.m / 2 + 1) * nr, zero);
    let mut h = vec![Complex::new(Dual64::from(0.0), Dual64::from(0.0)); nr];
    for j in 1..=g.m / 2 {
        parent.force_response_dual(p, &g.bin(j), &mut h);
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

/// `Re Σ_k X_k e^{2πikt/N}` for `t = 0 … N−1` from the one-sided `X` (`N/2 + 1` bins; the
/// inverse transform counts the DC and Nyquist bins once and the others twice).
fn real_sum(fft_n: &mut RealFft, x: &mut [Complex64]) -> Vec<f64> {
    let n = fft_n.len();
    x[0] *= 2.0;
    if n.is_multiple_of(2) {
        x[n / 2] *= 2.0;
    }
    let mut t = vec![0.0; n];
    if fft_n.inverse(x, &mut t).is_err() {
        t.fill(f64::NAN);
    }
    for v in &mut t {
        *v *= n as f64 / 2.0;
    }
    t
}

/// `κ_rs(δ) = Re Σ_j |d_j|² (C_j⁻¹)_rs e^{2πik_jδ/N}` for `δ = 0 … N−1`, per pair `r·nr + s`,
/// from the packed inverse `(a, b, c)` = `[[a, b], [b*, c]]` and the impulse's DFT `d`.
fn kappa_sums(
    fft_n: &mut RealFft,
    nr: usize,
    bins: &[usize],
    cinv: &[(f64, Complex64, f64)],
    imp: &[Complex64],
) -> Vec<Vec<f64>> {
    let nk = fft_n.len() / 2 + 1;
    let mut sums = Vec::with_capacity(nr * nr);
    for r in 0..nr {
        for c in 0..nr {
            let mut x = vec![Complex64::new(0.0, 0.0); nk];
            for (j, &k) in bins.iter().enumerate() {
                let (a, b, cc) = cinv[j];
                let e = match (r, c) {
                    (0, 0) => Complex64::new(a, 0.0),
                    (1, 1) => Complex64::new(cc, 0.0),
                    (0, 1) => b,
                    _ => b.conj(),
                };
                x[k] = e * imp[j].norm_sqr();
            }
            sums.push(real_sum(fft_n, &mut x));
        }
    }
    sums
}

/// `Σ_t a(t) b(t)` of two real series of length `m` from their one-sided spectra (Parseval).
fn parseval(m: usize, a: &[Complex64], b: &[Complex64]) -> f64 {
    let mut s = 0.0;
    for (j, (x, y)) in a.iter().zip(b).enumerate() {
        let w = if j == 0 || (m.is_multiple_of(2) && j == m / 2) {
            1.0
        } else {
            2.0
        };
        s += w * (x.conj() * y).re;
    }
    s / m as f64
}

/// The glitches' part of `Σ_k r_kᴴ C_k⁻¹ r_k` over a record's in-band bins, `r_k = ρ_k − d_k
/// Y_k` (`d` the impulse channel's DFT), without a transform of the record's own length per
/// evaluation (an odd or prime-factored `N` makes that a Bluestein transform, four times a
/// padded one): with the response `y_r(t)` cut to the record,
///
/// ```text
/// Re Σ_k d_k* Y_kᴴ w_k = Σ_r Σ_{t<N} y_r(t) q_r(t),   q_r(t) = Re Σ_k d_k* w_r,k e^{2πikt/N}
/// Σ_k |d_k|² Y_kᴴ C_k⁻¹ Y_k = Σ_rs Σ_{t,t'<N} y_r(t) κ_rs(t − t') y_s(t'),
///                             κ_rs(δ) = Re Σ_k |d_k|² (C_k⁻¹)_rs e^{2πikδ/N}
/// ```
///
/// (`w = C⁻¹ρ`), both by Parseval on the padded grid `M ≥ 2N`, where `κ` at lags `−N < δ < N`
/// does not alias. `κ` depends on the noise only (made once); `q` on the loop's residual.
#[derive(Debug, Clone)]
pub(super) struct Quadratic {
    n: usize,
    m: usize,
    nr: usize,
    fft_n: RealFft,
    fft_m: RealFft,
    bins: Vec<usize>,
    imp: Vec<Complex64>,
    /// `DFT_M` of `κ_rs` at lags `δ mod M`, per pair `r·nr + s`.
    kappa: Vec<Vec<Complex64>>,
    pad: Vec<f64>,
}

impl Quadratic {
    /// For a record of `n` samples at `fs` whose in-band bin `j` is record bin `bins[j]`, with
    /// `C_j⁻¹` packed as `(a, b, c)` and the impulse's DFT `imp[j]`; `nr ≤ 2` channels.
    pub(super) fn new(
        n: usize,
        fs: f64,
        nr: usize,
        bins: &[usize],
        cinv: &[(f64, Complex64, f64)],
        imp: &[Complex64],
    ) -> Self {
        let m = record_padding(n, fs);
        let zero = Complex64::new(0.0, 0.0);
        let mut fft_n = RealFft::new(n.max(1)).expect("n ≥ 1");
        let mut fft_m = RealFft::new(m).expect("m ≥ 2");
        let sums = kappa_sums(&mut fft_n, nr, bins, cinv, imp);
        let mut kappa = Vec::with_capacity(nr * nr);
        let mut pad = vec![0.0; m];
        for r in 0..nr {
            for c in 0..nr {
                // κ_rs(δ) at δ ≥ 0, κ_rs(−δ) = κ_sr(δ) at index M − δ
                pad.fill(0.0);
                pad[..n].copy_from_slice(&sums[r * nr + c]);
                for d in 1..n {
                    pad[m - d] = sums[c * nr + r][d];
                }
                let mut o = vec![zero; m / 2 + 1];
                if fft_m.forward(&pad, &mut o).is_err() {
                    o.fill(Complex64::new(f64::NAN, f64::NAN));
                }
                kappa.push(o);
            }
        }
        Self {
            n,
            m,
            nr,
            fft_n,
            fft_m,
            bins: bins.to_vec(),
            imp: imp.to_vec(),
            kappa,
            pad,
        }
    }

    /// `DFT_M` of `q_r` (type docs) per channel into `out`, from `w[j] = C_j⁻¹ρ_j`.
    pub(super) fn data_side(&mut self, w: &[[Complex64; 2]], out: &mut Vec<Vec<Complex64>>) {
        let zero = Complex64::new(0.0, 0.0);
        out.resize(self.nr, Vec::new());
        for (r, o) in out.iter_mut().enumerate() {
            let mut x = vec![zero; self.n / 2 + 1];
            for (j, &k) in self.bins.iter().enumerate() {
                x[k] = self.imp[j].conj() * w[j][r];
            }
            let q = real_sum(&mut self.fft_n, &mut x);
            self.pad[..self.n].copy_from_slice(&q);
            self.pad[self.n..].fill(0.0);
            o.resize(self.m / 2 + 1, zero);
            if self.fft_m.forward(&self.pad, o).is_err() {
                o.fill(Complex64::new(f64::NAN, f64::NAN));
            }
        }
    }

    /// `DFT_M` of the cut response `y_r` per channel into `out`, from `H` on the padded grid
    /// (as [`response_grid`] lays it out) and the force's `DFT_M` `g`.
    pub(super) fn response(
        &mut self,
        h: &[Complex64],
        g: &[Complex64],
        out: &mut Vec<Vec<Complex64>>,
    ) {
        let zero = Complex64::new(0.0, 0.0);
        let nr = self.nr;
        out.resize(nr, Vec::new());
        let mut q = vec![zero; self.m / 2 + 1];
        for (r, o) in out.iter_mut().enumerate() {
            for (j, v) in q.iter_mut().enumerate() {
                *v = h[j * nr + r] * g[j];
            }
            o.resize(self.m / 2 + 1, zero);
            let ok = self.fft_m.inverse(&q, &mut self.pad).is_ok() && {
                self.pad[self.n..].fill(0.0);
                self.fft_m.forward(&self.pad, o).is_ok()
            };
            if !ok {
                o.fill(Complex64::new(f64::NAN, f64::NAN));
            }
        }
    }

    /// `(Re Σ_k d_k* Y_kᴴ w_k, Σ_k |d_k|² Y_kᴴ C_k⁻¹ Y_k)` from [`Quadratic::response`]'s `y`
    /// and [`Quadratic::data_side`]'s `q`.
    pub(super) fn terms(&self, y: &[Vec<Complex64>], q: &[Vec<Complex64>]) -> (f64, f64) {
        let nr = self.nr;
        let mut b = 0.0;
        for r in 0..nr {
            b += parseval(self.m, &y[r], &q[r]);
        }
        let mut a = 0.0;
        let mut conv = vec![Complex64::new(0.0, 0.0); self.m / 2 + 1];
        for r in 0..nr {
            for (j, v) in conv.iter_mut().enumerate() {
                *v = (0..nr).map(|c| self.kappa[r * nr + c][j] * y[c][j]).sum();
            }
            a += parseval(self.m, &y[r], &conv);
        }
        (b, a)
    }
}

/// Longest horizon [`force_envelope`] computes (ten days at 1 Hz: a few MB).
pub const MAX_ENVELOPE_SECONDS: f64 = 864_000.0;

/// How long the residual's response to a force outlasts it: `e(t)`, the largest
/// `|h_r(t')|` over the residual channels `r` and `t' ≥ t`, over the peak of `|h_r|`, for
/// `t = 0, 1, … , seconds` s, where `h_r` is channel `r`'s response to a differential force
/// impulse ([`Model::force_response`] at `theta`, sampled at 1 Hz: the envelope is what the
/// loop's slow modes set). `None` when the model does not say how a force enters its residual,
/// or for `seconds` beyond [`MAX_ENVELOPE_SECONDS`] or not finite.
pub fn force_envelope(model: &dyn Model, theta: &[f64], seconds: f64) -> Option<Vec<f64>> {
    if !(seconds.is_finite() && seconds <= MAX_ENVELOPE_SECONDS) {
        return None;
    }
    let fs = 1.0;
    let n = (seconds.max(1.0).ceil() as usize).checked_add(1)?;
    let m = padded_len(2 * n + (MIN_PAD_SECONDS * fs) as usize);
    let g = GridConsts::new(model, m, fs);
    let nr = model.residual_channels().len();
    let mut h = Vec::new();
    let mut probe = vec![Complex64::new(0.0, 0.0); nr];
    if !model.force_response(theta, &g.bin(1), &mut probe) {
        return None;
    }
    response_grid(model, theta, &g, &mut h);
    let mut fft = RealFft::new(m).ok()?;
    let mut q = vec![Complex64::new(0.0, 0.0); m / 2 + 1];
    let mut t = vec![0.0; m];
    let mut env = vec![0.0f64; n];
    let mut peak = 0.0f64;
    for r in 0..nr {
        for (j, v) in q.iter_mut().enumerate() {
            *v = h[j * nr + r];
        }
        fft.inverse(&q, &mut t).ok()?;
        // the last n samples hold what a band-limited delay puts before t = 0, wrapped
        peak = t.iter().take(m - n).fold(peak, |p, v| p.max(v.abs()));
        let mut run = 0.0f64;
        for i in (0..n).rev() {
            run = run.max(t[i].abs());
            env[i] = env[i].max(run);
        }
    }
    if !(peak > 0.0 && peak.is_finite()) {
        return None;
    }
    Some(env.into_iter().map(|v| v / peak).collect())
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
    /// What [`GlitchScan::gains`] correlates against ([`GlitchScan::set_target`]).
    target: Option<Target>,
}

/// The data side of [`GlitchScan::gains`], on the correlation grid of `P ≥ 2N` samples.
#[derive(Debug, Clone)]
struct Target {
    fft: RealFft,
    /// `DFT_P` of `q_r(t) = Re Σ_k d_k* w_r,k e^{2πikt/N}` per channel.
    q: Vec<Vec<Complex64>>,
    /// `DFT_P` of `κ_rs(d)` for lags `1 … N−1` (zero at 0), `κ_rs(d) = Re Σ_k |d_k|² (C_k⁻¹)_rs
    /// e^{2πikd/N}`, per pair `r·nr + s`.
    kappa: Vec<Vec<Complex64>>,
    /// `κ_rs(0)` per pair.
    kappa0: Vec<f64>,
    /// `q` of each further column ([`GlitchScan::set_columns`]).
    columns: Vec<Vec<Vec<Complex64>>>,
}

/// What [`GlitchScan::gains_and_columns`] gives for every start `n0`.
#[derive(Debug, Clone)]
pub struct ScanGains {
    /// `B(n0)`.
    pub b: Vec<f64>,
    /// `A(n0)`.
    pub a: Vec<f64>,
    /// `B(n0)` of each column of [`GlitchScan::set_columns`].
    pub columns: Vec<Vec<f64>>,
}

/// `DFT_P` of `t` zero-padded to the length `P` of `fft` (NaN when the transform fails).
fn padded_spectrum(t: &[f64], fft: &mut RealFft) -> Vec<Complex64> {
    let p = fft.len();
    let mut pad = vec![0.0; p];
    pad[..t.len()].copy_from_slice(t);
    let mut o = vec![Complex64::new(0.0, 0.0); p / 2 + 1];
    if fft.forward(&pad, &mut o).is_err() {
        o.fill(Complex64::new(f64::NAN, f64::NAN));
    }
    o
}

impl GlitchScan {
    /// The scan of `model` (anything with a [`Model::force_response`]) at `theta` on a record
    /// of `n ≥ 2` samples at `fs`, glitches rising in `rise` s.
    pub fn new(model: &dyn Model, theta: &[f64], n: usize, fs: f64, rise: f64) -> Self {
        let causal = Causal::new(n, fs);
        let mut h = Vec::new();
        response_grid(
            model,
            theta,
            &GridConsts::new(model, causal.m(), fs),
            &mut h,
        );
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
            target: None,
        }
    }

    fn real_sum(&mut self, x: &mut [Complex64]) -> Vec<f64> {
        real_sum(&mut self.causal.fft_n, x)
    }

    /// The data [`GlitchScan::gains`] scans against: for each in-band bin `j`, its record bin
    /// `bins[j]`, `w_j = C_j⁻¹ r0_j` (`nr` values from `w[j·nr]`), `C_j⁻¹` packed as
    /// `(a, b, c)` = `[[a, b], [b*, c]]` (`c`, `b` unused for one channel) and the impulse
    /// channel's DFT `d_j`.
    pub fn set_target(
        &mut self,
        bins: &[usize],
        w: &[Complex64],
        cinv: &[(f64, Complex64, f64)],
        imp: &[Complex64],
    ) {
        let n = self.causal.n();
        let p = padded_len(2 * n);
        let mut fft = RealFft::new(p).expect("p ≥ 2");
        let q = self.correlation_target(&mut fft, bins, w, imp);
        let (mut kappa, mut kappa0) = (Vec::new(), Vec::new());
        for mut t in kappa_sums(&mut self.causal.fft_n, self.nr, bins, cinv, imp) {
            kappa0.push(t[0]);
            t[0] = 0.0;
            kappa.push(padded_spectrum(&t, &mut fft));
        }
        self.target = Some(Target {
            fft,
            q,
            kappa,
            kappa0,
            columns: Vec::new(),
        });
    }

    /// Further columns `ws[i]` (each laid out as [`GlitchScan::set_target`]'s `w`, `C⁻¹` times
    /// a column such as a parameter's `∂r`) whose correlations with every start
    /// [`GlitchScan::gains_and_columns`] gives beside `B`. Needs a target; replaces earlier
    /// columns.
    pub fn set_columns(&mut self, bins: &[usize], ws: &[Vec<Complex64>], imp: &[Complex64]) {
        let Some(mut t) = self.target.take() else {
            return;
        };
        t.columns = ws
            .iter()
            .map(|w| self.correlation_target(&mut t.fft, bins, w, imp))
            .collect();
        self.target = Some(t);
    }

    /// `q_r` of a weighted column `w` on the correlation grid, per channel.
    fn correlation_target(
        &mut self,
        fft: &mut RealFft,
        bins: &[usize],
        w: &[Complex64],
        imp: &[Complex64],
    ) -> Vec<Vec<Complex64>> {
        let nr = self.nr;
        let nk = self.causal.n() / 2 + 1;
        let zero = Complex64::new(0.0, 0.0);
        (0..nr)
            .map(|r| {
                let mut x = vec![zero; nk];
                for (j, &k) in bins.iter().enumerate() {
                    x[k] = imp[j].conj() * w[j * nr + r];
                }
                let t = self.real_sum(&mut x);
                padded_spectrum(&t, fft)
            })
            .collect()
    }

    /// For a unit glitch with the decay of the last [`GlitchScan::set_tau`] starting at each
    /// sample `n0 = 0 … N−1`, against the last [`GlitchScan::set_target`]: `B(n0) = Re Σ_j
    /// v_jᴴ w_j` and `A(n0) = Σ_j v_jᴴ C_j⁻¹ v_j` with `v_j = −Y(n0)_j d_j`, the terms of a
    /// glitch's gain (`ln L` changes by `−2aB − a²A` at amplitude `a`). Both are correlations of
    /// the delayed, cut response with the data and with itself, so all starts cost a few
    /// transforms of `P ≥ 2N` instead of one DFT each (`A` by a recursion over the cut). `None`
    /// without a target.
    pub fn gains(&mut self) -> Option<(Vec<f64>, Vec<f64>)> {
        self.gains_and_columns().map(|g| (g.b, g.a))
    }

    /// [`GlitchScan::gains`] and, per column of [`GlitchScan::set_columns`], its `B(n0)` with
    /// that column in place of the residual.
    pub fn gains_and_columns(&mut self) -> Option<ScanGains> {
        let n = self.causal.n();
        let nr = self.nr;
        let t = self.target.as_mut()?;
        let p = t.fft.len();
        let zero = Complex64::new(0.0, 0.0);
        let mut pad = vec![0.0; p];
        let mut zs = Vec::with_capacity(nr);
        for r in 0..nr {
            pad[..n].copy_from_slice(&self.z[r * n..(r + 1) * n]);
            pad[n..].fill(0.0);
            let mut o = vec![zero; p / 2 + 1];
            if t.fft.forward(&pad, &mut o).is_err() {
                return None;
            }
            zs.push(o);
        }
        let mut spec = vec![zero; p / 2 + 1];
        // B(n0) = −Σ_r Σ_u z_r(u) q_r(u + n0): a cross-correlation
        let mut correlate = |q: &[Vec<Complex64>], spec: &mut [Complex64]| {
            for (i, v) in spec.iter_mut().enumerate() {
                *v = (0..nr).map(|r| zs[r][i].conj() * q[r][i]).sum();
            }
            t.fft.inverse(spec, &mut pad).ok()?;
            Some(pad[..n].iter().map(|c| -c).collect::<Vec<f64>>())
        };
        let b = correlate(&t.q, &mut spec)?;
        let columns = t
            .columns
            .iter()
            .map(|q| correlate(q, &mut spec))
            .collect::<Option<Vec<_>>>()?;
        // g_r(L) = Σ_s Σ_{u<L} κ_rs(L − u) z_s(u): causal convolutions
        let mut g = vec![0.0; nr * n];
        for r in 0..nr {
            for (i, v) in spec.iter_mut().enumerate() {
                *v = (0..nr).map(|c| t.kappa[r * nr + c][i] * zs[c][i]).sum();
            }
            t.fft.inverse(&spec, &mut pad).ok()?;
            g[r * n..(r + 1) * n].copy_from_slice(&pad[..n]);
        }
        // F(L) = Σ_rs Σ_{u,u'<L} z_r(u) z_s(u') κ_rs(u − u'), A(n0) = F(N − n0)
        let mut f = vec![0.0; n + 1];
        for l in 0..n {
            let mut d = 0.0;
            for r in 0..nr {
                let zr = self.z[r * n + l];
                for c in 0..nr {
                    d += zr * self.z[c * n + l] * t.kappa0[r * nr + c];
                }
                d += 2.0 * zr * g[r * n + l];
            }
            f[l + 1] = f[l] + d;
        }
        let a = (0..n).map(|n0| f[n - n0]).collect();
        Some(ScanGains { b, a, columns })
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
                while r.is_multiple_of(p) {
                    r /= p;
                }
            }
            assert_eq!(r, 1, "{m}");
            assert!(((2 * n)..m).all(|x| {
                let mut r = x;
                for p in [2, 3, 5] {
                    while r.is_multiple_of(p) {
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

    /// The LTP loop's response to a force impulse outlasts it by its slowest closed-loop mode
    /// (0.13 mHz, ltp-model.md §4): the envelope is monotone, starts at its peak, holds 23 % at
    /// 1200 s and 8 % at 3600 s, and late falls as `e^{−t/τ}` with `τ` from the eigenvalues of
    /// the closed-loop state matrix (an independent computation) to within 10 %.
    #[test]
    fn the_loop_s_response_to_a_force_outlasts_it() {
        use crate::ltp::LtpParams;
        use crate::model::LtpModel;
        let m = LtpModel::new("ltp", Default::default());
        let th = LtpParams::default().to_array().to_vec();
        let e = force_envelope(&m, &th, 8000.0).unwrap();
        assert_eq!(e.len(), 8001);
        assert_eq!(e[0], 1.0);
        assert!(e.windows(2).all(|w| w[1] <= w[0]));
        // measured 0.230 at 1200 s, 0.082 at 3600 s, 0.0045 at 7200 s
        assert!((0.15..0.35).contains(&e[1200]), "{}", e[1200]);
        assert!((0.04..0.12).contains(&e[3600]), "{}", e[3600]);
        assert!(e[7200] < 0.01, "{}", e[7200]);
        // late, the slowest closed-loop pole (the state matrix's eigenvalues) sets the decay
        let poles = crate::ltp::closed_loop_poles(
            &LtpParams::default(),
            &crate::ltp::Controllers::default(),
            &crate::ltp::Masses::default(),
        )
        .unwrap();
        let slowest = poles.iter().map(|z| -z.re).fold(f64::INFINITY, f64::min);
        let want = (-2400.0 * slowest).exp();
        let got = e[7200] / e[4800];
        assert!(
            (got / want - 1.0).abs() < 0.1,
            "{got} vs e^(−2400 s/τ) = {want}"
        );
        // a model that does not say how a force enters has none; no horizon can exhaust memory
        let acc = crate::model::AccelModel::new("acc", Default::default());
        assert!(force_envelope(&acc, &th, 100.0).is_none());
        assert!(force_envelope(&m, &th, 1e12).is_none());
        assert!(force_envelope(&m, &th, f64::NAN).is_none());
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
        response_grid(&m, &th, &GridConsts::new(&m, c.m(), fs), &mut h);
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

    /// The correlations give every start's `B` and `A` as the DFT of each start would.
    #[test]
    fn gains_are_the_per_start_sums() {
        use crate::hermitian::quad;
        use crate::ltp::LtpParams;
        use crate::model::LtpModel;
        use rand::{RngExt, SeedableRng};
        let m = LtpModel::new("ltp", Default::default());
        let th = LtpParams::default().to_array().to_vec();
        let (n, fs, rise) = (1001, 1.0, 2.0);
        let mut scan = GlitchScan::new(&m, &th, n, fs, rise);
        let mut rng = rand::rngs::StdRng::seed_from_u64(5);
        let mut z = || Complex64::new(rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5);
        let bins: Vec<usize> = (3..480).collect();
        let w: Vec<Complex64> = (0..2 * bins.len()).map(|_| z() * 1e-3).collect();
        let imp: Vec<Complex64> = (0..bins.len()).map(|_| z() + 1.0).collect();
        let cinv: Vec<(f64, Complex64, f64)> = (0..bins.len())
            .map(|_| {
                let b = z() * 0.5;
                (1.0 + z().re.abs(), b, 1.0 + z().re.abs())
            })
            .collect();
        scan.set_target(&bins, &w, &cinv, &imp);
        // a column's correlations are the B of a target made of it
        let w2: Vec<Complex64> = (0..2 * bins.len()).map(|_| z() * 1e-3).collect();
        scan.set_columns(&bins, &[w2.clone(), w.clone()], &imp);
        let mut other = GlitchScan::new(&m, &th, n, fs, rise);
        other.set_target(&bins, &w2, &cinv, &imp);
        for tau in [30.0, 400.0] {
            scan.set_tau(tau);
            other.set_tau(tau);
            let g = scan.gains_and_columns().unwrap();
            assert_eq!(g.columns[0], other.gains().unwrap().0);
            assert_eq!(g.columns[1], g.b);
            let (b, a) = scan.gains().unwrap();
            let mut y = vec![Complex64::new(0.0, 0.0); (n / 2 + 1) * 2];
            for n0 in [0, 1, 17, 500, 999, 1000] {
                scan.at_sample(n0, &mut y);
                let (mut bb, mut aa) = (0.0, 0.0);
                for (j, &k) in bins.iter().enumerate() {
                    let v = [-y[2 * k] * imp[j], -y[2 * k + 1] * imp[j]];
                    bb += (v[0].conj() * w[2 * j] + v[1].conj() * w[2 * j + 1]).re;
                    aa += quad(&cinv[j], v);
                }
                let sa = a.iter().fold(1e-300, |x: f64, y| x.max(y.abs()));
                let sb = b.iter().fold(1e-300, |x: f64, y| x.max(y.abs()));
                assert!(
                    (b[n0] - bb).abs() < 1e-9 * sb,
                    "{tau} {n0}: B {} {bb}",
                    b[n0]
                );
                assert!(
                    (a[n0] - aa).abs() < 1e-9 * sa,
                    "{tau} {n0}: A {} {aa}",
                    a[n0]
                );
            }
        }
    }
}
