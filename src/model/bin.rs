//! What a model sees of the data: one frequency [`Bin`], a contiguous [`BinBlock`] of them, the
//! residual `r = M d` and its quadratic form, and the size limits of a model.

pub use crate::hermitian::tri_len;
use num_complex::Complex64;

/// Most data channels a model may read.
pub const MAX_CHANNELS: usize = 32;
/// Most residual channels a model may produce (the likelihood's noise matrix is `R×R`).
pub const MAX_RESIDUALS: usize = 16;
/// Most θ-independent complex constants per bin.
pub const MAX_CONSTS: usize = 64;

/// One frequency bin as a model sees it.
#[derive(Debug, Clone, Copy)]
pub struct Bin<'a> {
    /// Frequency (Hz).
    pub f: f64,
    /// Sample rate of the experiment (Hz), for models with a discrete-time response.
    pub fs: f64,
    /// The model's own θ-independent constants at `f` (from [`Model::bin_consts`](crate::model::Model::bin_consts)).
    pub consts: &'a [Complex64],
}

/// A contiguous run of DFT bins of one experiment with everything the likelihood needs:
/// `f_k = f0 + k·df`, the data DFTs, the inverse noise matrices and the model's constants.
///
/// Models with a fast kernel ([`Model::residual_power`](crate::model::Model::residual_power)) read it directly.
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
    /// Data DFTs, `n × C`, bin-major, in the order of [`Model::data_channels`](crate::model::Model::data_channels).
    pub data: &'a [Complex64],
    /// Inverse residual-noise matrix per bin, packed `(a, b, c)` = `[[a, b], [b*, c]]`, for one
    /// or two residual channels (for one only `a` is used, `b = c = 0`); empty for more.
    pub cinv: &'a [(f64, Complex64, f64)],
    /// For any number `R` of residual channels: the inverse Cholesky factor `W` of `C_k`
    /// (`C_k⁻¹ = WᴴW`, lower triangular, packed row by row, [`tri_len`]`(R)` entries per bin;
    /// [`crate::hermitian::whitener`]). Empty when the block was built without it.
    pub whiten: &'a [Complex64],
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

    /// `r_kᴴ C_k⁻¹ r_k` of the residual `r_k = M d_k` of bin `k`, for the model's coefficients
    /// `coef` (`nr` rows over the block's data channels). One or two residual channels use the
    /// packed inverse ([`BinBlock::cinv`], the arithmetic of every result so far), more the
    /// inverse Cholesky factor ([`BinBlock::whiten`]): the one place that choice is made.
    #[inline(always)]
    pub fn residual_quad(&self, k: usize, coef: &[Complex64], nr: usize) -> f64 {
        let nc = self.data.len() / self.n;
        let d = &self.data[k * nc..(k + 1) * nc];
        if nr <= 2 {
            return quad(&self.cinv[k], residual(coef, nr, d));
        }
        let nw = crate::hermitian::tri_len(nr);
        let mut r = [Complex64::new(0.0, 0.0); MAX_RESIDUALS];
        residual_into(coef, d, &mut r[..nr]);
        quad_whitened(&self.whiten[k * nw..(k + 1) * nw], &r[..nr])
    }
}

/// `rᴴ C⁻¹ r` for a packed Hermitian inverse.
#[inline(always)]
pub fn quad(cinv: &(f64, Complex64, f64), r: [Complex64; 2]) -> f64 {
    crate::hermitian::quad(cinv, r)
}

/// `rᴴ C⁻¹ r` for the inverse Cholesky factor `w` of `C` (`R = r.len()`, see
/// [`BinBlock::whiten`]).
#[inline(always)]
pub fn quad_whitened(w: &[Complex64], r: &[Complex64]) -> f64 {
    crate::hermitian::quad_whitened(w, r)
}

/// `r = M d` into `out` (its length is the number of rows), for any number of rows.
#[inline(always)]
pub fn residual_into(coef: &[Complex64], d: &[Complex64], out: &mut [Complex64]) {
    let nc = d.len();
    for (ri, slot) in out.iter_mut().enumerate() {
        let row = &coef[ri * nc..(ri + 1) * nc];
        let mut acc = Complex64::new(0.0, 0.0);
        for (m, x) in row.iter().zip(d) {
            acc += m * x;
        }
        *slot = acc;
    }
}

/// Calls `f` with a zeroed stack buffer of `n ≤ MAX_CHANNELS·MAX_RESIDUALS` complex values,
/// sized to the smallest of 16, 64 or the maximum that holds `n`: zeroing the largest (8 KiB)
/// for a small model would cost more than its coefficients.
#[inline(always)]
pub fn with_buffer<T>(n: usize, f: impl FnOnce(&mut [Complex64]) -> T) -> T {
    const Z: Complex64 = Complex64::new(0.0, 0.0);
    if n <= 16 {
        f(&mut [Z; 16][..n])
    } else if n <= 64 {
        f(&mut [Z; 64][..n])
    } else {
        f(&mut [Z; MAX_CHANNELS * MAX_RESIDUALS][..n])
    }
}

/// `r = M d` for `nr ≤ 2` rows (the second component is zero for a one-residual model).
#[inline(always)]
pub fn residual(coef: &[Complex64], nr: usize, d: &[Complex64]) -> [Complex64; 2] {
    let mut r = [Complex64::new(0.0, 0.0); 2];
    residual_into(coef, d, &mut r[..nr]);
    r
}
