use super::*;
use crate::ltp::LtpParams;
use crate::model::{Bin, BinBlock, LtpModel, Model, coefficients_at, residual_power_generic};
use num_complex::{Complex, Complex64};
use num_dual::Dual64;
use std::f64::consts::PI;

/// The `[[model]]` table of the example study, without `kind`.
fn example_def() -> UserModelDef {
    let text = include_str!("../../../examples/user-model-closed-loop.toml");
    let v: toml::Table = toml::from_str(text).unwrap();
    let mut t = v["model"].as_array().unwrap()[0]
        .as_table()
        .unwrap()
        .clone();
    assert_eq!(t.remove("kind").unwrap().as_str(), Some("user"));
    toml::Value::Table(t).try_into().unwrap()
}

fn from_toml(text: &str) -> Result<UserModel, String> {
    let def: UserModelDef = toml::from_str(text).map_err(|e| format!("toml: {e}"))?;
    UserModel::new(&def)
}

fn log_grid(n: usize) -> Vec<f64> {
    (0..n)
        .map(|k| 1e-4 * 1e4f64.powf(k as f64 / (n - 1) as f64))
        .collect()
}

fn dual_coefs(m: &dyn Model, th: &[f64], a: usize, f: f64) -> Vec<Complex64> {
    let mut consts = vec![Complex64::new(0.0, 0.0); m.n_consts()];
    m.bin_consts(f, 10.0, &mut consts);
    let thd: Vec<Dual64> = th
        .iter()
        .enumerate()
        .map(|(i, &x)| {
            if i == a {
                Dual64::from(x).derivative()
            } else {
                Dual64::from(x)
            }
        })
        .collect();
    let n = m.data_channels().len() * m.residual_channels().len();
    let mut out = vec![Complex::new(Dual64::from(0.0), Dual64::from(0.0)); n];
    let bin = Bin {
        f,
        fs: 10.0,
        consts: &consts,
    };
    m.coefficients_dual(&thd, &bin, &mut out);
    out.iter()
        .map(|z| Complex64::new(z.re.eps, z.im.eps))
        .collect()
}

#[test]
fn example_closed_loop_equals_the_builtin_ltp_model() {
    let u = UserModel::new(&example_def()).unwrap();
    let l = LtpModel::new("ltp", Default::default());
    assert_eq!(u.param_names(), l.param_names());
    assert_eq!(u.data_channels(), l.data_channels());
    assert_eq!(u.residual_channels(), l.residual_channels());
    // the two controllers are per-bin constants, the delays are not
    assert_eq!(u.n_consts(), 2);
    let th = LtpParams::default().to_array();
    u.check(&th).unwrap();
    let grid = log_grid(81);
    for &f in &grid {
        let (cu, cl) = (
            coefficients_at(&u, &th, f, 10.0),
            coefficients_at(&l, &th, f, 10.0),
        );
        for (k, (a, b)) in cu.iter().zip(&cl).enumerate() {
            assert!(
                (a - b).norm() <= 1e-12 * b.norm(),
                "f = {f}, entry {k}: {a} vs {b}"
            );
        }
        let du: Vec<_> = (0..7).map(|a| dual_coefs(&u, &th, a, f)).collect();
        let dl: Vec<_> = (0..7).map(|a| dual_coefs(&l, &th, a, f)).collect();
        for k in 0..8 {
            let scale = (0..7).map(|a| dl[a][k].norm()).fold(0.0, f64::max);
            for a in 0..7 {
                assert!(
                    (du[a][k] - dl[a][k]).norm() <= 1e-9 * scale,
                    "f = {f}, entry {k}, ∂/∂{}: {} vs {}",
                    l.param_names()[a],
                    du[a][k],
                    dl[a][k]
                );
            }
        }
    }
    crate::model::check_identifiable(&u, &th, &grid, 10.0).unwrap();
}

#[test]
fn generic_residual_power_matches_the_builtin_model() {
    let u = UserModel::new(&example_def()).unwrap();
    let l = LtpModel::new("ltp", Default::default());
    let th = LtpParams::default().to_array();
    let (n, f0, df, fs) = (2000, 1e-4, 1e-4, 10.0);
    let consts = |m: &dyn Model| {
        let nc = m.n_consts();
        let mut c = vec![Complex64::new(0.0, 0.0); n * nc];
        for k in 0..n {
            m.bin_consts(f0 + k as f64 * df, fs, &mut c[k * nc..(k + 1) * nc]);
        }
        c
    };
    // splitmix64 → uniform(−1, 1)
    let mut state = 0x2014u64;
    let mut rnd = || {
        state = state.wrapping_add(0x9e3779b97f4a7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58476d1ce4e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d049bb133111eb);
        z ^= z >> 31;
        2.0 * (z >> 11) as f64 / (1u64 << 53) as f64 - 1.0
    };
    let data: Vec<Complex64> = (0..4 * n).map(|_| Complex64::new(rnd(), rnd())).collect();
    let cinv: Vec<_> = (0..n)
        .map(|_| {
            let (a, c) = (1.5 + rnd(), 1.5 + rnd());
            (a, Complex64::new(0.3 * rnd(), 0.3 * rnd()), c)
        })
        .collect();
    let (cu, cl) = (consts(&u), consts(&l));
    let block = |c| BinBlock {
        f0,
        df,
        fs,
        n,
        data: &data,
        cinv: &cinv,
        whiten: &[],
        consts: c,
    };
    let pu = residual_power_generic(&u, &th, &block(&cu));
    let pl = l.residual_power(&th, &block(&cl));
    let pg = residual_power_generic(&l, &th, &block(&cl));
    assert!(pu.is_finite() && pu > 0.0);
    assert!((pu - pl).abs() <= 1e-10 * pl.abs(), "{pu} vs {pl}");
    assert!((pu - pg).abs() <= 1e-10 * pg.abs(), "{pu} vs {pg}");
    assert_eq!(u.residual_power(&th, &block(&cu)), pu);
}

/// A one-coefficient model `r = coef · d` with parameters `x` (and `y`) and one block.
fn one_block(block: &str, coef: &str) -> UserModel {
    from_toml(&format!(
        r#"
name = "blk"
parameters = ["x"]
data = ["d"]
residual = ["r"]
[blocks]
b = {block}
[coefficients.r]
d = "{coef}"
"#
    ))
    .unwrap()
}

#[test]
fn every_block_kind_matches_its_closed_form_with_exact_derivatives() {
    type Closed = fn(f64, f64) -> Complex64;
    let cases: [(&str, &str, f64, Closed); 8] = [
        (r#"{ kind = "gain", value = "x" }"#, "b", 0.7, |x, _| {
            x.into()
        }),
        (r#"{ kind = "delay", tau = "x" }"#, "b", 0.3, |x, f| {
            Complex64::from_polar(1.0, -2.0 * PI * f * x)
        }),
        (r#"{ kind = "pole", f = "x" }"#, "b", 0.2, |x, f| {
            (Complex64::new(1.0, f / x)).inv()
        }),
        (r#"{ kind = "zero", f = "x" }"#, "b", 0.2, |x, f| {
            Complex64::new(1.0, f / x)
        }),
        (
            r#"{ kind = "complex_pole", f = "x", q = "2*x + 1" }"#,
            "b",
            0.4,
            |x, f| {
                let (w0, w, q) = (2.0 * PI * x, 2.0 * PI * f, 2.0 * x + 1.0);
                w0 * w0 / Complex64::new(w0 * w0 - w * w, w * w0 / q)
            },
        ),
        (r#"{ kind = "s_power", n = -3 }"#, "x*b", 1.3, |x, f| {
            x * Complex64::new(0.0, 2.0 * PI * f).powi(-3)
        }),
        (r#"{ kind = "s_power", n = 2 }"#, "x*b", 1.3, |x, f| {
            x * Complex64::new(0.0, 2.0 * PI * f).powi(2)
        }),
        (
            r#"{ kind = "rational", num = ["x", 1], den = [1, "x^2 + pi", 3.5] }"#,
            "b",
            0.6,
            |x, f| {
                let s = Complex64::new(0.0, 2.0 * PI * f);
                (x * s + 1.0) / (s * s + (x * x + PI) * s + 3.5)
            },
        ),
    ];
    for (block, coef, x, closed) in cases {
        let m = one_block(block, coef);
        for f in [1e-3, 0.05, 0.2, 1.0, 3.0] {
            let v = coefficients_at(&m, &[x], f, 10.0)[0];
            let want = closed(x, f);
            assert!(
                (v - want).norm() <= 1e-13 * want.norm(),
                "{block} at {f}: {v} vs {want}"
            );
            let d = dual_coefs(&m, &[x], 0, f)[0];
            let h = 1e-6 * x.abs();
            let num = (closed(x + h, f) - closed(x - h, f)) / (2.0 * h);
            assert!(
                (d - num).norm() <= 1e-7 * num.norm().max(want.norm()),
                "{block} at {f}: d/dx {d} vs {num}"
            );
        }
    }
}

#[test]
fn constant_blocks_are_per_bin_constants() {
    // the same blocks with numbers only: one constant each, equal to the closed form
    let m = from_toml(
        r#"
name = "c"
parameters = ["x"]
data = ["d"]
residual = ["r"]
[constants]
fo = 0.5
[blocks]
p = { kind = "pole", f = "fo" }
cp = { kind = "complex_pole", f = 1.0, q = "2*fo" }
d = { kind = "delay", tau = 0.25 }
unused = { kind = "zero", f = 3 }
[coefficients.r]
d = "x*p*cp*d"
"#,
    )
    .unwrap();
    assert_eq!(m.n_consts(), 3);
    let f = 0.7;
    let s = Complex64::new(0.0, 2.0 * PI * f);
    let w0 = 2.0 * PI;
    let want = 2.0 / (1.0 + s / (2.0 * PI * 0.5)) * w0 * w0 / (s * s + s * w0 / 1.0 + w0 * w0)
        * (-s * 0.25).exp();
    let v = coefficients_at(&m, &[2.0], f, 10.0)[0];
    assert!((v - want).norm() < 1e-14 * want.norm(), "{v} vs {want}");
}

fn err(text: &str) -> String {
    match from_toml(text) {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => e,
    }
}

/// A valid two-residual model with `x`, `y`, one θ-dependent and one constant block; `patch`
/// lines replace or add entries.
fn base(extra_top: &str, extra: &str) -> String {
    format!(
        r#"
name = "bad"
parameters = ["x", "y"]
data = ["o1", "o12", "i1"]
residual = ["o1", "o12"]
{extra_top}
[constants]
c = 2.0
[blocks]
t = {{ kind = "delay", tau = "y" }}
g = {{ kind = "gain", value = 3 }}
[define]
h = "x*t*g/c"
[coefficients.o1]
o1 = "1"
i1 = "-h"
[coefficients.o12]
o12 = "1"
{extra}
"#
    )
}

#[test]
fn the_base_of_the_error_tests_is_valid() {
    let m = from_toml(&base("", "")).unwrap();
    m.check(&[1.0, 0.5]).unwrap();
    crate::model::check_identifiable(&m, &[1.0, 0.5], &[0.1], 10.0).unwrap();
}

#[test]
fn bad_definitions_name_the_model_the_entry_and_what_is_allowed() {
    let cases: Vec<(String, Vec<&str>)> = vec![
        // unknown names
        (
            base("", "i1 = \"zz*h\""),
            vec![
                "coefficients.o12.i1",
                "unknown name `zz`",
                "parameters (x, y)",
                "blocks (g, t)",
            ],
        ),
        (
            base("", "").replace("h = \"x*t*g/c\"", "h = \"x*t*g/c + nope\""),
            vec![
                "define.h",
                "unknown name `nope` at character 10",
                "defines (h)",
                "`s` and `pi`",
            ],
        ),
        (
            base("", "").replace("tau = \"y\"", "tau = \"y*g\""),
            vec![
                "blocks.t.tau",
                "unknown name `g`",
                "block `g` is complex",
                "blocks, defines and `s` are complex",
            ],
        ),
        (
            base("", "").replace("tau = \"y\"", "tau = \"y + s\""),
            vec!["blocks.t.tau", "unknown name `s`"],
        ),
        // channels
        (
            base("", "[coefficients.o3]\ni1 = \"1\""),
            vec![
                "coefficients.o3",
                "not a declared residual channel",
                "residual = [o1, o12]",
            ],
        ),
        (
            base("", "g9 = \"1\""),
            vec![
                "coefficients.o12.g9",
                "not a declared data channel",
                "data = [o1, o12, i1]",
            ],
        ),
        (
            base("", "").replace("o12 = \"1\"\n", ""),
            vec!["coefficients.o12", "no coefficients"],
        ),
        (
            base("", "").replace(
                "residual = [\"o1\", \"o12\"]",
                &format!(
                    "residual = [\"o1\", \"o12\", {}]",
                    (3..=17)
                        .map(|i| format!("\"o{i}\""))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            ),
            vec!["residual", "17 channels; at most 16"],
        ),
        (
            base("", "").replace(
                "data = [\"o1\", \"o12\", \"i1\"]",
                &format!(
                    "data = [\"o1\", \"o12\", \"i1\", {}]",
                    (0..30)
                        .map(|i| format!("\"d{i}\""))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            ),
            vec!["data", "33 channels; at most 32"],
        ),
        // names
        (
            base("", "").replace("[\"x\", \"y\"]", "[\"x\", \"y\", \"x\"]"),
            vec!["parameters", "`x` is listed twice"],
        ),
        (
            base("", "").replace("[\"x\", \"y\"]", "[\"x\", \"y\", \"t\"]"),
            vec!["blocks.t", "already taken by parameter `t`"],
        ),
        (
            base("", "").replace("c = 2.0", "c = 2.0\ns = 1.0"),
            vec!["constants.s", "already taken by the Laplace variable `s`"],
        ),
        (
            base("", "").replace("c = 2.0", "c = 2.0\nh = 1.0"),
            vec!["define.h", "already taken by constant `h`"],
        ),
        (
            base("", "").replace("[\"x\", \"y\"]", "[\"x\", \"y\", \"2y\"]"),
            vec!["parameters", "`2y` is not a valid name"],
        ),
        (
            base("", "").replace("c = 2.0", "c = 2.0\nE = 1.0"),
            vec![
                "constants.E",
                "function or constant of the real-expression parser",
            ],
        ),
        (
            base("", "").replace("[\"x\", \"y\"]", "[\"x\", \"y\", \"sin\"]"),
            vec!["parameters", "`sin` is a function"],
        ),
        // numbers
        (
            base("", "").replace("c = 2.0", "c = nan"),
            vec!["constants.c", "not a finite number"],
        ),
        (
            base("", "").replace("value = 3", "value = \"1/0\""),
            vec!["blocks.g.value", "not a finite number"],
        ),
        (
            base("", "").replace(
                "{ kind = \"gain\", value = 3 }",
                "{ kind = \"pole\", f = \"-c\" }",
            ),
            vec!["blocks.g.f", "is -2", "> 0 Hz"],
        ),
        (
            base("", "").replace(
                "{ kind = \"gain\", value = 3 }",
                "{ kind = \"zero\", f = 0 }",
            ),
            vec!["blocks.g.f", "non-zero"],
        ),
        (
            base("", "").replace(
                "{ kind = \"gain\", value = 3 }",
                "{ kind = \"complex_pole\", f = 1, q = 0 }",
            ),
            vec!["blocks.g.q", "> 0"],
        ),
        (
            base("", "").replace("tau = \"y\"", "tau = -1"),
            vec!["blocks.t.tau", "≥ 0"],
        ),
        (
            base("", "").replace(
                "{ kind = \"gain\", value = 3 }",
                "{ kind = \"rational\", num = [1], den = [] }",
            ),
            vec!["blocks.g.den", "empty"],
        ),
        (
            base("", "").replace(
                "{ kind = \"gain\", value = 3 }",
                "{ kind = \"rational\", num = [1], den = [0, \"c - 2\"] }",
            ),
            vec!["blocks.g.den", "identically zero"],
        ),
        // a controller written with a sign flipped: poles at s = (0.477 ± 0.318)/0.0633,
        // beside an integrator (a root at zero, allowed)
        (
            base("", "").replace(
                "{ kind = \"gain\", value = 3 }",
                "{ kind = \"rational\", num = [1], den = [0.03166287, -0.47746483, 1, 0] }",
            ),
            vec![
                "blocks.g.den",
                "has the root s = ",
                "positive real part",
                "signs of `den`",
            ],
        ),
        (
            base("", "").replace(
                "{ kind = \"gain\", value = 3 }",
                "{ kind = \"rational\", num = [inf], den = [1] }",
            ),
            vec!["blocks.g.num[0]", "not a finite number"],
        ),
        (
            base("", "").replace(
                "{ kind = \"gain\", value = 3 }",
                "{ kind = \"s_power\", n = 40 }",
            ),
            vec!["blocks.g.n", "|n| ≤ 16"],
        ),
        // parameters that do nothing
        (
            base("", "").replace("[\"x\", \"y\"]", "[\"x\", \"y\", \"w\"]"),
            vec![
                "parameters",
                "parameter `w` is declared but not used by any coefficient",
            ],
        ),
        (
            base("", "")
                .replace("[\"x\", \"y\"]", "[\"x\", \"y\", \"w\"]")
                .replace("h = \"x*t*g/c\"", "h = \"x*t*g/c\"\nunused = \"w\""),
            vec!["parameters", "`w`"],
        ),
        // defines
        (
            base("", "").replace("h = \"x*t*g/c\"", "h = \"x*t*g/c*k\"\nk = \"1 + h\""),
            vec!["define.h", "circular definition h → k → h"],
        ),
        (
            base("", "").replace("h = \"x*t*g/c\"", "h = \"x*t*g/c\"\nk = \"k\""),
            vec!["define.k", "circular definition k → k"],
        ),
        (
            base("", "").replace(
                "h = \"x*t*g/c\"",
                "h = \"x*t*g/c\"\nk = \"k2\"\nk2 = \"s*k3\"\nk3 = \"k\"",
            ),
            vec!["define.k", "circular definition k → k2 → k3 → k"],
        ),
        // syntax and size
        (
            base("", "i1 = \"(x + 1\""),
            vec!["coefficients.o12.i1", "missing `)`", "(x + 1"],
        ),
        (
            base("", "i1 = \"x^0.5\""),
            vec!["coefficients.o12.i1", "integer"],
        ),
        (
            base("", &format!("i1 = \"{}\"", vec!["x"; 300].join("+"))),
            vec!["coefficients.o12.i1", "too long", "512"],
        ),
        (
            base(
                "",
                &format!("i1 = \"{}x{}\"", "(1+".repeat(70), ")".repeat(70)),
            ),
            vec!["coefficients.o12.i1", "nests too deeply"],
        ),
    ];
    for (text, wants) in cases {
        let e = err(&text);
        assert!(e.starts_with("user model `bad`: "), "{e}");
        for w in wants {
            assert!(e.contains(w), "expected `{w}` in: {e}");
        }
    }
}

#[test]
fn schema_errors_come_from_serde() {
    let e = err(&base("", "").replace("value = 3", "value = 3, gian = 1"));
    assert!(e.contains("gian"), "{e}");
    let e = err(&base("", "").replace("kind = \"gain\"", "kind = \"integrator\""));
    assert!(e.contains("integrator"), "{e}");
    let e = err(&base("colour = \"red\"", ""));
    assert!(e.contains("colour"), "{e}");
}

#[test]
fn check_and_identifiability() {
    let m = from_toml(&base("", "").replace("tau = \"y\"", "tau = \"y - 1\"")).unwrap();
    m.check(&[1.0, 1.5]).unwrap();
    let e = m.check(&[1.0, 0.5]).unwrap_err();
    assert!(e.contains("blocks.t.tau") && e.contains("≥ 0"), "{e}");
    // a denominator whose root crosses into the right half-plane with θ: s² + (y − 1)s + 1
    let m = from_toml(&base("", "").replace(
        "{ kind = \"gain\", value = 3 }",
        "{ kind = \"rational\", num = [1], den = [1, \"y - 1\", 1] }",
    ))
    .unwrap();
    m.check(&[1.0, 1.5]).unwrap();
    let e = m.check(&[1.0, 0.5]).unwrap_err();
    assert!(
        e.contains("blocks.g.den") && e.contains("positive real part") && e.contains("at this θ"),
        "{e}"
    );
    assert!(m.check(&[f64::NAN, 1.5]).unwrap_err().contains("`x`"));
    assert!(m.check(&[1.0]).is_err());
    // y enters only as 0·y: used on paper, no effect on the coefficients
    let m = from_toml(
        &base("", "")
            .replace("tau = \"y\"", "tau = 0.1")
            .replace("o12 = \"1\"", "o12 = \"1 + 0*y\""),
    )
    .unwrap();
    let e = crate::model::check_identifiable(&m, &[1.0, 0.5], &[0.01, 0.1], 10.0).unwrap_err();
    assert!(
        e.contains("model `bad`") && e.contains("`y`") && !e.contains("`x`"),
        "{e}"
    );
    let m = from_toml(&base("", "")).unwrap();
    crate::model::check_identifiable(&m, &[1.0, 0.5], &[0.1], 10.0).unwrap();
    // at x = 0 the delay parameter y drops out of x·t
    let e = crate::model::check_identifiable(&m, &[0.0, 0.5], &[0.1, 1.0], 10.0).unwrap_err();
    assert!(e.contains("`y`") && !e.contains("`x`"), "{e}");
}

#[test]
fn definition_round_trips_through_toml() {
    let def = example_def();
    let text = toml::to_string(&def).unwrap();
    let back: UserModelDef = toml::from_str(&text).unwrap();
    assert_eq!(back, def);
}

#[test]
fn the_unit_table_gives_each_parameter_its_unit_and_names_a_wrong_key() {
    let m = from_toml(&base("unit = { y = \"s\" }", "")).unwrap();
    assert_eq!(m.param_units(), ["", "s"]);
    let e = err(&base("unit = { z = \"s\" }", ""));
    assert!(
        e.contains("user model `bad`") && e.contains("unit.z") && e.contains("parameters = [x, y]"),
        "{e}"
    );
    let e = err(&base("unit = { x = \"a\\nb\" }", ""));
    assert!(e.contains("unit.x") && e.contains("one line"), "{e}");
}
