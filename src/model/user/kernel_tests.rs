//! The compiled kernels against the interpreter, for every tier of value and every block kind,
//! on chunk boundaries and off them: the exact kernel equal to 1e−12 on every bin (bit for bit
//! when no delay depends on θ), the batch of coefficients at uneven edges bit for bit on every
//! edge and component.

use super::*;
use crate::ltp::LtpParams;
use crate::model::{
    BinBlock, Model, TiedModel, coefficients_batch_generic, residual_power_generic,
};
use num_complex::Complex64;
use std::sync::Arc;

/// splitmix64 → uniform(−1, 1)
fn rng(seed: u64) -> impl FnMut() -> f64 {
    let mut state = seed;
    move || {
        state = state.wrapping_add(0x9e3779b97f4a7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58476d1ce4e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d049bb133111eb);
        z ^= z >> 31;
        2.0 * (z >> 11) as f64 / (1u64 << 53) as f64 - 1.0
    }
}

/// Random data and inverse noise for `n` bins of a model, and its constants.
struct Bins {
    f0: f64,
    df: f64,
    data: Vec<Complex64>,
    cinv: Vec<(f64, Complex64, f64)>,
    consts: Vec<Complex64>,
    nc: usize,
    ncst: usize,
}

impl Bins {
    fn new(m: &dyn Model, n: usize, seed: u64) -> Bins {
        let mut r = rng(seed);
        let (f0, df) = (1e-4, 3.7e-4);
        let nc = m.data_channels().len();
        let ncst = m.n_consts();
        let mut consts = vec![Complex64::new(0.0, 0.0); n * ncst];
        for k in 0..n {
            m.bin_consts(
                f0 + k as f64 * df,
                10.0,
                &mut consts[k * ncst..(k + 1) * ncst],
            );
        }
        let data = (0..n * nc).map(|_| Complex64::new(r(), r())).collect();
        let cinv = (0..n)
            .map(|_| (1.5 + r(), Complex64::new(0.3 * r(), 0.3 * r()), 1.5 + r()))
            .collect();
        Bins {
            f0,
            df,
            data,
            cinv,
            consts,
            nc,
            ncst,
        }
    }

    /// Bins `k..k + len` as a block.
    fn block(&self, k: usize, len: usize) -> BinBlock<'_> {
        BinBlock {
            f0: self.f0 + k as f64 * self.df,
            df: self.df,
            fs: 10.0,
            n: len,
            data: &self.data[k * self.nc..(k + len) * self.nc],
            cinv: &self.cinv[k..k + len],
            consts: &self.consts[k * self.ncst..(k + len) * self.ncst],
            whiten: &[],
        }
    }
}

/// The kernel equals the interpreter over the whole block, and on every bin of it: with data
/// on bin `k` only, both give that bin's term (`rel`: relative tolerance, 0 for bit for bit).
fn assert_equal(m: &UserModel, n: usize, thetas: &[Vec<f64>], rel: f64) {
    let mut bins = Bins::new(m, n, 0x5eed + n as u64);
    let close = |a: f64, b: f64| {
        if rel == 0.0 {
            a.to_bits() == b.to_bits()
        } else {
            (a - b).abs() <= rel * b.abs()
        }
    };
    let whole = bins.block(0, n);
    let kernel = m.prepare_kernel(&whole).expect("a user model has a kernel");
    for th in thetas {
        let want = residual_power_generic(m, th, &whole);
        let got = kernel.residual_power(th);
        assert!(want.is_finite() && want > 0.0, "{want}");
        assert!(close(got, want), "θ = {th:?}: {got} against {want}");
    }
    let data = bins.data.clone();
    let nc = bins.nc;
    for k in 0..n {
        for (i, d) in bins.data.iter_mut().enumerate() {
            *d = if i / nc == k {
                data[i]
            } else {
                Complex64::new(0.0, 0.0)
            };
        }
        let one = bins.block(0, n);
        let kernel = m.prepare_kernel(&one).unwrap();
        for th in thetas {
            let want = residual_power_generic(m, th, &one);
            let got = kernel.residual_power(th);
            assert!(want > 0.0, "bin {k}: {want}");
            assert!(
                close(got, want),
                "bin {k}, θ = {th:?}: {got} against {want}"
            );
        }
    }
}

/// The closed loop of `examples/user-model-closed-loop.toml`, its text changed by `edit`.
fn closed_loop(edit: impl Fn(String) -> String) -> UserModel {
    let text = edit(include_str!("../../../examples/user-model-closed-loop.toml").to_string());
    let v: toml::Table = toml::from_str(&text).unwrap();
    let mut t = v["model"].as_array().unwrap()[0]
        .as_table()
        .unwrap()
        .clone();
    t.remove("kind");
    // the edits drop parameters; units do not enter the kernels
    t.remove("unit");
    let def: UserModelDef = toml::Value::Table(t).try_into().unwrap();
    UserModel::new(&def).unwrap()
}

/// Two θ of the closed loop: the truth and one with other delays and cross-talk.
fn closed_loop_thetas() -> Vec<Vec<f64>> {
    let th = LtpParams::default().to_array().to_vec();
    let mut other = th.clone();
    other[2] = 0.31;
    other[6] = -2e-4;
    vec![th, other]
}

/// Every tier of value, θ-dependent blocks of every kind, a negative power, a zero
/// coefficient and a constant one.
fn tiers() -> UserModel {
    let def: UserModelDef = toml::from_str(
        r#"
name = "tiers"
parameters = ["x", "y"]
data = ["a", "b", "c"]
residual = ["r1", "r2"]
[constants]
k = 2.5
[blocks]
p = { kind = "pole", f = "0.01*x" }
z = { kind = "zero", f = "y" }
cp = { kind = "complex_pole", f = "x*0.02", q = "y + 3" }
d = { kind = "delay", tau = "x" }
g0 = { kind = "gain", value = "x*y" }
ra = { kind = "rational", num = ["x", 1.0], den = [1.0, "y", 2.0] }
cst = { kind = "rational", num = [1.0], den = [1.0, 0.3] }
sp = { kind = "s_power", n = -2 }
[define]
c0 = "k*(1 + k)"
q = "s^2 + cst/c0"
g = "(x - y)^(-2) * c0"
h = "-g/x"
w = "q*g + p*z*cp - d*h + ra^3 - g0*sp"
[coefficients.r1]
a = "1"
b = "w/(q + h)"
[coefficients.r2]
b = "-cst*q"
c = "w*d - x"
"#,
    )
    .unwrap();
    UserModel::new(&def).unwrap()
}

#[test]
fn the_closed_loop_kernel_equals_the_interpreter_bit_for_bit() {
    let m = closed_loop(|t| t);
    let [th, other] = closed_loop_thetas().try_into().unwrap();
    // chunk boundaries: one bin, a whole chunk, a chunk and a tail
    for n in [1, 64, 200] {
        assert_equal(&m, n, &[th.clone(), other.clone()], 1e-12);
    }
}

#[test]
fn every_tier_and_block_kind_is_computed_as_the_interpreter_does() {
    // fixed (c0), frequency-only (q, cst), θ-only (g, h), mixed (everything reading x and s)
    let m = tiers();
    assert_equal(&m, 130, &[vec![1.3, 0.4], vec![0.7, -0.2]], 1e-12);
    // without a θ-dependent delay, every value is the interpreter's own: bit for bit
    let m = closed_loop(|t| {
        t.replace(r#"tau = "dt1""#, "tau = 0.2")
            .replace(r#"tau = "dt2""#, "tau = 0.3")
            .replace(
                r#"parameters = ["w1sq", "w2sq", "dt1", "dt2", "a_df", "a_sus", "d21"]"#,
                r#"parameters = ["w1sq", "w2sq", "a_df", "a_sus", "d21"]"#,
            )
    });
    assert_equal(&m, 130, &[vec![-1.3e-6, -1.9e-6, 0.82, 1.08, 4e-4]], 0.0);
}

/// `m`'s prepared batch of the components `comps` at `n` unevenly spaced edges equals the
/// interpreter's coefficients bit for bit on every edge and component, θ after θ from one
/// preparation. Returns the number of values compared.
fn assert_batch_equal(m: &dyn Model, n: usize, comps: &[usize], thetas: &[Vec<f64>]) -> usize {
    // edges as relative binning spaces them: denser at low frequencies
    let freqs: Vec<f64> = (0..n).map(|e| 1e-4 * 1.07f64.powi(e as i32)).collect();
    let ncst = m.n_consts();
    let mut consts = vec![Complex64::new(0.0, 0.0); n * ncst];
    for (e, &f) in freqs.iter().enumerate() {
        m.bin_consts(f, 10.0, &mut consts[e * ncst..(e + 1) * ncst]);
    }
    let batch = m
        .prepare_batch(&freqs, 10.0, &consts, comps)
        .expect("a user model prepares its batch");
    let mut compared = 0;
    for th in thetas {
        let mut want = vec![Complex64::new(f64::NAN, 0.0); n * comps.len()];
        coefficients_batch_generic(m, th, &freqs, 10.0, &consts, comps, &mut want);
        let mut got = vec![Complex64::new(f64::NAN, 0.0); n * comps.len()];
        batch.coefficients(th, &mut got);
        for (i, (g, w)) in got.iter().zip(&want).enumerate() {
            let (e, c) = (i / comps.len(), comps[i % comps.len()]);
            assert!(
                w.re.is_finite() && w.im.is_finite(),
                "edge {e}, comp {c}: {w}"
            );
            assert!(
                g.re.to_bits() == w.re.to_bits() && g.im.to_bits() == w.im.to_bits(),
                "edge {e} ({} Hz), comp {c}, θ = {th:?}: {g} against {w}",
                freqs[e]
            );
            compared += 1;
        }
    }
    compared
}

#[test]
fn the_batch_equals_the_interpreter_bit_for_bit_for_every_tier() {
    let m = tiers();
    let thetas = [vec![1.3, 0.4], vec![0.7, -0.2], vec![1.3, 0.4]];
    // all six coefficients (a zero, a constant, θ-dependent delays); a subset in another
    // order, whose values read only part of the program; one edge, a chunk, chunks and a tail
    for n in [1, 64, 130] {
        assert_batch_equal(&m, n, &[0, 1, 2, 3, 4, 5], &thetas);
        assert_batch_equal(&m, n, &[5, 1], &thetas);
        assert_batch_equal(&m, n, &[3], &thetas);
    }
}

#[test]
fn the_closed_loop_batch_equals_the_interpreter_bit_for_bit() {
    let m = closed_loop(|t| t);
    // the components relative binning asks for: the four that vary
    let n = assert_batch_equal(&m, 100, &[2, 3, 6, 7], &closed_loop_thetas());
    assert_eq!(n, 2 * 100 * 4);
    // a tied model forwards its parent's batch at the parent's θ
    let tied = TiedModel::new(
        "tied",
        Arc::new(m),
        &[("dt2".to_string(), "dt1".to_string())],
    )
    .unwrap();
    let th: Vec<Vec<f64>> = closed_loop_thetas()
        .into_iter()
        .map(|t| [&t[..3], &t[4..]].concat())
        .collect();
    assert_batch_equal(&tied, 65, &[2, 3, 6, 7], &th);
}
