//! Glitches as part of the model (`[analysis] glitches = "model"`): a parent model plus force
//! glitches on the test masses, each with its own parameters, so that the likelihood fits them
//! jointly with the physics instead of cutting the data out (gating).
//!
//! A glitch has the simulator's shape ([`crate::experiment::Glitch`]): a differential force
//! per unit mass `Δg = a·s(t − t0)` between the test masses (`g2 − g1`),
//! `s(u) = (e^{−u/τ} − e^{−u/τ_r})/c` for `u ≥ 0`, `c` its peak, so that `a` is the peak.
//! Glitch `j` adds the parameters `g<j>_t0` (s from its experiment's first sample),
//! `g<j>_tau` (s) and `g<j>_a` (m s⁻²) after the parent's; the rise time `τ_r` is fixed. A
//! force on one test mass (the simulator's glitch) is `Δg` plus a part along the loop's first
//! coordinate that drag-free control hides ([`Model::force_response`]): fitting that part
//! too left the likelihood flat along it (its Cramér–Rao bound 10⁴ times `Δg`'s), and the MAP
//! search did not converge in 9 of 12 realisations of `examples/glitches.toml`. Each glitch belongs to one experiment and acts
//! only there ([`Model::specialise`] with the experiment's name).
//!
//! # How a force no channel records enters the residual
//! The model reads one more data channel, [`GLITCH_CHANNEL`]: the unit impulse at the
//! experiment's first sample, whose DFT is 1 in every bin under the rectangular window. Its
//! coefficient carries the glitches' response, `M_r,δ = −Y_r`: the DFT over the record of the
//! read-outs' causal response to the glitches' sampled force `Σ_g a_g s(t − t0_g)` through the
//! parent's [`Model::force_response`] `H`, cut at the record's end
//! ([`super::glitch_response`]). The circular product `H(f_k) a S(f_k)` with the closed-form
//! template [`shape_dft`] (the DFT of the sampled shape, a geometric sum) is what the model did
//! before: it wraps the loop's response after the record's end round to its start, which for a
//! glitch in the last third of a stretch left most of it unexplained. Off the record's DFT grid
//! (a transfer-function plot, not a likelihood) the coefficient is still that product. The data
//! of such a model must be gap-free and analysed with the rectangular window (the impulse would
//! otherwise be windowed away); `jobs::prepare` checks both.

use super::bin::{Bin, BinBlock, with_buffer};
use super::covariates::Covariates;
use super::glitch_kernel::{GlitchKernel, ParentKernel};
use super::glitch_response::{
    Causal, GridConsts, add_samples, add_samples_dual, grid_index, peak, response_grid,
    response_grid_dual,
};
use super::traits::{BlockKernel, Model};
use num_complex::{Complex, Complex64};
use num_dual::{Dual64, DualNum};
use std::f64::consts::PI;
use std::sync::Arc;

/// The synthetic data channel of modelled glitches: the unit impulse at the first sample.
pub const GLITCH_CHANNEL: &str = "glitch_impulse";

/// Parameters per glitch (`t0`, `tau`, `a`).
pub const GLITCH_PARAMS: usize = 3;

/// Whether `model` carries modelled glitches (reads [`GLITCH_CHANNEL`]).
pub fn carries_glitches(model: &dyn Model) -> bool {
    model.data_channels().iter().any(|c| c == GLITCH_CHANNEL)
}

/// Whether `name` is a glitch's parameter (`g<j>_t0`, `g<j>_tau`, `g<j>_a`).
pub fn is_glitch_param(name: &str) -> bool {
    glitch_of(name).is_some()
}

/// The glitch (0-based: `g1` is 0) whose parameter `name` is, if it is one.
pub fn glitch_of(name: &str) -> Option<usize> {
    let (j, p) = name.strip_prefix('g')?.split_once('_')?;
    let ok = !j.is_empty() && j.bytes().all(|b| b.is_ascii_digit());
    if !ok || !matches!(p, "t0" | "tau" | "a") {
        return None;
    }
    j.parse::<usize>().ok()?.checked_sub(1)
}

/// The convergence tolerance (in Cramér–Rao σ, as for
/// [`crate::likelihood::fisher_scoring`]) of a MAP search on `model`: 1e−2 when it carries
/// glitches, else the usual 1e−3. A glitch's start enters the sampled template through the
/// first sample after it, so `ln L` has a kink in `t0` at every sample time (the shape rises
/// from zero with a non-zero slope) and Newton's steps oscillate across it at a few 1e−3 σ;
/// a candidate with little amplitude creeps along its flat `t0` and `τ` in steps below 1e−2 σ
/// (measured on `examples/glitches.toml`: `ln L` constant to 1e−3 over the last 25 of 40
/// iterations while some step stayed above 1e−3 σ).
pub fn map_tolerance(model: &dyn Model) -> f64 {
    if model.data_channels().iter().any(|c| c == GLITCH_CHANNEL) {
        1e-2
    } else {
        1e-3
    }
}

/// A parent model plus force glitches (see the module docs).
#[derive(Debug, Clone)]
pub struct GlitchModel {
    name: String,
    parent: Arc<dyn Model>,
    names: Vec<String>,
    units: Vec<String>,
    data: Vec<String>,
    /// Number of the parent's parameters (the glitches' follow).
    np: usize,
    /// The experiment of each glitch.
    experiments: Vec<String>,
    /// Duration `N/fs` of each experiment that has glitches (s).
    durations: Vec<(String, f64)>,
    /// Rise time `τ_r` (s).
    rise: f64,
    /// Specialised to one experiment: its glitches and duration. `None`: no glitch acts.
    here: Option<(Vec<usize>, f64)>,
    /// This instance's key in the Fisher passes' memo of parent coefficients (unique per
    /// construction and specialisation, never reused, unlike an address).
    memo_id: u64,
    /// The parent's constants on the padded grid of the causal response, made on first use
    /// (fresh for every specialisation: its parent is another).
    grid: Arc<std::sync::Mutex<Option<Arc<GridConsts>>>>,
}

impl GlitchModel {
    /// `parent` plus one glitch in each of `experiments` (in order: glitch `j + 1` is in
    /// `experiments[j]`), every experiment's duration (s) in `durations`, rise time `rise` (s).
    /// The parent must say how a differential force between the test masses enters its
    /// residual ([`Model::force_response`]).
    pub fn new(
        name: &str,
        parent: Arc<dyn Model>,
        experiments: Vec<String>,
        durations: Vec<(String, f64)>,
        rise: f64,
    ) -> Result<Self, String> {
        let probe = {
            let mut c = vec![Complex64::new(0.0, 0.0); parent.n_consts()];
            parent.bin_consts(1e-3, 1.0, &mut c);
            let th = vec![0.0; parent.param_names().len()];
            let mut out = vec![Complex64::new(0.0, 0.0); parent.residual_channels().len()];
            parent.force_response(
                &th,
                &Bin {
                    f: 1e-3,
                    fs: 1.0,
                    consts: &c,
                },
                &mut out,
            )
        };
        if !probe {
            return Err(format!(
                "model `{}` does not say how a force on a test mass enters its residual, so glitches cannot be modelled on it (the continuous LTP loop, kind = \"ltp\", and models tied to or drifting from it can); use glitches = \"gate\"",
                parent.name()
            ));
        }
        if parent.data_channels().iter().any(|c| c == GLITCH_CHANNEL) {
            return Err(format!(
                "model `{}` already reads `{GLITCH_CHANNEL}`",
                parent.name()
            ));
        }
        if !(rise.is_finite() && rise > 0.0) {
            return Err(format!("glitch rise time {rise} s: need > 0"));
        }
        for e in &experiments {
            if !durations.iter().any(|(d, t)| d == e && *t > 0.0) {
                return Err(format!("no duration of experiment `{e}`"));
            }
        }
        let np = parent.param_names().len();
        let mut names = parent.param_names().to_vec();
        let mut units = parent.param_units();
        for j in 1..=experiments.len() {
            for (p, u) in [("t0", "s"), ("tau", "s"), ("a", "m s⁻²")] {
                names.push(format!("g{j}_{p}"));
                units.push(u.into());
            }
        }
        if let Some(n) = parent
            .param_names()
            .iter()
            .find(|n| names[np..].contains(n))
        {
            return Err(format!(
                "model `{}` has a parameter `{n}`, the name of a glitch parameter",
                parent.name()
            ));
        }
        let mut data = parent.data_channels().to_vec();
        data.push(GLITCH_CHANNEL.into());
        Ok(Self {
            name: name.into(),
            parent,
            names,
            units,
            data,
            np,
            experiments,
            durations,
            rise,
            here: None,
            memo_id: next_memo_id(),
            grid: Default::default(),
        })
    }

    /// Number of glitches.
    pub fn n_glitches(&self) -> usize {
        self.experiments.len()
    }

    /// The index in θ of the first parameter (`t0`) of glitch `j` (0-based).
    pub fn glitch_index(&self, j: usize) -> usize {
        self.np + GLITCH_PARAMS * j
    }

    /// The experiment of each glitch.
    pub fn experiments(&self) -> &[String] {
        &self.experiments
    }

    /// The parent model.
    pub fn parent(&self) -> &Arc<dyn Model> {
        &self.parent
    }

    /// Fills `out` (`R × (C_p + 1)`) from the parent's coefficients `pc` (`R × C_p`) and the
    /// glitches' response `y` (`R`; `None`: no glitch acts): the impulse's coefficient is `−y`.
    fn fill<T: DualNum<Primitive = f64> + Copy>(
        &self,
        pc: &[Complex<T>],
        y: Option<&[Complex<T>]>,
        out: &mut [Complex<T>],
    ) {
        let nr = self.parent.residual_channels().len();
        let cp = self.data.len() - 1;
        let c = cp + 1;
        for r in 0..nr {
            out[r * c..r * c + cp].copy_from_slice(&pc[r * cp..(r + 1) * cp]);
            out[r * c + cp] = match y {
                Some(y) => -y[r],
                None => Complex::new(T::zero(), T::zero()),
            };
        }
    }

    /// The circular product `Σ_g H a_g S_g` at a frequency off the record's DFT grid (where the
    /// causal response of [`super::glitch_response`] has no bin), from the force response `pf`.
    fn circular<T: DualNum<Primitive = f64> + Copy>(
        &self,
        th: &[T],
        pf: &[Complex<T>],
        bin: &Bin,
        out: &mut [Complex<T>],
    ) {
        out.fill(Complex::new(T::zero(), T::zero()));
        let Some((active, duration)) = &self.here else {
            return;
        };
        for &g in active {
            let i = self.glitch_index(g);
            let s = shape_dft(th[i], th[i + 1], self.rise, *duration, bin.f, bin.fs);
            for (o, h) in out.iter_mut().zip(pf) {
                *o += *h * th[i + 2] * s;
            }
        }
    }

    /// The record's sample count and DFT bin of `bin`, if it is on the grid of this
    /// experiment's record and a glitch acts here.
    fn record_bin(&self, bin: &Bin) -> Option<(usize, usize)> {
        let (active, duration) = self.here.as_ref()?;
        if active.is_empty() {
            return None;
        }
        let n = (duration * bin.fs).round() as usize;
        (n >= 2)
            .then(|| grid_index(bin.f, bin.fs, n).map(|k| (n, k)))
            .flatten()
    }

    /// The parent's constants on the padded grid `(m, fs)`.
    fn grid_consts(&self, m: usize, fs: f64) -> Arc<GridConsts> {
        let mut g = self.grid.lock().unwrap_or_else(|e| e.into_inner());
        match g.as_ref() {
            Some(c) if c.is_for(m, fs) => c.clone(),
            _ => {
                let c = Arc::new(GridConsts::new(self.parent.as_ref(), m, fs));
                *g = Some(c.clone());
                c
            }
        }
    }

    /// The parent's force response on the padded grid at `p` (`m` points at `fs`), kept per
    /// thread for the last parent θ.
    fn with_response_grid<R>(
        &self,
        p: &[f64],
        m: usize,
        fs: f64,
        f: impl FnOnce(&[Complex64]) -> R,
    ) -> R {
        HGRID.with_borrow_mut(|memo| {
            let key = [self.memo_id, m as u64, fs.to_bits()];
            if memo.0 != key || memo.1.as_slice() != p {
                response_grid(
                    self.parent.as_ref(),
                    p,
                    &self.grid_consts(m, fs),
                    &mut memo.2,
                );
                memo.0 = key;
                memo.1 = p.to_vec();
            }
            f(&memo.2)
        })
    }

    /// The causal response `Y_r,k` of this experiment's glitches at θ on bin `k` of a record
    /// of `n` samples at `fs` ([`super::glitch_response`]), into `out` (`R`). The whole record's
    /// response is computed once per θ and thread.
    fn causal_response(&self, th: &[f64], n: usize, fs: f64, k: usize, out: &mut [Complex64]) {
        let nr = out.len();
        self.with_causal_values(th, n, fs, nr, |y| {
            out.copy_from_slice(&y[k * nr..(k + 1) * nr])
        })
    }

    /// Runs `f` with the causal response at θ on every bin of the record (`(N/2 + 1) × nr`),
    /// computed once per θ and thread.
    fn with_causal_values<R>(
        &self,
        th: &[f64],
        n: usize,
        fs: f64,
        nr: usize,
        f: impl FnOnce(&[Complex64]) -> R,
    ) -> R {
        EXACT.with_borrow_mut(|memo| {
            let key = [self.memo_id, n as u64, fs.to_bits()];
            if memo.key != key || memo.theta.as_slice() != th {
                let (active, _) = self.here.as_ref().expect("record_bin checked");
                with_causal(n, fs, |c| {
                    let mut g = vec![0.0; n];
                    for &j in active {
                        let i = self.glitch_index(j);
                        add_samples(th[i], th[i + 1], th[i + 2], self.rise, fs, &mut g);
                    }
                    let mut gs = Vec::new();
                    c.spectrum(&g, &mut gs);
                    memo.y.resize((n / 2 + 1) * nr, Complex64::new(0.0, 0.0));
                    self.with_response_grid(&th[..self.np], c.m(), fs, |h| {
                        c.apply(&[(h, &gs)], nr, &mut memo.y)
                    });
                });
                memo.key = key;
                memo.theta = th.to_vec();
            }
            f(&memo.y)
        })
    }

    /// [`Self::causal_response`] in dual numbers.
    fn causal_response_dual(
        &self,
        th: &[Dual64],
        n: usize,
        fs: f64,
        k: usize,
        out: &mut [Complex<Dual64>],
    ) {
        let nr = out.len();
        EXACT_DUAL.with_borrow_mut(|memo| {
            let key = [self.memo_id, n as u64, fs.to_bits()];
            let same = memo.key == key
                && memo.theta.len() == th.len()
                && memo.theta.iter().zip(th).all(|(a, b)| *a == b.re);
            if !same || memo.dirs.len() >= MAX_DIRECTIONS {
                memo.key = key;
                memo.theta = th.iter().map(|x| x.re).collect();
                memo.dirs.clear();
            }
            let at = memo
                .dirs
                .iter()
                .position(|(eps, _)| eps.iter().zip(th).all(|(e, x)| *e == x.eps));
            let at = match at {
                Some(i) => i,
                None => {
                    let (active, _) = self.here.as_ref().expect("record_bin checked");
                    let dy = with_causal(n, fs, |c| {
                        let p = &th[..self.np];
                        let loop_seeded = p.iter().any(|x| x.eps != 0.0);
                        // values only where the loop is seeded (its derivative is H'·G); dual
                        // samples only for a seeded glitch (the others' derivatives are zero)
                        let (mut g, mut dg) = (vec![0.0; n], vec![0.0; n]);
                        let mut scratch = vec![0.0; n];
                        for &j in active {
                            let i = self.glitch_index(j);
                            if th[i..i + 3].iter().any(|x| x.eps != 0.0) {
                                scratch.fill(0.0);
                                let (t0, tau, a) = (th[i], th[i + 1], th[i + 2]);
                                add_samples_dual(t0, tau, a, self.rise, fs, &mut scratch, &mut dg);
                            }
                            if loop_seeded {
                                let (t0, tau, a) = (th[i].re, th[i + 1].re, th[i + 2].re);
                                add_samples(t0, tau, a, self.rise, fs, &mut g);
                            }
                        }
                        let (mut gs, mut dgs) = (Vec::new(), Vec::new());
                        if loop_seeded {
                            c.spectrum(&g, &mut gs);
                        }
                        let seeded = dg.iter().any(|x| *x != 0.0);
                        if seeded {
                            c.spectrum(&dg, &mut dgs);
                        }
                        let zero = Complex64::new(0.0, 0.0);
                        let mut dy = vec![zero; (n / 2 + 1) * nr];
                        if !loop_seeded {
                            if seeded {
                                let pr: Vec<f64> = p.iter().map(|x| x.re).collect();
                                self.with_response_grid(&pr, c.m(), fs, |h| {
                                    c.apply(&[(h, &dgs)], nr, &mut dy)
                                });
                            }
                        } else {
                            let (mut h, mut dh) = (Vec::new(), Vec::new());
                            let g = self.grid_consts(c.m(), fs);
                            response_grid_dual(self.parent.as_ref(), p, &g, &mut h, &mut dh);
                            if seeded {
                                c.apply(&[(&dh, &gs), (&h, &dgs)], nr, &mut dy);
                            } else {
                                c.apply(&[(&dh, &gs)], nr, &mut dy);
                            }
                        }
                        dy
                    });
                    // the values are the real path's, shared by every seeded direction
                    let re: Vec<f64> = th.iter().map(|x| x.re).collect();
                    let y = self.with_causal_values(&re, n, fs, nr, <[Complex64]>::to_vec);
                    let y = y
                        .iter()
                        .zip(&dy)
                        .map(|(v, d)| {
                            Complex::new(Dual64::new(v.re, d.re), Dual64::new(v.im, d.im))
                        })
                        .collect();
                    memo.dirs.push((th.iter().map(|x| x.eps).collect(), y));
                    memo.dirs.len() - 1
                }
            };
            out.copy_from_slice(&memo.dirs[at].1[k * nr..(k + 1) * nr]);
        })
    }
}

/// The DFT of a glitch's sampled shape (module docs), generic over dual numbers in `t0` and
/// `tau`; zero for a glitch that starts after the record.
pub fn shape_dft<T: DualNum<Primitive = f64> + Copy>(
    t0: T,
    tau: T,
    rise: f64,
    duration: f64,
    f: f64,
    fs: f64,
) -> Complex<T> {
    let n0 = (t0.re() * fs).ceil().max(0.0);
    if n0 >= (duration * fs).round() {
        return Complex::new(T::zero(), T::zero());
    }
    let w = 2.0 * PI * f / fs;
    let (s0, c0) = (w * n0).sin_cos();
    let ph0 = Complex::new(T::from(c0), T::from(-s0));
    let (sw, cw) = w.sin_cos();
    let one = Complex::new(T::one(), T::zero());
    let start = T::from(n0 / fs) - t0;
    let end = T::from(duration) - t0;
    let u = |tau: T| -> Complex<T> {
        let head = (-start / tau).exp();
        let tail = (-end / tau).exp();
        let decay = (-(tau * fs).recip()).exp();
        let z = Complex::new(decay * cw, -(decay * sw));
        (ph0 * head - Complex::new(tail, T::zero())) / (one - z)
    };
    (u(tau) - u(T::from(rise))) / peak(tau, rise)
}

/// The parent's real coefficients at one bin and θ.
#[derive(Default)]
struct ParentMemo {
    /// The model's `memo_id`, the bin's constants (address), `f`, `fs` (bits).
    key: [u64; 4],
    theta: Vec<f64>,
    pc: Vec<Complex64>,
}

thread_local! {
    /// The last bin's parent coefficients evaluated on this thread: a Fisher matrix evaluates
    /// every bin once per free parameter, and for a glitch's parameter the parent's part is
    /// the same in each pass.
    static PARENT: std::cell::RefCell<ParentMemo> = std::cell::RefCell::new(ParentMemo {
        key: [u64::MAX; 4],
        ..Default::default()
    });
}

/// The causal response of one specialised model over its whole record at one θ.
struct ExactMemo<T> {
    /// The model's `memo_id`, the record's samples, `fs` (bits).
    key: [u64; 3],
    theta: Vec<T>,
    y: Vec<Complex<T>>,
}

/// The causal response in dual numbers of one specialised model over its whole record at one
/// real θ, for every seeded direction asked for there. A Fisher pass asks bin by bin for every
/// direction in turn ([`crate::likelihood::gradient_and_fisher`]): with one entry, each bin
/// recomputed the whole record's response once per direction (the MAP search of
/// `examples/glitches.toml` then ran for minutes per Fisher step).
struct DualMemo {
    /// As [`ExactMemo::key`].
    key: [u64; 3],
    /// The real part of θ.
    theta: Vec<f64>,
    /// Each direction's `ε` parts of θ and the response.
    dirs: Vec<(Vec<f64>, Vec<Complex<Dual64>>)>,
}

/// Directions kept per θ in a [`DualMemo`] (a Fisher pass seeds one per free parameter).
const MAX_DIRECTIONS: usize = 256;

thread_local! {
    /// The last θ's causal response on this thread: the generic path asks for it bin by bin.
    static EXACT: std::cell::RefCell<ExactMemo<f64>> = const { std::cell::RefCell::new(ExactMemo {
        key: [u64::MAX; 3],
        theta: Vec::new(),
        y: Vec::new(),
    }) };
    /// As [`EXACT`] in dual numbers, one entry per seeded direction.
    static EXACT_DUAL: std::cell::RefCell<DualMemo> = const { std::cell::RefCell::new(DualMemo {
        key: [u64::MAX; 3],
        theta: Vec::new(),
        dirs: Vec::new(),
    }) };
    /// The parent's force response on the padded grid: `(key, parent θ, H)`.
    static HGRID: std::cell::RefCell<([u64; 3], Vec<f64>, Vec<Complex64>)> =
        const { std::cell::RefCell::new(([u64::MAX; 3], Vec::new(), Vec::new())) };
    /// The transforms of the last record length on this thread.
    static CAUSAL: std::cell::RefCell<Option<Causal>> = const { std::cell::RefCell::new(None) };
}

/// Runs `f` with this thread's transforms of a record of `n` samples.
fn with_causal<R>(n: usize, fs: f64, f: impl FnOnce(&mut Causal) -> R) -> R {
    CAUSAL.with_borrow_mut(|c| {
        if c.as_ref().is_none_or(|c| c.n() != n || c.fs() != fs) {
            *c = Some(Causal::new(n, fs));
        }
        f(c.as_mut().expect("just made"))
    })
}

/// A new [`GlitchModel`] instance's `memo_id`.
fn next_memo_id() -> u64 {
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
}

impl Model for GlitchModel {
    fn name(&self) -> &str {
        &self.name
    }

    fn param_names(&self) -> &[String] {
        &self.names
    }

    fn param_units(&self) -> Vec<String> {
        self.units.clone()
    }

    fn physical_limits(&self) -> Vec<[Option<f64>; 2]> {
        // the loop's parameters first, then the glitches' (no physical limit in their boxes)
        let mut v = self.parent.physical_limits();
        v.resize(self.param_names().len(), [None, None]);
        v
    }

    fn data_channels(&self) -> &[String] {
        &self.data
    }

    fn channel_units(&self) -> Vec<String> {
        // the parent's channels, then the impulse (a unit sample: no unit)
        let mut u = self.parent.channel_units();
        u.resize(self.data.len(), String::new());
        u
    }

    fn residual_channels(&self) -> &[String] {
        self.parent.residual_channels()
    }

    fn n_consts(&self) -> usize {
        self.parent.n_consts()
    }

    fn bin_consts(&self, f: f64, fs: f64, out: &mut [Complex64]) {
        self.parent.bin_consts(f, fs, out)
    }

    fn coefficients(&self, theta: &[f64], bin: &Bin, out: &mut [Complex64]) {
        let nr = self.parent.residual_channels().len();
        let cp = self.data.len() - 1;
        let p = &theta[..self.np];
        with_buffer(nr * cp + 2 * nr, |buf| {
            let (pc, rest) = buf.split_at_mut(nr * cp);
            let (pf, y) = rest.split_at_mut(nr);
            self.parent.coefficients(p, bin, pc);
            let acts = match self.record_bin(bin) {
                Some((n, k)) => {
                    self.causal_response(theta, n, bin.fs, k, y);
                    true
                }
                None => {
                    let has = self.here.is_some() && self.parent.force_response(p, bin, pf);
                    if has {
                        self.circular(theta, pf, bin, y);
                    }
                    has
                }
            };
            self.fill(pc, acts.then_some(&*y), out);
        })
    }

    fn coefficients_dual(&self, theta: &[Dual64], bin: &Bin, out: &mut [Complex<Dual64>]) {
        let nr = self.parent.residual_channels().len();
        let cp = self.data.len() - 1;
        let z = Complex::new(Dual64::from(0.0), Dual64::from(0.0));
        let mut pc = vec![z; nr * cp];
        let mut pf = vec![z; nr];
        let mut y = vec![z; nr];
        let p = &theta[..self.np];
        // a Fisher matrix seeds one parameter at a time: for a glitch's parameter the parent's
        // coefficients are real (their dual evaluation would cost most of the time)
        let loop_seeded = !p.iter().all(|x| x.eps == 0.0);
        if loop_seeded {
            self.parent.coefficients_dual(p, bin, &mut pc);
        } else {
            let lift = |v: &Complex64| Complex::new(Dual64::from(v.re), Dual64::from(v.im));
            PARENT.with_borrow_mut(|memo| {
                let key = [
                    self.memo_id,
                    bin.consts.as_ptr() as u64,
                    bin.f.to_bits(),
                    bin.fs.to_bits(),
                ];
                let hit = memo.key == key
                    && memo.theta.len() == p.len()
                    && memo.theta.iter().zip(p).all(|(a, b)| *a == b.re);
                if !hit {
                    memo.key = key;
                    memo.theta = p.iter().map(|x| x.re).collect();
                    memo.pc.resize(nr * cp, Complex64::new(0.0, 0.0));
                    self.parent.coefficients(&memo.theta, bin, &mut memo.pc);
                }
                for (o, v) in pc.iter_mut().zip(&memo.pc) {
                    *o = lift(v);
                }
            });
        }
        let acts = match self.record_bin(bin) {
            Some((n, k)) => {
                self.causal_response_dual(theta, n, bin.fs, k, &mut y);
                true
            }
            None => {
                let has = self.here.is_some() && self.parent.force_response_dual(p, bin, &mut pf);
                if has {
                    self.circular(theta, &pf, bin, &mut y);
                }
                has
            }
        };
        self.fill(&pc, acts.then_some(&y[..]), out);
    }

    fn is_stable(&self, theta: &[f64]) -> bool {
        self.parent.is_stable(&theta[..self.np])
    }

    fn check(&self, theta: &[f64]) -> Result<(), String> {
        self.parent.check(&theta[..self.np])?;
        for j in 0..self.n_glitches() {
            let tau = theta[self.glitch_index(j) + 1];
            if !(tau > self.rise) {
                return Err(format!(
                    "g{}_tau = {tau} s: a glitch decays slower than it rises ({} s)",
                    j + 1,
                    self.rise
                ));
            }
        }
        Ok(())
    }

    fn data_noise_csd(&self, theta: &[f64], bin: &Bin, out: &mut [Complex64]) -> bool {
        let cp = self.data.len() - 1;
        let mut inner = vec![Complex64::new(0.0, 0.0); cp * cp];
        if !self
            .parent
            .data_noise_csd(&theta[..self.np], bin, &mut inner)
        {
            return false;
        }
        // the impulse is noiseless: a zero row and column
        out.fill(Complex64::new(0.0, 0.0));
        for r in 0..cp {
            out[r * (cp + 1)..r * (cp + 1) + cp].copy_from_slice(&inner[r * cp..(r + 1) * cp]);
        }
        true
    }

    /// The model on experiment `cov.experiment`: its glitches act, the others' do not.
    fn specialise(&self, cov: &Covariates) -> Result<Option<Arc<dyn Model>>, String> {
        let parent = self
            .parent
            .specialise(cov)?
            .unwrap_or_else(|| self.parent.clone());
        let exp = cov.experiment.as_deref();
        let active: Vec<usize> = (0..self.n_glitches())
            .filter(|&j| Some(self.experiments[j].as_str()) == exp)
            .collect();
        let duration = match exp {
            Some(e) if !active.is_empty() => self
                .durations
                .iter()
                .find(|(d, _)| d == e)
                .map(|(_, t)| *t)
                .ok_or_else(|| format!("no duration of experiment `{e}`"))?,
            _ => 0.0,
        };
        Ok(Some(Arc::new(Self {
            parent,
            here: Some((active, duration)),
            memo_id: next_memo_id(),
            grid: Default::default(),
            ..self.clone()
        })))
    }

    /// The parent's parameters, and once specialised only the glitches of its experiment.
    fn reads_param(&self, a: usize) -> bool {
        if a < self.np {
            return self.parent.reads_param(a);
        }
        match &self.here {
            Some((active, _)) => active.contains(&((a - self.np) / GLITCH_PARAMS)),
            None => false,
        }
    }

    fn force_response(&self, theta: &[f64], bin: &Bin, out: &mut [Complex64]) -> bool {
        self.parent.force_response(&theta[..self.np], bin, out)
    }

    /// Specialised to an experiment: the prepared kernel of `model/glitch_kernel.rs`, or the
    /// parent's where no glitch acts.
    fn prepare_kernel(&self, b: &BinBlock) -> Option<Arc<dyn BlockKernel>> {
        let (active, duration) = self.here.as_ref()?;
        if active.is_empty() {
            let nc = self.data.len();
            if b.n == 0 || b.data.len() != b.n * nc {
                return None;
            }
            let data: Vec<Complex64> = b
                .data
                .chunks(nc)
                .flat_map(|d| d[..nc - 1].iter().copied())
                .collect();
            let inner = self
                .parent
                .prepare_kernel(&BinBlock { data: &data, ..*b })?;
            return Some(Arc::new(ParentKernel { inner, np: self.np }));
        }
        let glitches = active.iter().map(|&g| self.glitch_index(g)).collect();
        let k = GlitchKernel::new(
            self.parent.clone(),
            self.np,
            glitches,
            self.rise,
            *duration,
            b,
        )?;
        Some(Arc::new(k))
    }

    fn force_response_dual(
        &self,
        theta: &[Dual64],
        bin: &Bin,
        out: &mut [Complex<Dual64>],
    ) -> bool {
        self.parent.force_response_dual(&theta[..self.np], bin, out)
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::experiment::Glitch;
    use crate::model::{LtpModel, coefficients_at};
    use crate::signal::RealFft;

    #[test]
    fn glitch_parameters_are_named_as_the_model_names_them() {
        let m = model();
        let names = m.param_names();
        assert!(names[..7].iter().all(|n| !is_glitch_param(n)));
        assert!(names[7..].iter().all(|n| is_glitch_param(n)));
        for n in ["g_t0", "gx_tau", "g1_b", "g1", "w1sq", "g12_a2", "g0_a"] {
            assert!(!is_glitch_param(n), "{n}");
        }
        assert_eq!(glitch_of("g13_a"), Some(12));
        assert_eq!(glitch_of("g1_t0"), Some(0));
    }

    /// The closed form equals the FFT of the sampled shape, for starts on and off the sample
    /// grid and a glitch cut by the record's end.
    #[test]
    fn shape_dft_is_the_fft_of_the_samples() {
        let (n, fs) = (4096usize, 2.0);
        let duration = n as f64 / fs;
        for (t0, tau) in [(100.0, 40.0), (333.37, 200.0), (1900.2, 300.0), (0.0, 12.0)] {
            let g = Glitch {
                t0,
                amplitude: 1.0,
                decay: tau,
                rise: 2.0,
                tm: 1,
            };
            let x: Vec<f64> = (0..n).map(|k| g.at(k as f64 / fs)).collect();
            let mut fft = RealFft::new(n).unwrap();
            let mut spec = vec![Complex64::new(0.0, 0.0); fft.spectrum_len()];
            fft.forward(&x, &mut spec).unwrap();
            let big = spec.iter().map(|z| z.norm()).fold(0.0, f64::max);
            for k in [1usize, 7, 100, 1000, 2047] {
                let s = shape_dft(t0, tau, 2.0, duration, k as f64 * fs / n as f64, fs);
                assert!(
                    (s - spec[k]).norm() < 1e-10 * big,
                    "t0 {t0} k {k}: {s} vs {}",
                    spec[k]
                );
            }
        }
    }

    /// Dual derivatives in `t0` and `tau` equal central differences.
    #[test]
    fn shape_dft_derivatives_are_exact() {
        let (duration, fs, f) = (4000.0, 1.0, 0.013);
        for (t0, tau) in [(100.3, 40.0), (2500.6, 700.0)] {
            let d = |a: usize| {
                let mut x = [Dual64::from(t0), Dual64::from(tau)];
                x[a] = x[a].derivative();
                let s = shape_dft(x[0], x[1], 2.0, duration, f, fs);
                Complex64::new(s.re.eps, s.im.eps)
            };
            let h = 1e-4;
            let fd_t0 = (shape_dft(t0 + h, tau, 2.0, duration, f, fs)
                - shape_dft(t0 - h, tau, 2.0, duration, f, fs))
                / (2.0 * h);
            let fd_tau = (shape_dft(t0, tau + h, 2.0, duration, f, fs)
                - shape_dft(t0, tau - h, 2.0, duration, f, fs))
                / (2.0 * h);
            assert!(
                (d(0) - fd_t0).norm() < 1e-6 * fd_t0.norm(),
                "{} {fd_t0}",
                d(0)
            );
            assert!(
                (d(1) - fd_tau).norm() < 1e-6 * fd_tau.norm(),
                "{} {fd_tau}",
                d(1)
            );
        }
    }

    /// Why the MAP search on a glitch model stops at 1e−2 σ ([`map_tolerance`]): the sampled
    /// template has a kink in `t0` at every sample time. As `t0` crosses sample `k` from below,
    /// that sample drops from `slope × (t_k − t0)` to zero, so `∂S/∂t0` jumps by
    /// `slope · e^{−2πi f t_k}` (`slope` the normalised shape's at its start) and is smooth
    /// elsewhere.
    #[test]
    fn the_sampled_template_kinks_in_t0_at_every_sample_time() {
        let (duration, fs, f, tau, rise) = (4000.0, 1.0, 0.013, 100.0, 2.0);
        let s = |t0: f64| shape_dft(t0, tau, rise, duration, f, fs);
        let h = 1e-6;
        let star = (tau / rise).ln() * tau * rise / (tau - rise);
        let peak = (-star / tau).exp() - (-star / rise).exp();
        let slope = (1.0 / rise - 1.0 / tau) / peak;
        let jump = |t: f64| ((s(t + h) - s(t)) - (s(t) - s(t - h))) / h;
        for t in [1000.0, 1001.0, 2500.0] {
            let want = Complex64::from_polar(slope, -2.0 * std::f64::consts::PI * f * t);
            let got = jump(t);
            assert!(
                (got - want).norm() < 1e-3 * slope,
                "t0 {t}: {got} vs {want}"
            );
        }
        // between sample times the derivative is continuous
        assert!(jump(1000.5).norm() < 1e-3 * slope, "{}", jump(1000.5));
        assert_eq!(map_tolerance(&model()), 1e-2);
        let plain = LtpModel::new("ltp", Default::default());
        assert_eq!(map_tolerance(&plain), 1e-3);
        assert!(carries_glitches(&model()) && !carries_glitches(&plain));
    }

    /// The LTP loop with glitches in experiments `a` (two: `g1`, `g3`) and `b` (`g2`).
    pub(in crate::model) fn model() -> GlitchModel {
        let p: Arc<dyn Model> = Arc::new(LtpModel::new("ltp", Default::default()));
        GlitchModel::new(
            "ltp",
            p,
            vec!["a".into(), "b".into(), "a".into()],
            vec![("a".into(), 3000.0), ("b".into(), 5000.0)],
            2.0,
        )
        .unwrap()
    }

    fn theta(m: &GlitchModel) -> Vec<f64> {
        let mut th = crate::ltp::LtpParams::default().to_array().to_vec();
        for j in 0..m.n_glitches() {
            th.extend([300.4 + 500.0 * j as f64, 60.0, -1e-13 * (j + 1) as f64]);
        }
        th
    }

    /// On its experiment the impulse's coefficient is minus the glitches' causal response
    /// (against a slow oracle: a direct convolution); elsewhere, and unspecialised, it is zero;
    /// the parent's coefficients are kept.
    #[test]
    fn coefficients_add_the_glitches_of_the_experiment_only() {
        let m = model();
        let th = theta(&m);
        let (f, fs) = (0.01, 1.0);
        let parent = coefficients_at(m.parent().as_ref(), &th[..7], f, fs);
        let on = |e: Option<&str>| {
            let cov = Covariates {
                experiment: e.map(str::to_string),
                ..Default::default()
            };
            let s = m.specialise(&cov).unwrap().unwrap();
            coefficients_at(s.as_ref(), &th, f, fs)
        };
        let plain = coefficients_at(&m, &th, f, fs);
        let sa = m
            .specialise(&Covariates {
                experiment: Some("a".into()),
                ..Default::default()
            })
            .unwrap()
            .unwrap();
        let read: Vec<usize> = (0..th.len()).filter(|&i| sa.reads_param(i)).collect();
        let want: Vec<usize> = (0..10).chain(13..16).collect();
        assert_eq!(read, want, "experiment a reads the loop, g1 and g3");
        let a = on(Some("a"));
        let c = on(Some("c"));
        // the oracle: the loop's impulse response by a long inverse transform (2^18 samples,
        // where it has died), convolved sample by sample with the simulator's glitches, and
        // transformed at this bin of the 3000-sample record. A sampled `H` that is not band-
        // limited has a small acausal part at negative lags (the end of the long grid), which
        // the model's and the simulator's products include: so does the sum.
        let (n, l) = (3000usize, 1usize << 18);
        let mut hs = [
            vec![Complex64::new(0.0, 0.0); l / 2 + 1],
            vec![Complex64::new(0.0, 0.0); l / 2 + 1],
        ];
        for j in 1..=l / 2 {
            let fj = j as f64 * fs / l as f64;
            let mut c = vec![Complex64::new(0.0, 0.0); m.n_consts()];
            m.bin_consts(fj, fs, &mut c);
            let mut h = [Complex64::new(0.0, 0.0); 2];
            let b = Bin {
                f: fj,
                fs,
                consts: &c,
            };
            assert!(m.force_response(&th, &b, &mut h));
            hs[0][j] = h[0];
            hs[1][j] = h[1];
        }
        let mut fft = RealFft::new(l).unwrap();
        let g: Vec<f64> = (0..n)
            .map(|t| {
                [0usize, 2]
                    .iter()
                    .map(|&j| {
                        let i = 7 + 3 * j;
                        Glitch {
                            t0: th[i],
                            decay: th[i + 1],
                            amplitude: th[i + 2],
                            rise: 2.0,
                            tm: 2,
                        }
                        .at(t as f64 / fs)
                    })
                    .sum()
            })
            .collect();
        let k = (f * n as f64 / fs).round();
        for r in 0..2 {
            let mut h = vec![0.0; l];
            fft.inverse(&hs[r], &mut h).unwrap();
            let mut want = Complex64::new(0.0, 0.0);
            for t in 0..n {
                let y: f64 = (0..n).map(|s| h[(t + l - s) % l] * g[s]).sum();
                want -= Complex64::from_polar(y, -2.0 * PI * k * t as f64 / n as f64);
            }
            assert_eq!(&a[r * 5..r * 5 + 4], &parent[r * 4..r * 4 + 4]);
            assert_eq!(plain[r * 5 + 4], Complex64::new(0.0, 0.0));
            assert_eq!(c[r * 5 + 4], Complex64::new(0.0, 0.0));
            assert!(
                (a[r * 5 + 4] - want).norm() < 1e-8 * want.norm(),
                "{r}: {} {want}",
                a[r * 5 + 4]
            );
        }
        // off the record's grid, the circular product of the force response and the template
        let f_off = 0.01 + 0.3 / 3000.0;
        let mut cst = vec![Complex64::new(0.0, 0.0); m.n_consts()];
        m.bin_consts(f_off, fs, &mut cst);
        let bin = Bin {
            f: f_off,
            fs,
            consts: &cst,
        };
        let mut h = [Complex64::new(0.0, 0.0); 2];
        assert!(m.force_response(&th, &bin, &mut h));
        let a = {
            let cov = Covariates {
                experiment: Some("a".into()),
                ..Default::default()
            };
            coefficients_at(
                m.specialise(&cov).unwrap().unwrap().as_ref(),
                &th,
                f_off,
                fs,
            )
        };
        for r in 0..2 {
            let mut want = Complex64::new(0.0, 0.0);
            for g in [0usize, 2] {
                let i = 7 + 3 * g;
                let s = shape_dft(th[i], th[i + 1], 2.0, 3000.0, f_off, fs);
                want -= h[r] * th[i + 2] * s;
            }
            assert!((a[r * 5 + 4] - want).norm() < 1e-12 * want.norm());
        }
    }

    /// `m` specialised to its experiment `a`.
    fn on_a(m: &GlitchModel) -> Arc<dyn Model> {
        let cov = Covariates {
            experiment: Some("a".into()),
            ..Default::default()
        };
        m.specialise(&cov).unwrap().unwrap()
    }

    /// The `ε` parts of `s`'s dual coefficients at `th` seeded in parameter `a`, bin `f`.
    fn derivative(s: &dyn Model, th: &[f64], a: usize, f: f64, fs: f64) -> Vec<Complex64> {
        let mut cst = vec![Complex64::new(0.0, 0.0); s.n_consts()];
        s.bin_consts(f, fs, &mut cst);
        let bin = Bin {
            f,
            fs,
            consts: &cst,
        };
        let mut d: Vec<Dual64> = th.iter().map(|&v| Dual64::from(v)).collect();
        d[a] = d[a].derivative();
        let mut out = vec![Complex::new(Dual64::from(0.0), Dual64::from(0.0)); 10];
        s.coefficients_dual(&d, &bin, &mut out);
        out.iter()
            .map(|c| Complex64::new(c.re.eps, c.im.eps))
            .collect()
    }

    /// Every parameter's dual derivative of the specialised coefficients equals a central
    /// difference.
    #[test]
    fn dual_coefficients_have_exact_derivatives() {
        let m = model();
        let s = on_a(&m);
        let th = theta(&m);
        let (f, fs) = (0.004, 1.0);
        let mut cst = vec![Complex64::new(0.0, 0.0); m.n_consts()];
        m.bin_consts(f, fs, &mut cst);
        let bin = Bin {
            f,
            fs,
            consts: &cst,
        };
        for a in [0usize, 3, 6, 7, 8, 9, 13] {
            let mut d: Vec<Dual64> = th.iter().map(|&v| Dual64::from(v)).collect();
            d[a] = d[a].derivative();
            let mut out = vec![Complex::new(Dual64::from(0.0), Dual64::from(0.0)); 10];
            s.coefficients_dual(&d, &bin, &mut out);
            let h = 1e-6 * th[a].abs().max(1e-30);
            let (mut up, mut dn) = (th.clone(), th.clone());
            up[a] += h;
            dn[a] -= h;
            let cu = coefficients_at(s.as_ref(), &up, f, fs);
            let cd = coefficients_at(s.as_ref(), &dn, f, fs);
            let z = coefficients_at(s.as_ref(), &th, f, fs);
            let fd: Vec<Complex64> = (0..10).map(|k| (cu[k] - cd[k]) / (2.0 * h)).collect();
            // central differences of the loop's entries carry ~1e−6 of the largest
            let scale = fd.iter().map(|z| z.norm()).fold(0.0, f64::max);
            for k in 0..10 {
                let v = Complex64::new(out[k].re.re, out[k].im.re);
                assert!((v - z[k]).norm() <= 1e-13 * z[k].norm(), "{v} vs {}", z[k]);
                let ex = Complex64::new(out[k].re.eps, out[k].im.eps);
                assert!(
                    (ex - fd[k]).norm() <= 1e-4 * fd[k].norm() + 1e-6 * scale,
                    "param {a} comp {k}: {ex} vs {}",
                    fd[k]
                );
            }
        }
    }

    /// A Fisher pass asks for every direction at one bin before the next bin: each answer is
    /// that direction's, as when it is asked alone.
    #[test]
    fn interleaved_directions_get_their_own_derivatives() {
        let m = model();
        let s = on_a(&m);
        let th = theta(&m);
        let fs = 1.0;
        let dirs = [0usize, 7, 8, 9, 3];
        let bins = [0.004, 0.005, 0.02];
        let mut interleaved = Vec::new();
        for &f in &bins {
            for &a in &dirs {
                interleaved.push(derivative(s.as_ref(), &th, a, f, fs));
            }
        }
        let mut i = 0;
        for &f in &bins {
            for &a in &dirs {
                // another model's response in between empties this thread's memo
                derivative(on_a(&model()).as_ref(), &th, a, f, fs);
                let alone = derivative(s.as_ref(), &th, a, f, fs);
                assert!(alone.iter().any(|z| z.norm() > 0.0), "direction {a}");
                assert_eq!(interleaved[i], alone, "direction {a} at {f} Hz");
                i += 1;
            }
        }
    }

    /// Glitches can be put on a drifting loop: it gives the force response of the stretch it
    /// is specialised to.
    #[test]
    fn a_drifting_parent_carries_glitches() {
        use crate::model::{DriftModel, DriftRule};
        let cov = |k: usize| Covariates::new(Some(&format!("s{k}")), &[("time", k as f64 * 1e5)]);
        let ltp: Arc<dyn Model> = Arc::new(LtpModel::new("ltp", Default::default()));
        let d: Arc<dyn Model> = Arc::new(
            DriftModel::new(
                "d",
                ltp.clone(),
                vec![cov(0), cov(1)],
                &[("w1sq".to_string(), DriftRule::Linear("time".into()))],
            )
            .unwrap(),
        );
        let m = GlitchModel::new(
            "g",
            d.clone(),
            vec!["a".into()],
            vec![("a".into(), 3000.0)],
            2.0,
        )
        .unwrap();
        // w1sq, its slope, then the loop's others: in stretch 1 w1sq is −1.3e−6 + 0.5e5·1e−12
        let mut th = vec![-1.3e-6, 1e-12, -1.9e-6, 0.2, 0.2, 0.82, 1.08, 4e-4];
        th.extend([300.4, 60.0, 2e-13]);
        let mut here = cov(1);
        here.experiment = Some("a".into());
        let s = m.specialise(&here).unwrap().unwrap();
        let mut c = vec![Complex64::new(0.0, 0.0); ltp.n_consts()];
        ltp.bin_consts(0.01, 1.0, &mut c);
        let bin = Bin {
            f: 0.01,
            fs: 1.0,
            consts: &c,
        };
        let (mut got, mut want) = ([Complex64::new(0.0, 0.0); 2], [Complex64::new(0.0, 0.0); 2]);
        assert!(s.force_response(&th, &bin, &mut got));
        let loop_th = [-1.3e-6 + 0.5e5 * 1e-12, -1.9e-6, 0.2, 0.2, 0.82, 1.08, 4e-4];
        assert!(ltp.force_response(&loop_th, &bin, &mut want));
        for (a, b) in got.iter().zip(&want) {
            assert!((a - b).norm() <= 1e-12 * b.norm(), "{a} vs {b}");
        }
    }

    #[test]
    fn a_parent_without_a_force_response_is_refused() {
        let p: Arc<dyn Model> = Arc::new(crate::model::AccelModel::new("acc", Default::default()));
        let e = GlitchModel::new("x", p, vec![], vec![], 2.0).unwrap_err();
        assert!(e.contains("glitches = \"gate\""), "{e}");
    }
}
