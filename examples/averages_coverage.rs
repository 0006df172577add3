//! Coverage of the 1σ posterior interval against the number of Welch averages behind the
//! noise reference (issue 22, "Few averages"), for the Whittle, Student-t and Wishart
//! statistics, on the toy of `src/likelihood/statistic_tests.rs`: a gain `a` between a white
//! known input and an output with AR(1) noise (pole 0.9), 4096 samples at 1 Hz, band
//! [0.02, 0.45] Hz, and a noise-only stretch of 4096 samples averaged with M = 1, 2, 4, 8, 32
//! BH92 segments (M_eff from Percival & Walden eq. 292b).
//!
//! Per (statistic, M) over N realisations: the fraction whose central 68.27 % posterior
//! interval (uniform prior, posterior on a grid) contains the truth, against 0.683 ± 3
//! binomial sd (`!` outside), the law `2Φ(1/√(1 + 1/M_eff)) − 1` of the per-bin marginals
//! (module docs of `occam::likelihood::statistic`), and the bias, the mean of
//! (posterior mean − truth)/(posterior sd) (standard error ≈ 1/√N).
//!
//!   cargo run --release --example averages_coverage -- 200

use num_complex::{Complex, Complex64};
use num_dual::Dual64;
use occam::data::dataset::ExperimentData;
use occam::likelihood::{
    ExperimentSpectra, Likelihood, LogPeriodogramOptions, SpectraOptions, Statistic, fisher_exact,
};
use occam::model::{Bin, Model};
use occam::prior::{Prior, PriorKind};
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use rand_xoshiro::Xoshiro256PlusPlus;
use rayon::prelude::*;
use std::f64::consts::PI;
use std::sync::Arc;

const COVER: f64 = 0.6827;
const TAU: usize = 3;

/// `r = o − a e^{−i2πfτ} i`.
#[derive(Debug)]
struct Toy {
    names: Vec<String>,
    data: Vec<String>,
    res: Vec<String>,
}

impl Model for Toy {
    fn name(&self) -> &str {
        "toy"
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
    fn coefficients(&self, th: &[f64], b: &Bin, out: &mut [Complex64]) {
        let p = 2.0 * PI * b.f * TAU as f64;
        out[0] = Complex64::new(1.0, 0.0);
        out[1] = Complex64::new(-th[0] * p.cos(), th[0] * p.sin());
    }
    fn coefficients_dual(&self, th: &[Dual64], b: &Bin, out: &mut [Complex<Dual64>]) {
        let p = 2.0 * PI * b.f * TAU as f64;
        out[0] = Complex::new(Dual64::from(1.0), Dual64::from(0.0));
        out[1] = Complex::new(-th[0] * p.cos(), th[0] * p.sin());
    }
}

fn toy_data(seed: u64, n: usize, a: f64) -> ExperimentData {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let mut z = || -> f64 { StandardNormal.sample(&mut rng) };
    let mut x = 0.0;
    let mut noise: Vec<f64> = (0..2 * n + 500)
        .map(|_| {
            x = 0.9 * x + z();
            x
        })
        .collect();
    noise.drain(..500);
    let fit_noise = noise.split_off(n);
    let i: Vec<f64> = (0..n).map(|_| 0.3 * z()).collect();
    let o: Vec<f64> = (0..n)
        .map(|t| a * i[(t + n - TAU) % n] + fit_noise[t])
        .collect();
    ExperimentData {
        name: "toy".into(),
        fs: 1.0,
        o: [o, Vec::new()],
        i: [i, Vec::new()],
        noise: [noise, Vec::new()],
        extra: Default::default(),
        noise_extra: Default::default(),
        gaps: Vec::new(),
        noise_gaps: Vec::new(),
        known_in_gaps: Vec::new(),
    }
}

/// (covered, pull of the posterior mean, M_eff) of one realisation.
fn realisation(stat: Statistic, averages: usize, seed: u64) -> (bool, f64, f64) {
    let (n, a0) = (4096, 1.0);
    let e = toy_data(seed, n, a0);
    let model: Arc<dyn Model> = Arc::new(Toy {
        names: vec!["a".into()],
        data: vec!["o1".into(), "i1".into()],
        res: vec!["o1".into()],
    });
    let opts = SpectraOptions {
        band: [0.02, 0.45],
        welch_averages: averages,
        ..Default::default()
    };
    let sp = ExperimentSpectra::new(&e, &opts, model.as_ref(), &[1.0], None).unwrap();
    let m_eff = 0.5 * sp.noise_dof.unwrap();
    let prior = Prior::new(
        vec!["a".into()],
        vec![PriorKind::Uniform {
            lo: -10.0,
            hi: 10.0,
        }],
    )
    .unwrap();
    let lik = Likelihood::new(model, vec![sp], prior)
        .unwrap()
        .with_statistic(
            stat,
            &LogPeriodogramOptions::default(),
            std::slice::from_ref(&e),
        )
        .unwrap();
    let sigma = 1.0 / fisher_exact(&lik, &[a0], &[0])[(0, 0)].sqrt();
    // the Whittle ln L is quadratic in a: centre the grid on its maximum
    let lw = |a: f64| lik.ln_likelihood_whittle(&[a]);
    let (lm, l0, lp) = (lw(a0 - sigma), lw(a0), lw(a0 + sigma));
    let centre = a0 + sigma * 0.5 * (lp - lm) / (2.0 * l0 - lp - lm);
    let g = 801;
    let mut w = 12.0;
    let (grid, p) = loop {
        let grid: Vec<f64> = (0..g)
            .map(|j| centre + sigma * w * (-1.0 + 2.0 * j as f64 / (g - 1) as f64))
            .collect();
        let ll: Vec<f64> = grid.iter().map(|&a| lik.ln_likelihood_full(&[a])).collect();
        let mx = ll.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        let p: Vec<f64> = ll.iter().map(|l| (l - mx).exp()).collect();
        if (p[0] < 1e-6 && p[g - 1] < 1e-6) || w > 1e6 {
            break (grid, p);
        }
        w *= 2.0;
    };
    let total: f64 = p.iter().sum();
    let mean = grid.iter().zip(&p).map(|(a, p)| a * p).sum::<f64>() / total;
    let var = grid
        .iter()
        .zip(&p)
        .map(|(a, p)| (a - mean).powi(2) * p)
        .sum::<f64>()
        / total;
    let below = grid
        .iter()
        .zip(&p)
        .map(|(&a, &p)| if a < a0 { p } else { 0.0 })
        .sum::<f64>()
        / total;
    let lo = 0.5 * (1.0 - COVER);
    (
        (lo..=1.0 - lo).contains(&below),
        (mean - a0) / var.sqrt(),
        m_eff,
    )
}

fn main() {
    let n: u64 = std::env::args()
        .nth(1)
        .map(|s| s.parse().expect("number of realisations"))
        .unwrap_or(200);
    let sd = (COVER * (1.0 - COVER) / n as f64).sqrt();
    println!(
        "{n} realisations per row; 1σ coverage target {COVER:.3} ± {:.3} (3 binomial sd)",
        3.0 * sd
    );
    println!("   M  M_eff  statistic   1σ coverage   law   bias (σ)");
    for m in [1usize, 2, 4, 8, 32] {
        for stat in [Statistic::Whittle, Statistic::StudentT, Statistic::Wishart] {
            let out: Vec<_> = (0..n)
                .into_par_iter()
                .map(|s| realisation(stat, m, 1000 + s))
                .collect();
            let c = out.iter().filter(|o| o.0).count() as f64 / n as f64;
            let bias = out.iter().map(|o| o.1).sum::<f64>() / n as f64;
            let m_eff = out[0].2;
            let law = if stat == Statistic::Whittle {
                "   —  ".to_string()
            } else {
                format!(
                    "{:.3} ",
                    statrs::function::erf::erf(1.0 / (2.0 * (1.0 + 1.0 / m_eff)).sqrt())
                )
            };
            let flag = if (c - COVER).abs() > 3.0 * sd {
                "!"
            } else {
                " "
            };
            println!(
                "{m:4} {m_eff:6.2}  {:<10}  {c:.3}{flag}       {law} {bias:+.3}",
                stat.name()
            );
        }
    }
}
