use super::*;
use crate::evidence::coverage_check::assert_nominal_coverage;
use crate::evidence::normal::interval;
use crate::prior::{Prior, PriorKind};
use rand::{RngExt, SeedableRng};
use rand_distr::Exp1;
use rand_xoshiro::Xoshiro256PlusPlus;

/// A log-likelihood of the parameters.
type LnL = Box<dyn Fn(&[f64]) -> f64 + Sync>;

/// `ln L(θ)` on a uniform prior over a box.
struct Target {
    prior: Prior,
    ln_l: LnL,
}

impl LogDensity for Target {
    fn ln_likelihood(&self, theta: &[f64]) -> f64 {
        (self.ln_l)(theta)
    }
    fn prior(&self) -> &Prior {
        &self.prior
    }
}

fn boxed(bounds: &[(f64, f64)], ln_l: LnL) -> Target {
    Target {
        prior: Prior::new(
            (0..bounds.len()).map(|i| format!("p{i}")).collect(),
            bounds
                .iter()
                .map(|&(lo, hi)| PriorKind::Uniform { lo, hi })
                .collect(),
        )
        .unwrap(),
        ln_l,
    }
}

/// The rows `x = A y` maps to independent log-exponential variables: `ln L(y) = Σ xᵢ − e^{xᵢ}`,
/// skewed (a long left tail, a right tail far lighter than a Gaussian's) and correlated, with
/// `∫ L dy = 1/|det A|`.
const A: [[f64; 3]; 3] = [[1.0, 0.6, 0.0], [0.0, 1.0, -0.4], [0.3, 0.0, 1.0]];
fn a_matrix() -> nalgebra::Matrix3<f64> {
    nalgebra::Matrix3::from_fn(|i, j| A[i][j])
}

fn a_inv(x: &[f64; 3]) -> [f64; 3] {
    let y = a_matrix().try_inverse().unwrap() * nalgebra::Vector3::from_column_slice(x);
    [y[0], y[1], y[2]]
}

fn skewed() -> (Target, f64) {
    let t = boxed(
        &[(-40.0, 40.0); 3],
        Box::new(|y| {
            (0..3)
                .map(|i| {
                    let x: f64 = (0..3).map(|j| A[i][j] * y[j]).sum();
                    x - x.exp()
                })
                .sum()
        }),
    );
    (t, -a_matrix().determinant().abs().ln() - 3.0 * 80f64.ln())
}

/// A standard Gaussian likelihood in 2-D on the box `[lo, hi]²`, with its `ln Z`.
fn gauss_in_box(lo: f64, hi: f64) -> (Target, f64) {
    let t = boxed(
        &[(lo, hi); 2],
        Box::new(|th| -0.5 * (th[0] * th[0] + th[1] * th[1])),
    );
    let ln_z =
        (2.0 * std::f64::consts::PI).ln() + 2.0 * interval(lo, hi).ln() - 2.0 * (hi - lo).ln();
    (t, ln_z)
}

/// Two chains of `n` draws each, every distinct draw repeated `repeat` times (a chain that
/// moves once every `repeat` iterations), `draw` giving independent posterior draws.
fn chains_of(
    t: &Target,
    n: usize,
    repeat: usize,
    rng: &mut Xoshiro256PlusPlus,
    draw: &dyn Fn(&mut Xoshiro256PlusPlus) -> Vec<f64>,
) -> Vec<(Vec<f64>, Vec<f64>)> {
    (0..2)
        .map(|_| {
            let (mut s, mut lp) = (Vec::new(), Vec::new());
            while lp.len() < n {
                let th = draw(rng);
                let l = t.ln_posterior(&th);
                for _ in 0..repeat.min(n - lp.len()) {
                    s.extend_from_slice(&th);
                    lp.push(l);
                }
            }
            (s, lp)
        })
        .collect()
}

fn try_estimate(
    t: &Target,
    ch: &[(Vec<f64>, Vec<f64>)],
    seed: u64,
) -> Result<BridgeSamplingEstimate, EvidenceError> {
    let draws: Vec<PosteriorDraws<'_>> = ch
        .iter()
        .map(|(s, lp)| PosteriorDraws {
            samples: s,
            ln_posterior: lp,
        })
        .collect();
    bridge_sampling(t, &draws, seed)
}

fn estimate(t: &Target, ch: &[(Vec<f64>, Vec<f64>)], seed: u64) -> BridgeSamplingEstimate {
    try_estimate(t, ch, seed).unwrap()
}

fn skewed_draw(rng: &mut Xoshiro256PlusPlus) -> Vec<f64> {
    let x: [f64; 3] = std::array::from_fn(|_| {
        let e: f64 = Exp1.sample(rng);
        e.ln()
    });
    a_inv(&x).to_vec()
}

/// A standard normal truncated to `[lo, hi]` in each of two coordinates (by rejection).
fn truncated_draw(lo: f64, hi: f64) -> impl Fn(&mut Xoshiro256PlusPlus) -> Vec<f64> {
    move |rng| {
        (0..2)
            .map(|_| {
                loop {
                    let v: f64 = StandardNormal.sample(rng);
                    if (lo..=hi).contains(&v) {
                        break v;
                    }
                }
            })
            .collect()
    }
}

/// The stated errors cover the exact `ln Z` at the nominal rate over 200 seeds in each of four
/// cases where a shortcut would break: a skewed, correlated posterior (where the reciprocal
/// identity's terms have no variance); the same drawn by chains that move once in ten
/// iterations (the error must grow by the autocorrelation); a posterior wider than its prior
/// box (most draws from the fitted Gaussian fall outside); a MAP on a corner of the box. The
/// 800 intervals pooled would fail with errors 20 % off ([`assert_nominal_coverage`]); each
/// case on its own shows no bias beyond 3 of its errors over the seeds.
#[test]
fn the_errors_cover_the_exact_evidence_at_the_edges() {
    let seeds = 200;
    let (sk, sk_z) = skewed();
    let (wide, wide_z) = gauss_in_box(-0.4, 0.4);
    let (corner, corner_z) = gauss_in_box(0.0, 3.0);
    let wide_draw = truncated_draw(-0.4, 0.4);
    let corner_draw = truncated_draw(0.0, 3.0);
    type Case<'a> = (
        &'a str,
        &'a Target,
        f64,
        usize,
        usize,
        &'a dyn Fn(&mut Xoshiro256PlusPlus) -> Vec<f64>,
    );
    let cases: [Case<'_>; 4] = [
        ("skewed", &sk, sk_z, 2000, 1, &skewed_draw),
        ("skewed, sticky chains", &sk, sk_z, 4000, 10, &skewed_draw),
        ("wider than the box", &wide, wide_z, 2000, 1, &wide_draw),
        ("MAP on a corner", &corner, corner_z, 2000, 1, &corner_draw),
    ];
    let mut pooled = Vec::new();
    let mut mean_err = Vec::new();
    for (name, t, truth, n, repeat, draw) in cases {
        let z: Vec<f64> = (0..seeds)
            .map(|s| {
                let mut rng = Xoshiro256PlusPlus::seed_from_u64(1000 + s);
                let ch = chains_of(t, n, repeat, &mut rng, draw);
                let b = estimate(t, &ch, 77 + s);
                (b.ln_z - truth) / b.std_err
            })
            .collect();
        let mean = z.iter().sum::<f64>() / seeds as f64;
        let cover = z.iter().filter(|v| v.abs() < 1.0).count() as f64 / seeds as f64;
        println!("{name}: mean z {mean:+.3}, coverage {cover:.3}");
        assert!(
            mean.abs() < 3.0 / (seeds as f64).sqrt(),
            "{name}: bias {mean}"
        );
        assert!((0.55..0.81).contains(&cover), "{name}: coverage {cover}");
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(5);
        let ch = chains_of(t, n, repeat, &mut rng, draw);
        mean_err.push(estimate(t, &ch, 5).std_err);
        pooled.extend(z);
    }
    assert_nominal_coverage("bridge sampling, four cases", &pooled);
    // chains ten times stickier: the posterior side's ESS is a tenth, so the error is larger
    // although there are twice the draws (measured 1.54×; without the ESS it would shrink)
    assert!(mean_err[1] > 1.3 * mean_err[0], "{mean_err:?}");
}

/// The same seed gives the same number whatever the threads; another seed another one.
#[test]
fn the_number_does_not_depend_on_the_threads() {
    let (t, _) = skewed();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(9);
    let ch = chains_of(&t, 1000, 1, &mut rng, &skewed_draw);
    let run = |threads: usize, seed: u64| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| estimate(&t, &ch, seed))
    };
    assert_eq!(run(1, 3), run(3, 3));
    assert_ne!(run(1, 3).ln_z, run(1, 4).ln_z);
}

/// Inputs it cannot use are refused with the reason, never a number.
#[test]
fn what_it_cannot_use_it_says() {
    let (t, _) = gauss_in_box(-3.0, 3.0);
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(2);
    let draw = truncated_draw(-3.0, 3.0);
    let ch = chains_of(&t, 40, 1, &mut rng, &draw);
    let draws = |ch: &[(Vec<f64>, Vec<f64>)]| -> Vec<(Vec<f64>, Vec<f64>)> { ch.to_vec() };
    let run = |ch: &[(Vec<f64>, Vec<f64>)]| try_estimate(&t, ch, 1);
    assert!(run(&ch).is_ok());
    // too few draws
    let mut few = draws(&ch);
    for (s, lp) in &mut few {
        s.truncate(10);
        lp.truncate(5);
    }
    let e = run(&few).unwrap_err().to_string();
    assert!(e.contains("run a longer chain"), "{e}");
    // chains of different lengths
    let mut uneven = draws(&ch);
    uneven[1].0.truncate(60);
    uneven[1].1.truncate(30);
    assert!(matches!(run(&uneven), Err(EvidenceError::Dimension { .. })));
    // a parameter that never moved
    let mut stuck = draws(&ch);
    for (s, _) in &mut stuck {
        s.chunks_mut(2).for_each(|r| r[1] = 0.5);
    }
    let e = run(&stuck).unwrap_err().to_string();
    assert!(
        e.contains("singular") && e.contains("`p1` never moved"),
        "{e}"
    );
    // a draw where the density is zero
    let mut outside = draws(&ch);
    outside[0].1[3] = f64::NEG_INFINITY;
    let e = run(&outside).unwrap_err().to_string();
    assert!(e.contains("not finite"), "{e}");
    // no chains, no parameters
    assert!(run(&[]).is_err());
    let _ = rng.random::<f64>();
}

/// An LTP-sized `ln Z` (~2.5·10⁶, where doubles are 5·10⁻¹⁰ apart) converges, and to the
/// same number as the unshifted problem, shifted.
#[test]
fn an_ltp_sized_evidence_converges() {
    let offset = 2_534_018.8;
    let (t, _) = gauss_in_box(0.0, 3.0);
    let shifted = boxed(
        &[(0.0, 3.0); 2],
        Box::new(move |th| offset - 0.5 * (th[0] * th[0] + th[1] * th[1])),
    );
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(4);
    let draw = truncated_draw(0.0, 3.0);
    let ch = chains_of(&t, 2000, 1, &mut rng, &draw);
    let up: Vec<(Vec<f64>, Vec<f64>)> = ch
        .iter()
        .map(|(s, lp)| (s.clone(), lp.iter().map(|l| l + offset).collect()))
        .collect();
    let (a, b) = (estimate(&t, &ch, 8), estimate(&shifted, &up, 8));
    assert!((b.ln_z - a.ln_z - offset).abs() < 1e-6, "{a:?} {b:?}");
    assert!(
        (b.std_err - a.std_err).abs() < 1e-6 * a.std_err,
        "{a:?} {b:?}"
    );
}
