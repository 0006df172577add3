//! Cost of MVE/MCD on chains that barely move: 10 000 rows in 7-D with 40, 400 and 10 000
//! distinct values (a chain stuck for 250, 25 and 1 steps at a time).
//!
//!   cargo run --release --example robust_sticky

use nalgebra::DMatrix;
use occam::evidence::robust::{McdOptions, MveOptions, mcd, mve};
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};
use rand_xoshiro::Xoshiro256PlusPlus;

fn main() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(1);
    let draws = DMatrix::<f64>::from_fn(10_000, 7, |_, _| StandardNormal.sample(&mut rng));
    for distinct in [40usize, 400, 10_000] {
        let stay = 10_000 / distinct;
        let x = DMatrix::from_fn(10_000, 7, |i, j| draws[(i / stay, j)]);
        let t0 = std::time::Instant::now();
        let r = mve(&x, &MveOptions::default());
        let t_mve = t0.elapsed().as_secs_f64();
        let t0 = std::time::Instant::now();
        let s = mcd(&x, &McdOptions::default());
        let t_mcd = t0.elapsed().as_secs_f64();
        let show =
            |r: &Result<occam::evidence::RobustCovariance, occam::evidence::EvidenceError>| match r
            {
                Ok(c) => format!("var[0] = {:.3}, inliers {}", c.cov[(0, 0)], c.n_inliers),
                Err(e) => e.to_string(),
            };
        println!(
            "{distinct} distinct: MVE {t_mve:.3} s ({}); MCD {t_mcd:.3} s ({})",
            show(&r),
            show(&s)
        );
    }
}
