//! Oracles of the likelihood with more than two residual channels: a dense evaluation (nalgebra
//! LU inverse and determinant per bin), the packed 2×2 path, finite differences, the
//! Student-t formula written out, and the refusals.

use super::*;
use crate::data::dataset::ExperimentData;
use crate::model::{Bin, Model, residual_power_generic, residual_power_whitened};
use crate::prior::{Prior, PriorKind};
use nalgebra::{DMatrix, DVector};
use num_complex::{Complex, Complex64};
use num_dual::Dual64;
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use rand_xoshiro::Xoshiro256PlusPlus;
use std::sync::Arc;

const N: usize = 512;

fn c(re: f64, im: f64) -> Complex64 {
    Complex64::new(re, im)
}

/// `r = y − G(f; a, b) u` with `R` outputs `y` and `U` noiseless inputs `u`:
/// `G = G0 + a G1 (1 + f) + b G2 (1 − f/2)`, random complex gains, so `ln L` is exactly
/// quadratic in `(a, b)`. Its own data-channel noise (if `own_noise`) is
/// `S(f) = 2 [(A + f B)(A + f B)ᴴ/R + I/2]` on the outputs, zero on the inputs; with `bad_above`
/// the last output's noise is the first's above that frequency (a singular matrix).
#[derive(Debug)]
struct Mix {
    nr: usize,
    nu: usize,
    g: [Vec<Complex64>; 3],
    a: Vec<Complex64>,
    b: Vec<Complex64>,
    own_noise: bool,
    bad_above: Option<f64>,
    names: Vec<String>,
    data: Vec<String>,
    res: Vec<String>,
}

impl Mix {
    fn new(nr: usize, nu: usize, seed: u64) -> Self {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        let mut z = |n: usize, s: f64| -> Vec<Complex64> {
            (0..n)
                .map(|_| {
                    let (x, y): (f64, f64) = (
                        StandardNormal.sample(&mut rng),
                        StandardNormal.sample(&mut rng),
                    );
                    c(s * x, s * y)
                })
                .collect()
        };
        let g = [z(nr * nu, 1.0), z(nr * nu, 0.5), z(nr * nu, 0.5)];
        let (a, b) = (z(nr * nr, 1.0), z(nr * nr, 0.7));
        let data = (0..nr)
            .map(|i| format!("y{}", i + 1))
            .chain((0..nu).map(|j| format!("u{}", j + 1)))
            .collect();
        Self {
            nr,
            nu,
            g,
            a,
            b,
            own_noise: true,
            bad_above: None,
            names: vec!["a".into(), "b".into()],
            data,
            res: (0..nr).map(|i| format!("r{}", i + 1)).collect(),
        }
    }

    /// `−G_ij(f; a, b)`.
    fn neg_gain<T>(&self, i: usize, j: usize, f: f64, a: T, b: T) -> Complex<T>
    where
        T: Copy
            + std::ops::Mul<f64, Output = T>
            + std::ops::Add<f64, Output = T>
            + std::ops::Add<Output = T>,
    {
        let k = i * self.nu + j;
        let (g0, g1, g2) = (self.g[0][k], self.g[1][k], self.g[2][k]);
        let (p, q) = (-(1.0 + f), -(1.0 - 0.5 * f));
        Complex::new(
            a * (g1.re * p) + b * (g2.re * q) + -g0.re,
            a * (g1.im * p) + b * (g2.im * q) + -g0.im,
        )
    }

    /// The outputs' CSD at `f`, `R × R` row-major.
    fn noise(&self, f: f64) -> Vec<Complex64> {
        let r = self.nr;
        let m: Vec<Complex64> = (0..r * r).map(|i| self.a[i] + self.b[i] * f).collect();
        let mut s = vec![c(0.0, 0.0); r * r];
        for i in 0..r {
            for j in 0..r {
                for k in 0..r {
                    s[i * r + j] += m[i * r + k] * m[j * r + k].conj() * (2.0 / r as f64);
                }
            }
            s[i * r + i] += 1.0;
        }
        if self.bad_above.is_some_and(|x| f > x) {
            let l = r - 1;
            for j in 0..r {
                s[l * r + j] = s[j];
                s[j * r + l] = s[j * r];
            }
            s[l * r + l] = s[0];
        }
        s
    }
}

impl Model for Mix {
    fn name(&self) -> &str {
        "mix"
    }
    fn param_names(&self) -> &[String] {
        &self.names
    }
    fn data_channels(&self) -> &[String] {
        &self.data
    }
    fn residual_channels(&self) -> &[String] {
        &self.res
    }
    fn coefficients(&self, th: &[f64], bin: &Bin, out: &mut [Complex64]) {
        let nc = self.nr + self.nu;
        for i in 0..self.nr {
            for k in 0..self.nr {
                out[i * nc + k] = c(f64::from(u8::from(i == k)), 0.0);
            }
            for j in 0..self.nu {
                out[i * nc + self.nr + j] = self.neg_gain(i, j, bin.f, th[0], th[1]);
            }
        }
    }
    fn coefficients_dual(&self, th: &[Dual64], bin: &Bin, out: &mut [Complex<Dual64>]) {
        let nc = self.nr + self.nu;
        let zero = Dual64::from(0.0);
        for i in 0..self.nr {
            for k in 0..self.nr {
                out[i * nc + k] = Complex::new(Dual64::from(f64::from(u8::from(i == k))), zero);
            }
            for j in 0..self.nu {
                out[i * nc + self.nr + j] = self.neg_gain(i, j, bin.f, th[0], th[1]);
            }
        }
    }
    fn data_noise_csd(&self, _th: &[f64], bin: &Bin, out: &mut [Complex64]) -> bool {
        if !self.own_noise {
            return false;
        }
        let (r, nc) = (self.nr, self.nr + self.nu);
        out.fill(c(0.0, 0.0));
        let s = self.noise(bin.f);
        for i in 0..r {
            for j in 0..r {
                out[i * nc + j] = s[i * r + j];
            }
        }
        true
    }
}

/// Random data: white outputs mixed across channels (so the Welch CSD matrix is not
/// diagonal), white inputs, and noise-only stretches of the outputs.
fn data(m: &Mix, seed: u64) -> ExperimentData {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let mut series =
        |n: usize| -> Vec<f64> { (0..n).map(|_| StandardNormal.sample(&mut rng)).collect() };
    let mixed = |raw: &[Vec<f64>], i: usize| -> Vec<f64> {
        (0..raw[0].len())
            .map(|t| raw[i][t] + 0.6 * raw[(i + 1) % raw.len()][t])
            .collect()
    };
    let raw: Vec<Vec<f64>> = (0..m.nr).map(|_| series(N)).collect();
    let raw_noise: Vec<Vec<f64>> = (0..m.nr).map(|_| series(8 * N)).collect();
    let mut extra = std::collections::BTreeMap::new();
    let mut noise_extra = std::collections::BTreeMap::new();
    for i in 0..m.nr {
        extra.insert(m.data[i].clone(), mixed(&raw, i));
        noise_extra.insert(m.data[i].clone(), mixed(&raw_noise, i));
    }
    for j in 0..m.nu {
        extra.insert(m.data[m.nr + j].clone(), series(N));
    }
    ExperimentData {
        name: "mixed".into(),
        fs: 1.0,
        o: [Vec::new(), Vec::new()],
        i: [Vec::new(), Vec::new()],
        noise: [Vec::new(), Vec::new()],
        extra,
        noise_extra,
        gaps: Vec::new(),
        noise_gaps: Vec::new(),
        known_in_gaps: Vec::new(),
    }
}

fn prior() -> Prior {
    Prior::new(
        vec!["a".into(), "b".into()],
        vec![PriorKind::Uniform { lo: -5.0, hi: 5.0 }; 2],
    )
    .unwrap()
}

const TH_REF: [f64; 2] = [0.3, -0.2];

fn opts(noise: NoiseSource) -> SpectraOptions {
    SpectraOptions {
        band: [0.01, 0.45],
        noise,
        ..Default::default()
    }
}

fn likelihood(m: Mix, e: &ExperimentData, noise: NoiseSource) -> Likelihood {
    let sp = ExperimentSpectra::new(e, &opts(noise), &m, &TH_REF, None).unwrap();
    Likelihood::new(Arc::new(m), vec![sp], prior()).unwrap()
}

/// The dense evaluation: per bin `C = (fs/2) N S_r`, `S_r = M S_d Mᴴ` with `S_d` the model's own
/// noise (or, with `from_spectra`, the `S_r` the spectra hold), inverted and its determinant
/// taken by LU. Returns `(ln L, ρ_opt²)`.
fn dense(lik: &Likelihood, th: &[f64], from_spectra: bool) -> (f64, f64) {
    let m = lik.model();
    let (nr, nc) = (m.residual_channels().len(), m.data_channels().len());
    let mut ln_l = 0.0;
    let mut rho2 = 0.0;
    for e in lik.spectra() {
        let scale = e.fs / 2.0 * e.n as f64;
        for k in 0..e.len() {
            let bin = e.bin(k, m.n_consts());
            let mut coef = vec![c(0.0, 0.0); nr * nc];
            let sr = if from_spectra {
                DMatrix::from_row_slice(nr, nr, e.csd_at(k))
            } else {
                m.coefficients(&TH_REF, &bin, &mut coef);
                let mref = DMatrix::from_row_slice(nr, nc, &coef);
                let mut sd = vec![c(0.0, 0.0); nc * nc];
                assert!(m.data_noise_csd(&TH_REF, &bin, &mut sd));
                let sd = DMatrix::from_row_slice(nc, nc, &sd);
                &mref * sd * mref.adjoint()
            };
            let cm = sr * c(scale, 0.0);
            let inv = cm.clone().try_inverse().unwrap();
            let det = cm.determinant();
            m.coefficients(th, &bin, &mut coef);
            let mm = DMatrix::from_row_slice(nr, nc, &coef);
            let d = DVector::from_column_slice(e.data_at(k));
            let r = &mm * &d;
            let din = DVector::from_iterator(
                nc,
                (0..nc).map(|i| if e.is_input[i] { d[i] } else { c(0.0, 0.0) }),
            );
            let s = &mm * din;
            ln_l -= (r.adjoint() * &inv * &r)[(0, 0)].re
                + nr as f64 * std::f64::consts::PI.ln()
                + det.re.ln();
            rho2 += 2.0 * (s.adjoint() * &inv * &s)[(0, 0)].re;
        }
    }
    (ln_l, rho2)
}

#[test]
fn many_channel_whittle_equals_the_dense_evaluation() {
    for (nr, nu, seed) in [(3, 2, 1), (5, 3, 2)] {
        let m = Mix::new(nr, nu, seed);
        let e = data(&m, seed + 10);
        let lik = likelihood(m, &e, NoiseSource::Model);
        assert_eq!(lik.spectra()[0].nr, nr);
        assert!(lik.spectra()[0].cinv.is_empty());
        let mut worst: f64 = 0.0;
        for th in [[0.0, 0.0], TH_REF, [1.7, -2.4]] {
            let (want, rho2) = dense(&lik, &th, false);
            let got = lik.ln_likelihood_full(&th);
            let rel = ((got - want) / want).abs();
            worst = worst.max(rel);
            assert!(rel < 1e-12, "R = {nr} at {th:?}: {got} vs {want}");
            // the θ-dependent part alone, so the normalisation cannot hide it
            let part = -lik.residual_power(&th);
            let rel_part = ((got - lik.ln_norm()) - part).abs() / part.abs();
            assert!(rel_part < 1e-12);
            let snr = lik.snr(&th);
            assert!(
                ((snr * snr - rho2) / rho2).abs() < 1e-12,
                "{snr} vs {}",
                rho2.sqrt()
            );
        }
        eprintln!("R = {nr}: whittle ln L vs dense LU: worst relative difference {worst:.1e}");
    }
}

#[test]
fn many_channel_welch_noise_is_the_csd_matrix_and_the_likelihood_is_dense() {
    let m = Mix::new(3, 2, 5);
    let e = data(&m, 15);
    let lik = likelihood(m, &e, NoiseSource::Welch);
    let sp = &lik.spectra()[0];
    assert!(sp.noise_dof.is_some());
    // the outputs are mixed channel i + 0.6 channel i+1: the Welch CSD has off-diagonal terms
    let s = sp.csd_at(sp.len() / 2);
    assert!(s[1].norm() > 0.2 * s[0].re, "{s:?}");
    assert!((s[1] - s[3].conj()).norm() < 1e-12 * s[0].re);
    let th = [0.9, 0.4];
    let (want, _) = dense(&lik, &th, true);
    let got = lik.ln_likelihood_full(&th);
    eprintln!(
        "R = 3, Welch noise: ln L vs dense LU: relative difference {:.1e}",
        ((got - want) / want).abs()
    );
    assert!(((got - want) / want).abs() < 1e-12, "{got} vs {want}");
}

#[test]
fn general_path_equals_the_packed_one_for_two_and_one_channels() {
    let mut worst: f64 = 0.0;
    let mut worst_bin: f64 = 0.0;
    for nr in [1, 2] {
        let m = Mix::new(nr, 2, 3 + nr as u64);
        let e = data(&m, 20);
        let lik = likelihood(m, &e, NoiseSource::Model);
        let sp = &lik.spectra()[0];
        assert_eq!(sp.cinv.len(), sp.len());
        for th in [[0.0, 0.0], [1.1, -0.7]] {
            let packed = residual_power_generic(lik.model().as_ref(), &th, &sp.block());
            let general = residual_power_whitened(lik.model().as_ref(), &th, &sp.block());
            let rel = ((packed - general) / packed).abs();
            // bin by bin too, so a sum cannot hide a difference
            lik.visit_residuals(sp, &th, |k, r, _| {
                let (p, g) = (
                    sp.quad(k, r),
                    crate::hermitian::quad_whitened(sp.whitener(k), r),
                );
                worst_bin = worst_bin.max(((p - g) / p).abs());
            });
            worst = worst.max(rel);
            assert!(rel < 1e-12, "R = {nr}: {packed} vs {general}");
        }
        let norm: f64 = sp
            .ln_det
            .iter()
            .map(|ld| -(nr as f64) * std::f64::consts::PI.ln() - ld)
            .sum();
        assert!(((norm - lik.ln_norm()) / norm).abs() < 1e-12);
    }
    // the closed loop (its fast kernel reads the packed inverse) on the small study
    let study = super::tests::small_study(3, 1e-7, "circular");
    let o = SpectraOptions {
        band: [1e-3, 0.3],
        ..Default::default()
    };
    let lik = super::tests::likelihood_of(&study, &o);
    let th = study.truth.to_array();
    let general: f64 = lik
        .spectra()
        .iter()
        .map(|e| residual_power_whitened(lik.model().as_ref(), &th, &e.block()))
        .sum();
    let packed = lik.residual_power(&th);
    let rel = ((packed - general) / packed).abs();
    eprintln!(
        "R ≤ 2: general (Cholesky) vs packed path: worst relative difference {worst:.1e} (toy, sum), {worst_bin:.1e} (toy, per bin), {rel:.1e} (closed loop)"
    );
    assert!(worst_bin < 1e-12);
    assert!(rel < 1e-12, "{packed} vs {general}");
}

#[test]
fn many_channel_fisher_is_the_hessian_and_the_map_is_the_maximum() {
    let m = Mix::new(3, 2, 7);
    let e = data(&m, 17);
    let lik = likelihood(m, &e, NoiseSource::Model);
    let th = [0.4, -0.3];
    let free = [0, 1];
    let (g, f) = gradient_and_fisher(&lik, &th, &free);
    // ln L is exactly quadratic in θ: −Hessian = F and central differences are exact to
    // rounding
    let (gn, hn) =
        gradient_hessian_numeric(&|t| lik.ln_likelihood_full(t), &th, &free, &[1e-2, 1e-2]);
    let scale = f.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let mut worst: f64 = 0.0;
    for i in 0..2 {
        assert!((g[i] - gn[i]).abs() < 1e-6 * scale, "{g:?} vs {gn:?}");
        for j in 0..2 {
            worst = worst.max((f[(i, j)] + hn[(i, j)]).abs() / scale);
        }
    }
    let fnum = fisher_numeric(&lik, &th, &free, Some(&[1e-3, 1e-3]));
    let worst_num = (&f - &fnum).abs().max() / scale;
    eprintln!(
        "R = 3: Fisher vs −Hessian of exact ln L {worst:.1e}, vs fisher_numeric {worst_num:.1e} (relative to max |F| = {scale:.3e})"
    );
    assert!(worst < 1e-6 && worst_num < 1e-9, "{f} {hn} {fnum}");
    let map = fisher_scoring(&lik, &[0.0, 0.0], &free, 1e-10, 50).unwrap();
    assert!(map.converged);
    let (g, f) = gradient_and_fisher(&lik, &map.theta, &free);
    for i in 0..2 {
        assert!(
            g[i].abs() < 1e-6 * f[(i, i)].sqrt(),
            "gradient {g:?} at the MAP"
        );
    }
}

#[test]
fn many_channel_relative_binning_matches_exact() {
    for (nr, nu, seed) in [(3, 2, 9), (5, 4, 10)] {
        let m = Mix::new(nr, nu, seed);
        let e = data(&m, seed + 30);
        let lik = likelihood(m, &e, NoiseSource::Model);
        let fid = fisher_scoring(&lik, &[0.0, 0.0], &[0, 1], 1e-10, 50)
            .unwrap()
            .theta;
        let rb = RelBinLikelihood::new(&lik, &fid, &Default::default()).unwrap();
        let v = rb.validation();
        assert!(v.worst_abs_delta_ln_l <= 0.05, "{v:?}");
        // independent points: ±3σ of the Fisher covariance in a grid, plus the batched
        // evaluation (nr·nu = 20 components takes the wide-buffer chunking) against the unbatched
        let cov = crate::linalg::Spd::new(&fisher_exact(&lik, &fid, &[0, 1]))
            .unwrap()
            .inverse();
        let (sa, sb) = (cov[(0, 0)].sqrt(), cov[(1, 1)].sqrt());
        let mut worst: f64 = 0.0;
        let mut worst_batch: f64 = 0.0;
        for i in -3..=3 {
            for j in -3..=3 {
                let t = [fid[0] + i as f64 * sa, fid[1] + j as f64 * sb];
                let got = rb.ln_likelihood_full(&t);
                worst = worst.max((got - lik.ln_likelihood_full(&t)).abs());
                let un = rb.ln_likelihood_unbatched(&t);
                worst_batch = worst_batch.max(((got - un) / un).abs());
            }
        }
        eprintln!(
            "R = {nr}, {} components: relbin {} coarse bins, reported worst |Δ ln L| {:.1e}, grid worst {worst:.1e}; batched vs unbatched {worst_batch:.1e}",
            nr * nu,
            rb.n_coarse(),
            v.worst_abs_delta_ln_l
        );
        assert!(worst <= 0.05, "{worst}");
        assert!(worst_batch < 1e-12, "{worst_batch}");
    }
}

#[test]
fn many_channel_student_t_is_the_formula() {
    use statrs::function::gamma::ln_gamma;
    let m = Mix::new(3, 2, 11);
    let e = data(&m, 21);
    let lik = likelihood(m, &e, NoiseSource::Welch)
        .with_statistic(
            Statistic::StudentT,
            &Default::default(),
            std::slice::from_ref(&e),
        )
        .unwrap();
    let nu = lik.student_t_dof()[0];
    let r = 3.0;
    let th = [0.2, 0.5];
    let sp = &lik.spectra()[0];
    let scale = sp.fs / 2.0 * sp.n as f64;
    let mut want = 0.0;
    lik.visit_residuals(sp, &th, |k, res, _| {
        let cm = DMatrix::from_row_slice(3, 3, sp.csd_at(k)) * c(scale, 0.0);
        let rv = DVector::from_column_slice(res);
        let q = (rv.adjoint() * cm.clone().try_inverse().unwrap() * &rv)[(0, 0)].re;
        want += ln_gamma((nu + 2.0 * r) / 2.0)
            - ln_gamma(nu / 2.0)
            - r * (nu / 2.0).ln()
            - r * std::f64::consts::PI.ln()
            - cm.determinant().re.ln()
            - (nu + 2.0 * r) / 2.0 * (1.0 + 2.0 * q / nu).ln();
    });
    let got = lik.ln_likelihood_full(&th);
    eprintln!(
        "R = 3 Student-t (ν = {nu:.2}) vs the formula: relative difference {:.1e}",
        ((got - want) / want).abs()
    );
    assert!(((got - want) / want).abs() < 1e-12, "{got} vs {want}");
}

/// The Wishart statistic for R = 3 against its formula with a dense inverse and the gamma
/// functions (`ln Γ(M + 1) − ln Γ(M − 2) − 3 ln M`).
#[test]
fn many_channel_wishart_is_the_formula() {
    use statrs::function::gamma::ln_gamma;
    let m = Mix::new(3, 2, 11);
    let e = data(&m, 21);
    let lik = likelihood(m, &e, NoiseSource::Welch)
        .with_statistic(
            Statistic::Wishart,
            &Default::default(),
            std::slice::from_ref(&e),
        )
        .unwrap();
    let mm = lik.wishart_averages()[0];
    assert_eq!(2.0 * mm, lik.spectra()[0].noise_dof.unwrap());
    let r = 3.0;
    let th = [0.2, 0.5];
    let sp = &lik.spectra()[0];
    let scale = sp.fs / 2.0 * sp.n as f64;
    let mut want = 0.0;
    lik.visit_residuals(sp, &th, |k, res, _| {
        let cm = DMatrix::from_row_slice(3, 3, sp.csd_at(k)) * c(scale, 0.0);
        let rv = DVector::from_column_slice(res);
        let q = (rv.adjoint() * cm.clone().try_inverse().unwrap() * &rv)[(0, 0)].re;
        want += ln_gamma(mm + 1.0)
            - ln_gamma(mm + 1.0 - r)
            - r * mm.ln()
            - r * std::f64::consts::PI.ln()
            - cm.determinant().re.ln()
            - (mm + 1.0) * (1.0 + q / mm).ln();
    });
    let got = lik.ln_likelihood_full(&th);
    eprintln!(
        "R = 3 Wishart (M = {mm:.2}) vs the formula: relative difference {:.1e}",
        ((got - want) / want).abs()
    );
    assert!(((got - want) / want).abs() < 1e-10, "{got} vs {want}");
}

#[test]
fn many_channel_refusals_are_errors_with_reasons() {
    // a singular noise matrix above 0.2 Hz: an error naming experiment, frequency and channel
    let mut m = Mix::new(3, 2, 12);
    m.bad_above = Some(0.2);
    let e = data(&m, 22);
    let err = ExperimentSpectra::new(&e, &opts(NoiseSource::Model), &m, &TH_REF, None)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("experiment `mixed`")
            && err.contains("3×3 residual noise CSD is not positive definite at 2.0")
            && err.contains("`r3`"),
        "{err}"
    );
    // the log-periodogram is refused with its reason; the residual PSD of channel 1 is not
    let m = Mix::new(3, 2, 13);
    let e = data(&m, 23);
    let lik = likelihood(m, &e, NoiseSource::Welch);
    let err = lik
        .clone()
        .with_statistic(
            Statistic::LogPeriodogram,
            &Default::default(),
            std::slice::from_ref(&e),
        )
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("3 residual channels") && err.contains("one or two"),
        "{err}"
    );
    let psd = residual_psd::residual_psds(&lik, std::slice::from_ref(&e), &[0.0, 0.0]).unwrap();
    assert_eq!(psd[0].channel, "r1");
    assert!(psd[0].residual.iter().all(|v| v.is_finite() && *v > 0.0));
    // noise = "model" for a model that does not know its noise falls back to the study's,
    // which this one has not
    let mut m = Mix::new(3, 2, 14);
    m.own_noise = false;
    let err = ExperimentSpectra::new(&e, &opts(NoiseSource::Model), &m, &TH_REF, None)
        .unwrap_err()
        .to_string();
    assert!(err.contains("does not know the noise"), "{err}");
    // seventeen residual channels are too many
    let m = Mix::new(17, 1, 15);
    let err = crate::model::validate_shape(&m).unwrap_err();
    assert!(err.contains("1 to 16"), "{err}");
}
