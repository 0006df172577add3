//! Unit tests of state-space models: responses against closed forms, exact derivatives,
//! delays, discrete time, noise CSDs, the transfer-matrix form and the load-time errors.

use super::*;
use crate::model::user::UserModel;
use crate::model::{Bin, Model, coefficients_at};
use num_complex::{Complex, Complex64};
use num_dual::Dual64;
use std::f64::consts::PI;

fn def(text: &str) -> StateSpaceDef {
    toml::from_str(text).unwrap()
}

const OSC: &str = r#"
name = "osc"
parameters = ["k", "gamma"]
inputs = ["u"]
outputs = ["y"]
a = [[0, 1], ["-k", "-gamma"]]
b = [[0], [1]]
c = [[1, 0]]
"#;

fn s_of(f: f64) -> Complex64 {
    Complex64::new(0.0, 2.0 * PI * f)
}

/// `M = [1, −H]` of the oscillator is `H = 1/(s² + γ s + k)`, with exact derivatives.
#[test]
fn oscillator_response_and_derivatives() {
    let m = StateSpaceModel::new(&def(OSC)).unwrap();
    let (k, g) = (3.0, 0.4);
    for f in [1e-3, 0.05, 0.2756, 1.0, 30.0] {
        let s = s_of(f);
        let h = 1.0 / (s * s + g * s + k);
        let c = coefficients_at(&m, &[k, g], f, 10.0);
        assert!((c[0] - 1.0).norm() == 0.0);
        assert!((c[1] + h).norm() < 1e-14 * h.norm(), "f = {f}");
        // dH/dk = −H², dH/dγ = −s H²
        let bin = Bin {
            f,
            fs: 10.0,
            consts: &[],
        };
        let zero = Complex::new(Dual64::from(0.0), Dual64::from(0.0));
        for (a, want) in [(0, -h * h), (1, -s * h * h)] {
            let mut th = [Dual64::from(k), Dual64::from(g)];
            th[a] = th[a].derivative();
            let mut out = [zero; 2];
            m.coefficients_dual(&th, &bin, &mut out);
            let d = Complex64::new(out[1].re.eps, out[1].im.eps);
            assert!((d + want).norm() < 1e-13 * want.norm(), "f = {f}, θ{a}");
        }
    }
}

#[test]
fn delays_discrete_time_and_feedthrough() {
    // x[k+1] = a x[k] + u, y = x + 0.5 u (delayed by tau on the output): H = (1/(z − a) + 0.5) e^{−sτ}
    let m = StateSpaceModel::new(&def(r#"
name = "first"
parameters = ["a", "tau"]
inputs = ["u"]
outputs = ["y"]
time = "discrete"
a = [["a"]]
b = [[1]]
c = [[1]]
d = [[0.5]]
delay = { y = "tau" }
"#))
    .unwrap();
    let (a, tau, fs) = (0.6, 0.13, 4.0);
    for f in [0.01, 0.3, 1.7] {
        let z = Complex64::from_polar(1.0, 2.0 * PI * f / fs);
        let h = (1.0 / (z - a) + 0.5) * (-s_of(f) * tau).exp();
        let c = coefficients_at(&m, &[a, tau], f, fs);
        assert!((c[1] + h).norm() < 1e-14, "f = {f}");
    }
    assert!(m.check(&[0.6, 0.1]).is_ok());
    let e = m.check(&[1.2, 0.1]).unwrap_err();
    assert!(e.contains("unit circle") && e.contains("`first`"), "{e}");
    let e = m.check(&[0.6, -0.1]).unwrap_err();
    assert!(e.contains("delay.y"), "{e}");
}

/// The batch and the residual power evaluate the matrices once per θ and must equal the
/// per-bin path exactly.
#[test]
fn batch_and_residual_power_equal_the_generic_paths() {
    let m = StateSpaceModel::new(&def(OSC)).unwrap();
    let th = [2.0, 0.3];
    let freqs = [0.01, 0.1, 0.2, 0.4];
    let mut out = [Complex64::new(0.0, 0.0); 8];
    m.coefficients_batch(&th, &freqs, 10.0, &[], &[0, 1], &mut out);
    let mut generic = out;
    crate::model::coefficients_batch_generic(&m, &th, &freqs, 10.0, &[], &[0, 1], &mut generic);
    assert_eq!(out, generic);
    let data: Vec<Complex64> = (0..8)
        .map(|k| Complex64::new(k as f64 * 0.1 + 0.3, 1.0 - k as f64 * 0.2))
        .collect();
    let cinv = vec![(2.0, Complex64::new(0.0, 0.0), 0.0); 4];
    let block = crate::model::BinBlock {
        f0: 0.01,
        df: 0.05,
        fs: 10.0,
        n: 4,
        data: &data,
        cinv: &cinv,
        consts: &[],
        whiten: &[],
    };
    let a = m.residual_power(&th, &block);
    let b = crate::model::residual_power_generic(&m, &th, &block);
    assert!((a - b).abs() <= 1e-15 * b.abs(), "{a} vs {b}");
}

/// Three outputs: the residual power goes through the whitening factors (the N-channel
/// likelihood) and equals the generic whitened path and a direct `rᴴC⁻¹r` with `C = L Lᴴ`.
#[test]
fn three_outputs_take_the_whitened_path() {
    let m = StateSpaceModel::new(&def(r#"
name = "three"
parameters = ["k", "g"]
inputs = ["u"]
outputs = ["y1", "y2", "y3"]
a = [[0, 1], ["-k", "-g"]]
b = [[0], [1]]
c = [[1, 0], [0, 1], ["g", "k"]]
d = [[0], [0.1], [0]]
"#))
    .unwrap();
    let th = [2.0, 0.3];
    let n = 5;
    let data: Vec<Complex64> = (0..4 * n)
        .map(|k| Complex64::new((k as f64 * 0.37).sin(), (k as f64 * 0.11).cos()))
        .collect();
    // C_k = L Lᴴ with L lower triangular, diagonal > 0
    let z = Complex64::new(0.0, 0.0);
    let mut cov = Vec::new();
    let mut whiten = Vec::new();
    for k in 0..n {
        let x = k as f64;
        let l = [
            [Complex64::new(1.0 + 0.1 * x, 0.0), z, z],
            [Complex64::new(0.2, -0.1 * x), Complex64::new(0.8, 0.0), z],
            [
                Complex64::new(-0.3, 0.2),
                Complex64::new(0.1 * x, 0.4),
                Complex64::new(1.2, 0.0),
            ],
        ];
        let mut c = vec![z; 9];
        for i in 0..3 {
            for j in 0..3 {
                c[i * 3 + j] = (0..3).map(|q| l[i][q] * l[j][q].conj()).sum();
            }
        }
        let mut w = vec![z; crate::model::tri_len(3)];
        crate::hermitian::whitener(&c, 3, 1e-14, &mut w).unwrap();
        whiten.extend(w);
        cov.push(nalgebra::DMatrix::from_row_slice(3, 3, &c));
    }
    let block = crate::model::BinBlock {
        f0: 0.01,
        df: 0.05,
        fs: 10.0,
        n,
        data: &data,
        cinv: &[],
        consts: &[],
        whiten: &whiten,
    };
    let a = m.residual_power(&th, &block);
    let b = crate::model::residual_power_whitened(&m, &th, &block);
    let mut direct = 0.0;
    let mut coef = [z; 12];
    for k in 0..n {
        m.coefficients(
            &th,
            &Bin {
                f: 0.01 + k as f64 * 0.05,
                fs: 10.0,
                consts: &[],
            },
            &mut coef,
        );
        let d = &data[k * 4..(k + 1) * 4];
        let r = nalgebra::DVector::from_iterator(
            3,
            (0..3).map(|i| (0..4).map(|c| coef[i * 4 + c] * d[c]).sum::<Complex64>()),
        );
        let x = cov[k].clone().lu().solve(&r).unwrap();
        direct += r.dotc(&x).re;
    }
    assert!((a - b).abs() <= 1e-15 * b.abs(), "{a} vs {b}");
    assert!(
        (a - direct).abs() <= 1e-12 * direct.abs(),
        "{a} vs {direct}"
    );
}

#[test]
fn noise_inputs_give_the_output_csd() {
    // ẋ = −a x + w, y = x + v: S_y = q/|s + a|² + r
    let m = StateSpaceModel::new(&def(r#"
name = "noisy"
parameters = ["a"]
inputs = ["u"]
outputs = ["y"]
a = [["-a"]]
b = [[1]]
c = [[1]]
g = [[1, 0]]
h = [[0, 1]]
noise = [2.0, "0.5*a"]
"#))
    .unwrap();
    let a = 0.7;
    let f = 0.2;
    let mut out = [Complex64::new(9.0, 9.0); 4];
    let bin = Bin {
        f,
        fs: 10.0,
        consts: &[],
    };
    assert!(m.data_noise_csd(&[a], &bin, &mut out));
    let want = 2.0 / (s_of(f) + a).norm_sqr() + 0.5 * a;
    assert!((out[0].re - want).abs() < 1e-14 * want && out[0].im.abs() < 1e-16);
    assert_eq!(&out[1..], &[Complex64::new(0.0, 0.0); 3]);
    let plain = StateSpaceModel::new(&def(OSC)).unwrap();
    assert!(!plain.data_noise_csd(&[1.0, 1.0], &bin, &mut out));
}

/// A two-mass spring under PD position control of the first mass, written as a state-space model and as a user
/// model with blocks: same coefficients, same derivatives.
#[test]
fn two_mass_spring_matches_the_user_model() {
    let ss = StateSpaceModel::new(&def(r#"
name = "ss"
parameters = ["k", "kp", "kd"]
inputs = ["r"]
outputs = ["y1", "y2"]
constants = { m1 = 1.0, m2 = 0.5, c = 0.05 }
# states x1, x2, v1, v2; force on mass 1: kp (r − x1) − kd v1
a = [[0, 0, 1, 0], [0, 0, 0, 1],
     ["-(k + kp)/m1", "k/m1", "-(c + kd)/m1", 0],
     ["k/m2", "-k/m2", 0, "-c/m2"]]
b = [[0], [0], ["kp/m1"], [0]]
c = [[1, 0, 0, 0], [0, 1, 0, 0]]
"#))
    .unwrap();
    let user: crate::model::user::UserModelDef = toml::from_str(
        r#"
name = "user"
parameters = ["k", "kp", "kd"]
data = ["y1", "y2", "r"]
residual = ["y1", "y2"]
constants = { m1 = 1.0, m2 = 0.5, c = 0.05 }
[define]
# (m1 s² + c s + k) x1 − k x2 = kp (r − x1) − kd s x1 ; (m2 s² + c s + k) x2 = k x1
p1 = "m1*s^2 + (c + kd)*s + k + kp"
p2 = "m2*s^2 + c*s + k"
det = "p1*p2 - k^2"
[coefficients.y1]
y1 = "1"
r = "-kp*p2/det"
[coefficients.y2]
y2 = "1"
r = "-kp*k/det"
"#,
    )
    .unwrap();
    let user = UserModel::new(&user).unwrap();
    let th = [2.0, 3.0, 1.5];
    assert!(ss.check(&th).is_ok());
    let zero = Complex::new(Dual64::from(0.0), Dual64::from(0.0));
    let mut worst: f64 = 0.0;
    for k in 0..200 {
        let f = 1e-3 * 1.05f64.powi(k);
        let (a, b) = (
            coefficients_at(&ss, &th, f, 100.0),
            coefficients_at(&user, &th, f, 100.0),
        );
        // relative to the largest entry: a component far below the others is rounding
        let scale = b.iter().map(|z| z.norm()).fold(0.0, f64::max);
        for (x, y) in a.iter().zip(&b) {
            worst = worst.max((x - y).norm() / scale);
        }
        let bin = Bin {
            f,
            fs: 100.0,
            consts: &[],
        };
        for p in 0..3 {
            let mut t: Vec<Dual64> = th.iter().map(|&x| Dual64::from(x)).collect();
            t[p] = t[p].derivative();
            let (mut da, mut db) = ([zero; 6], [zero; 6]);
            ss.coefficients_dual(&t, &bin, &mut da);
            user.coefficients_dual(&t, &bin, &mut db);
            let eps = |z: &Complex<Dual64>| Complex64::new(z.re.eps, z.im.eps);
            let scale = db.iter().map(|z| eps(z).norm()).fold(0.0, f64::max);
            for (x, y) in da.iter().zip(&db) {
                worst = worst.max((eps(x) - eps(y)).norm() / scale);
            }
        }
    }
    assert!(worst < 1e-11, "worst relative difference {worst:e}");
    eprintln!("two-mass spring: state-space vs user model {worst:.1e}");
}

#[test]
fn transfer_matrix_is_a_user_model() {
    let t: TransferMatrixDef = toml::from_str(
        r#"
name = "tm"
parameters = ["k", "gamma"]
inputs = ["u"]
outputs = ["y"]
[define]
p = "s^2 + gamma*s + k"
[h.y]
u = "1/p"
"#,
    )
    .unwrap();
    let user = UserModel::new(&to_user_def(&t).unwrap()).unwrap();
    let ss = StateSpaceModel::new(&def(OSC)).unwrap();
    for f in [0.01, 0.3] {
        let (a, b) = (
            coefficients_at(&user, &[3.0, 0.4], f, 10.0),
            coefficients_at(&ss, &[3.0, 0.4], f, 10.0),
        );
        assert_eq!(user.data_channels(), ss.data_channels());
        assert!((a[1] - b[1]).norm() < 1e-14 * b[1].norm());
    }
    let mut bad = t.clone();
    bad.h.insert("z".into(), Default::default());
    assert!(to_user_def(&bad).unwrap_err().contains("h.z"));
    let mut bad = t.clone();
    bad.h.get_mut("y").unwrap().insert("q".into(), "1".into());
    assert!(to_user_def(&bad).unwrap_err().contains("h.y.q"));
    let mut bad = t;
    bad.h
        .get_mut("y")
        .unwrap()
        .insert("u".into(), "1/pp".into());
    let e = user_error(&UserModel::new(&to_user_def(&bad).unwrap()).unwrap_err());
    assert!(
        e.contains("transfer-matrix model `tm`: h.y.u") && e.contains("pp"),
        "{e}"
    );
}

/// Every load-time error names the model and the entry.
#[test]
fn errors_name_the_entry() {
    let err = |edit: &dyn Fn(&mut StateSpaceDef)| {
        let mut d = def(OSC);
        edit(&mut d);
        StateSpaceModel::new(&d).unwrap_err()
    };
    type Edit = Box<dyn Fn(&mut StateSpaceDef)>;
    let cases: Vec<(Edit, &[&str])> = vec![
        (
            Box::new(|d| d.a[1].pop().map(|_| ()).unwrap()),
            &["a[1]", "2 × 2"],
        ),
        (
            Box::new(|d| d.b.push(vec![])),
            &[": b: ", "states × inputs"],
        ),
        (
            Box::new(|d| d.c[0][0] = RealValue::Expr("k*zz".into())),
            &["c[0][0]", "zz", "parameters (k, gamma)"],
        ),
        (
            Box::new(|d| d.c[0][0] = RealValue::Expr("k*+".into())),
            &["c[0][0]"],
        ),
        (
            Box::new(|d| d.parameters.push("unused".into())),
            &["parameters", "`unused`"],
        ),
        (
            Box::new(|d| d.inputs = vec!["y".into()]),
            &["inputs", "both"],
        ),
        (Box::new(|d| d.outputs.clear()), &["outputs", "empty"]),
        (
            Box::new(|d| {
                d.delay.insert("w".into(), RealValue::Number(0.1));
            }),
            &["delay.w", "not an input or output"],
        ),
        (
            Box::new(|d| {
                d.delay.insert("u".into(), RealValue::Number(-0.1));
            }),
            &["delay.u", "≥ 0"],
        ),
        (
            Box::new(|d| d.noise = Some(vec![RealValue::Number(1.0)])),
            &["`g`", "missing"],
        ),
        (
            Box::new(|d| d.states = Some(vec!["p".into()])),
            &["states", "2 rows"],
        ),
        (
            Box::new(|d| d.parameters[1] = "sin".into()),
            &["parameters", "`sin`"],
        ),
        (
            Box::new(|d| {
                d.constants.insert("k".into(), 1.0);
            }),
            &["constants.k", "twice"],
        ),
        (
            Box::new(|d| d.a[0][0] = RealValue::Number(f64::INFINITY)),
            &["a[0][0]", "finite"],
        ),
        (Box::new(|d| d.a.clear()), &[": a: ", "1 to 32 states"]),
        // a `noise` list shorter than `g`'s columns is what is wrong, not `g`'s rows
        (
            Box::new(|d| {
                d.g = Some(vec![
                    vec![RealValue::Number(0.0), RealValue::Number(0.0)],
                    vec![RealValue::Number(1.0), RealValue::Number(0.0)],
                ]);
                d.noise = Some(vec![RealValue::Number(1.0)]);
            }),
            &[": noise: ", "has 1 entries, but `g` has 2 columns"],
        ),
        (
            Box::new(|d| d.c[0][0] = RealValue::Expr("foo(k)".into())),
            &["c[0][0]", "unknown function `foo`"],
        ),
    ];
    for (k, (edit, want)) in cases.iter().enumerate() {
        let e = err(edit.as_ref());
        assert!(e.contains("state-space model `osc`"), "case {k}: {e}");
        for w in *want {
            assert!(e.contains(w), "case {k}: `{w}` not in: {e}");
        }
    }
}

use crate::model::user::RealValue;

/// The transfer matrix `y = g u` with `line` added to its table, as a user model.
fn one_gain_transfer_matrix(line: &str) -> UserModel {
    let text = format!(
        "name = \"tm\"\nparameters = [\"g\"]\n{line}\ninputs = [\"u\"]\noutputs = [\"y\"]\n[h.y]\nu = \"g\"\n"
    );
    let tm: TransferMatrixDef = toml::from_str(&text).unwrap();
    UserModel::new(&to_user_def(&tm).unwrap()).unwrap()
}

#[test]
fn state_space_and_transfer_matrix_models_carry_their_parameter_units() {
    let d = def(&OSC.replace(
        "parameters = [\"k\", \"gamma\"]",
        "parameters = [\"k\", \"gamma\"]\nunit = { k = \"s⁻²\", gamma = \"s⁻¹\" }",
    ));
    let m = StateSpaceModel::new(&d).unwrap();
    assert_eq!(m.param_units(), ["s⁻²", "s⁻¹"]);
    let u = one_gain_transfer_matrix("unit = { g = \"m/N\" }");
    assert_eq!(u.param_units(), ["m/N"]);
    let bad = def(&OSC.replace("c = [[1, 0]]", "c = [[1, 0]]\nunit = { q = \"s\" }"));
    let e = StateSpaceModel::new(&bad).unwrap_err();
    assert!(
        e.contains("state-space model `osc`") && e.contains("unit.q"),
        "{e}"
    );
}

/// Physical limits (issue 52's walk: `bc = 0` of the two-mass example and `dt1 = 0` of the
/// state-space loop were warned about as misplaced prior boxes): a parameter that is a delay
/// is ≥ 0 unasked, `physical_limits` states others, and a written entry replaces the implied
/// one; the transfer-matrix form carries them too.
#[test]
fn state_space_models_state_their_physical_limits() {
    let m = StateSpaceModel::new(&def(OSC)).unwrap();
    assert_eq!(m.physical_limits(), [[None, None]; 2]);
    let delayed = OSC.replace(
        "parameters = [\"k\", \"gamma\"]",
        "parameters = [\"k\", \"gamma\", \"tau\"]\ndelay = { u = \" tau \" }\nphysical_limits = { gamma = { lo = 0.0 } }",
    );
    let m = StateSpaceModel::new(&def(&delayed)).unwrap();
    assert_eq!(
        m.physical_limits(),
        [[None, None], [Some(0.0), None], [Some(0.0), None]]
    );
    let replaced = delayed.replace(
        "{ gamma = { lo = 0.0 } }",
        "{ tau = { lo = 0.0, hi = 2.0 } }",
    );
    let m = StateSpaceModel::new(&def(&replaced)).unwrap();
    assert_eq!(m.physical_limits()[2], [Some(0.0), Some(2.0)]);
    for (limits, says) in [
        ("{ q = { lo = 0.0 } }", "`q` is not a parameter"),
        ("{ k = { } }", "give `lo`, `hi` or both"),
        (
            "{ k = { lo = 1.0, hi = 1.0 } }",
            "lo = 1 is not below hi = 1",
        ),
        ("{ k = { lo = -inf } }", "lo is not a finite number"),
    ] {
        let bad = OSC.replace(
            "c = [[1, 0]]",
            &format!("c = [[1, 0]]\nphysical_limits = {limits}"),
        );
        let e = StateSpaceModel::new(&def(&bad)).unwrap_err();
        assert!(
            e.contains("state-space model `osc`: physical_limits.") && e.contains(says),
            "{e}"
        );
    }
    assert!(
        toml::from_str::<StateSpaceDef>(&OSC.replace(
            "c = [[1, 0]]",
            "c = [[1, 0]]\nphysical_limits = { k = { low = 0.0 } }"
        ))
        .is_err()
    );
    let u = one_gain_transfer_matrix("physical_limits = { g = { hi = 1.0 } }");
    assert_eq!(u.physical_limits(), [[None, Some(1.0)]]);
}
