//! The [`Model`] trait (a linear frequency-response model, see the module docs of
//! [`crate::model`]), the prepared [`BlockKernel`], and the default implementations of the
//! trait's batch methods.

use super::bin::{
    Bin, BinBlock, MAX_RESIDUALS, quad_whitened, residual_into, tri_len, with_buffer,
};
use super::covariates::Covariates;
use num_complex::{Complex, Complex64};
use num_dual::Dual64;

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

    /// Per parameter, in the order of θ, the limits physics sets, `[lower, upper]` (`None`:
    /// none) — a delay cannot be negative. A MAP on a prior bound at such a limit says the
    /// data are consistent with the limit, not that the prior box is misplaced, and a fit
    /// states it as a note. The default knows none.
    fn physical_limits(&self) -> Vec<[Option<f64>; 2]> {
        vec![[None, None]; self.param_names().len()]
    }

    /// Data channels `d_c` the model reads (columns of `M`), at most [`MAX_CHANNELS`](crate::model::MAX_CHANNELS).
    fn data_channels(&self) -> &[String];

    /// Residual channels `r_r` (rows of `M`), 1 to [`MAX_RESIDUALS`].
    fn residual_channels(&self) -> &[String];

    /// SI unit of each data channel, in the order of [`Model::data_channels`], for the axes of
    /// the data, spectra and Bode plots: `"m"`, `"m s⁻²"`; an empty string for an unknown
    /// unit. The default knows none.
    fn channel_units(&self) -> Vec<String> {
        vec![String::new(); self.data_channels().len()]
    }

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

    /// [`Model::coefficients_batch`] prepared once for fixed frequencies, constants and
    /// components (relative binning's coarse-bin edges, the same for every θ), like
    /// [`Model::prepare_kernel`]: it may precompute anything that does not depend on θ. `None`
    /// (the default) means [`Model::coefficients_batch`] is called per θ. A prepared batch
    /// must give the values of [`coefficients_batch_generic`] to rounding; its tests say how
    /// close.
    fn prepare_batch(
        &self,
        _freqs: &[f64],
        _fs: f64,
        _consts: &[Complex64],
        _comps: &[usize],
    ) -> Option<std::sync::Arc<dyn BatchKernel>> {
        None
    }

    /// The one-sided CSD matrix `S_d(f)` of the noise of the data channels at `bin`, row-major
    /// `C × C` in the order of [`Model::data_channels`] (zero rows and columns for noiseless
    /// channels such as commanded injections), when the model knows its own noise — a
    /// state-space model with noise inputs. `false` (the default) means it does not, and the
    /// likelihood takes the noise from the Welch estimate of the noise-only stretch or from
    /// the study's noise model.
    fn data_noise_csd(&self, _theta: &[f64], _bin: &Bin, _out: &mut [Complex64]) -> bool {
        false
    }

    /// Whether the model is physically valid at θ (e.g. a stable loop); the message says why
    /// not. The likelihood does not call it per evaluation; `fit` and `select` warn when the
    /// start of a model's MAP search (its fixed values and start values) fails it.
    fn check(&self, _theta: &[f64]) -> Result<(), String> {
        Ok(())
    }

    /// Whether the system the model describes is stable at θ, asked at **every** likelihood
    /// evaluation: where it is not, `ln L = −∞` (the frequency-domain likelihood of an
    /// unstable loop describes no data) and the evaluation is counted. It must be cheap: the
    /// LTP loop's is a Routh–Hurwitz test of its characteristic polynomial
    /// ([`crate::ltp::hurwitz`]), a state-space model's its eigenvalues. `true` (the
    /// default): the model declares no stability condition.
    fn is_stable(&self, _theta: &[f64]) -> bool {
        true
    }

    /// Where a non-finite coefficient at θ and frequency `f` comes from, for a model built
    /// from parts (a user model: the first block or define that is not finite, and why);
    /// `None` (the default) when the model has no parts to name.
    fn explain_non_finite(&self, _theta: &[f64], _f: f64, _fs: f64) -> Option<String> {
        None
    }

    /// The model as it applies to one experiment, with the same parameters, for a model whose
    /// coefficients depend on the experiment's stretch or covariates (a parameter that drifts
    /// between stretches, [`crate::model::drift`]). `Ok(None)` (the default): the same model for
    /// every experiment. The likelihood specialises the model to every experiment it is built
    /// on; an error says why an experiment cannot be analysed (it has no stretch, or lacks a
    /// covariate).
    fn specialise(&self, _cov: &Covariates) -> Result<Option<std::sync::Arc<dyn Model>>, String> {
        Ok(None)
    }

    /// Whether the coefficients depend on parameter `a` at all (`false` lets the Fisher
    /// matrix skip it: a model specialised to one experiment does not read the parameters of
    /// another's glitches). The default: every parameter.
    fn reads_param(&self, _a: usize) -> bool {
        true
    }

    /// How a differential force per unit mass between the test masses that no data channel
    /// records — a glitch ([`crate::model::glitch`]), `Δg = g2 − g1` in m s⁻² — enters the
    /// residual channels: `out[r]` is residual `r`'s response to a unit `Δg`. A force on one
    /// test mass also has a part along the loop's first coordinate, which drag-free control
    /// hides from the read-outs: four orders of magnitude less well measured than `Δg` on
    /// Table I's set-up ([`crate::ltp::h_dg_column`]), so a modelled glitch leaves it out.
    /// `false` (the default): the model does not say, and glitches cannot be modelled on it.
    fn force_response(&self, _theta: &[f64], _bin: &Bin, _out: &mut [Complex64]) -> bool {
        false
    }

    /// As [`Model::force_response`] with dual-number parameters (exact derivatives).
    fn force_response_dual(
        &self,
        _theta: &[Dual64],
        _bin: &Bin,
        _out: &mut [Complex<Dual64>],
    ) -> bool {
        false
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

/// A prepared [`Model::coefficients_batch`] (see [`Model::prepare_batch`]).
pub trait BatchKernel: Send + Sync + std::fmt::Debug {
    /// The prepared components at the prepared frequencies at θ, into
    /// `out[e·comps.len() + i]` (`out.len()` = frequencies × components), as
    /// [`Model::coefficients_batch`] gives them. Allocation-free.
    fn coefficients(&self, theta: &[f64], out: &mut [Complex64]);
}

/// The default [`Model::residual_power`]: coefficients bin by bin. Kept callable so fast
/// kernels can be tested against it. The noise weighting is [`BinBlock::residual_quad`]'s.
pub fn residual_power_generic<M: Model + ?Sized>(m: &M, theta: &[f64], b: &BinBlock) -> f64 {
    let nr = m.residual_channels().len();
    let nc = m.data_channels().len();
    let ncst = m.n_consts();
    with_buffer(nr * nc, |coef| {
        let mut s = 0.0;
        for k in 0..b.n {
            m.coefficients(theta, &b.bin(k, ncst), coef);
            s += b.residual_quad(k, coef, nr);
        }
        s
    })
}

/// `Σ_k r_kᴴ C_k⁻¹ r_k = Σ_k |W_k r_k|²` through the inverse Cholesky factors
/// ([`BinBlock::whiten`]), for any number of residual channels: the general path, which for
/// one or two channels agrees with the packed one to rounding. Allocation-free.
pub fn residual_power_whitened<M: Model + ?Sized>(m: &M, theta: &[f64], b: &BinBlock) -> f64 {
    let nc = m.data_channels().len();
    let nr = m.residual_channels().len();
    let ncst = m.n_consts();
    let nw = tri_len(nr);
    assert_eq!(
        b.whiten.len(),
        b.n * nw,
        "the block has no whitening factors"
    );
    let mut r = [Complex64::new(0.0, 0.0); MAX_RESIDUALS];
    let r = &mut r[..nr];
    with_buffer(nr * nc, |coef| {
        let mut s = 0.0;
        for k in 0..b.n {
            m.coefficients(theta, &b.bin(k, ncst), coef);
            residual_into(coef, &b.data[k * nc..(k + 1) * nc], r);
            s += quad_whitened(&b.whiten[k * nw..(k + 1) * nw], r);
        }
        s
    })
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
    with_buffer(ncoef, |coef| {
        for (e, &f) in freqs.iter().enumerate() {
            let bin = Bin {
                f,
                fs,
                consts: &consts[e * ncst..(e + 1) * ncst],
            };
            m.coefficients(theta, &bin, coef);
            for (o, &c) in out[e * nc..(e + 1) * nc].iter_mut().zip(comps) {
                *o = coef[c];
            }
        }
    })
}
