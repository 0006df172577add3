//! The model layer: what a model is, independent of data files and samplers.
//!
//! A model has named real parameters θ. At a frequency `f` it gives the complex coefficients
//! `M_rc(f; θ)` that turn an experiment's data channels `d_c` (DFTs of named time series:
//! `o1`, `o12`, `i1`, `i12`, `g1`, …) into its residual channels `r_r`:
//!
//! ```text
//! r_r(f; θ) = Σ_c M_rc(f; θ) d_c(f)
//! ```
//!
//! The residual is what the model says is noise. The closed loop of the LTP is
//! `r = o − H_io(θ) i` (coefficients `[I | −H_io]`); the acceleration domain is
//! `r = P(θ) o − G(θ) g`. The likelihood (`crate::likelihood`) is written once for every model:
//! `ln L = −Σ_e Σ_k r_kᴴ C_k⁻¹ r_k + const`, with `C_k` the CSD of the residual noise.
//!
//! Coefficients come in two flavours with one implementation behind them: `f64` for the
//! likelihood and [`Dual64`] (forward-mode dual numbers) so that every model gets exact
//! parameter derivatives, hence an exact Fisher matrix.
//!
//! θ-independent per-bin factors (controller responses, fixed filters) are computed once per
//! bin by [`Model::bin_consts`] and handed back on every call in [`Bin::consts`]: the hot
//! path never recomputes them and never allocates.

pub mod accel;
pub mod ltp;
mod ltp_kernel;
pub mod tied;
pub mod user;

pub use accel::{AccelModel, AccelOptions};
pub use ltp::{LoopResponse, LtpModel, LtpModelOptions, ThrusterResponse};
pub use tied::TiedModel;

use num_complex::{Complex, Complex64};
use num_dual::Dual64;

/// Most data channels a model may read.
pub const MAX_CHANNELS: usize = 8;
/// Most residual channels a model may produce (the likelihood's noise matrix is 2×2 at most).
pub const MAX_RESIDUALS: usize = 2;
/// Most θ-independent complex constants per bin.
pub const MAX_CONSTS: usize = 64;

/// One frequency bin as a model sees it.
#[derive(Debug, Clone, Copy)]
pub struct Bin<'a> {
    /// Frequency (Hz).
    pub f: f64,
    /// Sample rate of the experiment (Hz), for models with a discrete-time response.
    pub fs: f64,
    /// The model's own θ-independent constants at `f` (from [`Model::bin_consts`]).
    pub consts: &'a [Complex64],
}

/// A contiguous run of DFT bins of one experiment with everything the likelihood needs:
/// `f_k = f0 + k·df`, the data DFTs, the inverse noise matrices and the model's constants.
///
/// Models with a fast kernel ([`Model::residual_power`]) read it directly.
#[derive(Debug, Clone, Copy)]
pub struct BinBlock<'a> {
    /// Frequency of the first bin (Hz).
    pub f0: f64,
    /// Bin spacing (Hz).
    pub df: f64,
    /// Sample rate (Hz).
    pub fs: f64,
    /// Number of bins.
    pub n: usize,
    /// Data DFTs, `n × C`, bin-major, in the order of [`Model::data_channels`].
    pub data: &'a [Complex64],
    /// Inverse residual-noise matrix per bin, packed `(a, b, c)` = `[[a, b], [b*, c]]`. For a
    /// one-residual model only `a` is used (`b = c = 0`).
    pub cinv: &'a [(f64, Complex64, f64)],
    /// The model's constants, `n × n_consts`, bin-major.
    pub consts: &'a [Complex64],
}

impl BinBlock<'_> {
    /// The [`Bin`] of bin `k`.
    #[inline(always)]
    pub fn bin(&self, k: usize, n_consts: usize) -> Bin<'_> {
        Bin {
            f: self.f0 + k as f64 * self.df,
            fs: self.fs,
            consts: &self.consts[k * n_consts..(k + 1) * n_consts],
        }
    }
}

/// `rᴴ C⁻¹ r` for a packed Hermitian inverse.
#[inline(always)]
pub fn quad(cinv: &(f64, Complex64, f64), r: [Complex64; 2]) -> f64 {
    crate::hermitian::quad(cinv, r)
}

/// A linear frequency-response model (see the module docs).
///
/// Implementors provide the coefficient matrix once, generically, and expose it through
/// [`Model::coefficients`] and [`Model::coefficients_dual`]. Everything else has a default.
///
/// ```
/// use occam::model::{Bin, Model};
/// use num_complex::{Complex, Complex64};
/// use num_dual::Dual64;
///
/// /// r = o − a·i: one gain between an injection and an output.
/// #[derive(Debug)]
/// struct Gain { names: Vec<String>, data: Vec<String>, res: Vec<String> }
/// impl Model for Gain {
///     fn name(&self) -> &str { "gain" }
///     fn param_names(&self) -> &[String] { &self.names }
///     fn data_channels(&self) -> &[String] { &self.data }
///     fn residual_channels(&self) -> &[String] { &self.res }
///     fn coefficients(&self, th: &[f64], _: &Bin, out: &mut [Complex64]) {
///         out[0] = Complex64::new(1.0, 0.0);
///         out[1] = Complex64::new(-th[0], 0.0);
///     }
///     fn coefficients_dual(&self, th: &[Dual64], _: &Bin, out: &mut [Complex<Dual64>]) {
///         out[0] = Complex::new(Dual64::from(1.0), Dual64::from(0.0));
///         out[1] = Complex::new(-th[0], Dual64::from(0.0));
///     }
/// }
/// let m = Gain { names: vec!["a".into()], data: vec!["o1".into(), "i1".into()], res: vec!["o1".into()] };
/// let mut c = [Complex64::new(0.0, 0.0); 2];
/// m.coefficients(&[2.0], &Bin { f: 0.1, fs: 10.0, consts: &[] }, &mut c);
/// assert_eq!(c[1].re, -2.0);
/// ```
pub trait Model: Send + Sync + std::fmt::Debug {
    /// A short name for messages and outputs.
    fn name(&self) -> &str;

    /// Parameter names, in the order of θ.
    fn param_names(&self) -> &[String];

    /// SI unit of each parameter, in the order of θ, for axis labels and tables: `"s⁻²"`,
    /// `"s"`, `"Hz"`; an empty string for a dimensionless parameter or an unknown unit. The
    /// default knows no units, so models written before units existed keep working.
    fn param_units(&self) -> Vec<String> {
        vec![String::new(); self.param_names().len()]
    }

    /// Data channels `d_c` the model reads (columns of `M`), at most [`MAX_CHANNELS`].
    fn data_channels(&self) -> &[String];

    /// Residual channels `r_r` (rows of `M`), one or two.
    fn residual_channels(&self) -> &[String];

    /// Number of θ-independent complex constants per bin.
    fn n_consts(&self) -> usize {
        0
    }

    /// Fills `out` (length [`Model::n_consts`]) with the constants at `f` for data sampled at
    /// `fs`.
    fn bin_consts(&self, _f: f64, _fs: f64, _out: &mut [Complex64]) {}

    /// `M_rc(f; θ)`, row-major: `out[r·C + c]`, `C = data_channels().len()`.
    fn coefficients(&self, theta: &[f64], bin: &Bin, out: &mut [Complex64]);

    /// As [`Model::coefficients`] with dual-number parameters (exact derivatives).
    fn coefficients_dual(&self, theta: &[Dual64], bin: &Bin, out: &mut [Complex<Dual64>]);

    /// Selected components `comps` (indices `r·C + c` of [`Model::coefficients`]) of
    /// `M(f_e; θ)` at many frequencies `freqs` (constants `consts`, `freqs.len() ×
    /// n_consts`, bin-major) into `out[e·comps.len() + i]`: what relative binning needs per θ
    /// at its coarse-bin edges.
    ///
    /// The default loops over [`Model::coefficients`]; a model may override it with a batch
    /// that computes only the requested components (the LTP closed loop does), and must then
    /// give the same values to rounding.
    fn coefficients_batch(
        &self,
        theta: &[f64],
        freqs: &[f64],
        fs: f64,
        consts: &[Complex64],
        comps: &[usize],
        out: &mut [Complex64],
    ) {
        coefficients_batch_generic(self, theta, freqs, fs, consts, comps, out)
    }

    /// Whether the model is physically valid at θ (e.g. a stable loop); the message says why
    /// not. The likelihood does not call it per evaluation; `fit` and `select` warn when the
    /// start of a model's MAP search (its fixed values and start values) fails it.
    fn check(&self, _theta: &[f64]) -> Result<(), String> {
        Ok(())
    }

    /// `Σ_k r_kᴴ C_k⁻¹ r_k` over a block of bins: the hot path of the exact likelihood.
    ///
    /// The default evaluates [`Model::coefficients`] bin by bin; models with a faster kernel
    /// (the LTP closed loop) override it and are tested against the default.
    fn residual_power(&self, theta: &[f64], block: &BinBlock) -> f64 {
        residual_power_generic(self, theta, block)
    }

    /// A kernel for one block of bins, prepared once (it may precompute anything that does not
    /// depend on θ, data included) and then evaluated for many θ, like an FFT plan. `None`
    /// (the default) means [`Model::residual_power`] is used. A prepared kernel must give the
    /// same value as [`residual_power_generic`] to rounding; its tests say how close.
    fn prepare_kernel(&self, _block: &BinBlock) -> Option<std::sync::Arc<dyn BlockKernel>> {
        None
    }

    /// One kernel for several blocks at once (the experiments of a likelihood), which may
    /// share work between them (the LTP closed loop computes `det P` once for experiments on
    /// one grid). `None` (the default) means per-block kernels ([`Model::prepare_kernel`]).
    /// Its value is the sum over the blocks.
    fn prepare_joint_kernel(
        &self,
        _blocks: &[BinBlock],
    ) -> Option<std::sync::Arc<dyn BlockKernel>> {
        None
    }
}

/// A prepared per-block evaluation of `Σ_k r_kᴴ C_k⁻¹ r_k` (see [`Model::prepare_kernel`]).
pub trait BlockKernel: Send + Sync + std::fmt::Debug {
    /// `Σ_k r_kᴴ C_k⁻¹ r_k` at θ. Allocation-free.
    fn residual_power(&self, theta: &[f64]) -> f64;
}

/// The default [`Model::residual_power`]: coefficients bin by bin. Kept callable so fast
/// kernels can be tested against it.
pub fn residual_power_generic<M: Model + ?Sized>(m: &M, theta: &[f64], b: &BinBlock) -> f64 {
    let nc = m.data_channels().len();
    let nr = m.residual_channels().len();
    let ncst = m.n_consts();
    let mut coef = [Complex64::new(0.0, 0.0); MAX_CHANNELS * MAX_RESIDUALS];
    let mut s = 0.0;
    for k in 0..b.n {
        m.coefficients(theta, &b.bin(k, ncst), &mut coef[..nr * nc]);
        let d = &b.data[k * nc..(k + 1) * nc];
        let r = residual(&coef, nr, d);
        s += quad(&b.cinv[k], r);
    }
    s
}

/// The default [`Model::coefficients_batch`]: [`Model::coefficients`] frequency by frequency.
pub fn coefficients_batch_generic<M: Model + ?Sized>(
    m: &M,
    theta: &[f64],
    freqs: &[f64],
    fs: f64,
    consts: &[Complex64],
    comps: &[usize],
    out: &mut [Complex64],
) {
    let ncoef = m.data_channels().len() * m.residual_channels().len();
    let ncst = m.n_consts();
    let nc = comps.len();
    let mut coef = [Complex64::new(0.0, 0.0); MAX_CHANNELS * MAX_RESIDUALS];
    for (e, &f) in freqs.iter().enumerate() {
        let bin = Bin {
            f,
            fs,
            consts: &consts[e * ncst..(e + 1) * ncst],
        };
        m.coefficients(theta, &bin, &mut coef[..ncoef]);
        for (o, &c) in out[e * nc..(e + 1) * nc].iter_mut().zip(comps) {
            *o = coef[c];
        }
    }
}

/// `r = M d` for `nr` rows (the second component is zero for a one-residual model).
#[inline(always)]
pub fn residual(coef: &[Complex64], nr: usize, d: &[Complex64]) -> [Complex64; 2] {
    let nc = d.len();
    let mut r = [Complex64::new(0.0, 0.0); 2];
    for (ri, slot) in r.iter_mut().enumerate().take(nr) {
        let row = &coef[ri * nc..(ri + 1) * nc];
        for (m, x) in row.iter().zip(d) {
            *slot += m * x;
        }
    }
    r
}

/// Checks that a model's shape is usable by the likelihood: names unique and non-empty, one or
/// two residual channels, at most [`MAX_CHANNELS`] data channels and [`MAX_CONSTS`] constants.
pub fn validate_shape(m: &dyn Model) -> Result<(), String> {
    let name = m.name();
    let nr = m.residual_channels().len();
    if nr == 0 || nr > MAX_RESIDUALS {
        return Err(format!(
            "model `{name}` has {nr} residual channels; one or two are supported"
        ));
    }
    let nc = m.data_channels().len();
    if nc == 0 || nc > MAX_CHANNELS {
        return Err(format!(
            "model `{name}` reads {nc} data channels; 1 to {MAX_CHANNELS} are supported"
        ));
    }
    if m.n_consts() > MAX_CONSTS {
        return Err(format!(
            "model `{name}` needs {} constants per bin; at most {MAX_CONSTS} are supported",
            m.n_consts()
        ));
    }
    for (what, list) in [
        ("parameter", m.param_names()),
        ("data channel", m.data_channels()),
        ("residual channel", m.residual_channels()),
    ] {
        for (i, a) in list.iter().enumerate() {
            if a.is_empty() {
                return Err(format!("model `{name}`: a {what} has an empty name"));
            }
            if list[..i].contains(a) {
                return Err(format!("model `{name}`: {what} `{a}` is listed twice"));
            }
        }
    }
    Ok(())
}

/// Errors if some parameter has no effect on any coefficient at `theta` over `freqs` (the
/// dual derivative of every coefficient with respect to it is zero at every frequency).
pub fn check_identifiable(
    m: &dyn Model,
    theta: &[f64],
    freqs: &[f64],
    fs: f64,
) -> Result<(), String> {
    let np = m.param_names().len();
    if theta.len() != np {
        return Err(format!(
            "model `{}`: θ has {} values for {np} parameters",
            m.name(),
            theta.len()
        ));
    }
    let ncoef = m.data_channels().len() * m.residual_channels().len();
    let mut consts = vec![Complex64::new(0.0, 0.0); m.n_consts()];
    let mut out = vec![Complex::new(Dual64::from(0.0), Dual64::from(0.0)); ncoef];
    let mut seen = vec![false; np];
    let mut th: Vec<Dual64> = theta.iter().map(|&x| Dual64::from(x)).collect();
    for &f in freqs {
        m.bin_consts(f, fs, &mut consts);
        let bin = Bin {
            f,
            fs,
            consts: &consts,
        };
        for a in 0..np {
            if seen[a] {
                continue;
            }
            th[a] = Dual64::from(theta[a]).derivative();
            m.coefficients_dual(&th, &bin, &mut out);
            th[a] = Dual64::from(theta[a]);
            seen[a] = out.iter().any(|z| {
                (z.re.eps != 0.0 && z.re.eps.is_finite())
                    || (z.im.eps != 0.0 && z.im.eps.is_finite())
            });
        }
    }
    let dead: Vec<String> = m
        .param_names()
        .iter()
        .zip(&seen)
        .filter(|(_, s)| !**s)
        .map(|(p, _)| format!("`{p}`"))
        .collect();
    if dead.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "model `{}`: parameter{} {} ha{} no effect on any coefficient at this θ \
             over the {} frequencies checked, so the data cannot determine {}",
            m.name(),
            if dead.len() == 1 { "" } else { "s" },
            dead.join(", "),
            if dead.len() == 1 { "s" } else { "ve" },
            freqs.len(),
            if dead.len() == 1 { "it" } else { "them" },
        ))
    }
}

/// The `f64` coefficients of `m` at θ and frequency `f` (constants computed on the spot): a
/// convenience for tests, plots and the simulator, not for hot paths.
pub fn coefficients_at(m: &dyn Model, theta: &[f64], f: f64, fs: f64) -> Vec<Complex64> {
    let mut consts = vec![Complex64::new(0.0, 0.0); m.n_consts()];
    m.bin_consts(f, fs, &mut consts);
    let mut out =
        vec![Complex64::new(0.0, 0.0); m.data_channels().len() * m.residual_channels().len()];
    m.coefficients(
        theta,
        &Bin {
            f,
            fs,
            consts: &consts,
        },
        &mut out,
    );
    out
}
