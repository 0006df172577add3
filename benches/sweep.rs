//! Benchmark: a 2-D design sweep with full model selection at every point, and the sweep's
//! parallel efficiency from 1 to 2 workers.
//!
//! The study is `examples/design-frequency.toml` (X = 4 parameters against Y = 5, every
//! estimator including parallel tempering with the file's 12 rungs) on a grid of the x1
//! injection frequency (1e-4–1 Hz) × ρ_opt (10–1000), one realisation per point.
//!
//! `cargo bench --bench sweep` runs the `SWEEP_BENCH_N` × `SWEEP_BENCH_N` grid (default 20) on
//! 2 workers and prints its wall time, then the first `SWEEP_BENCH_EFF` tasks (default 24) on 1
//! and on 2 workers, side by side, and the parallel efficiency T₁ / (2 T₂). Each run writes into
//! a fresh temporary directory, so nothing is reused. `SWEEP_BENCH_CROSS_CHECKS=light` (or
//! `off`) sets every task's `[select] cross_checks`.

use occam::jobs::exec::Threads;
use occam::jobs::sweep::grid::parse_axis;
use occam::jobs::sweep::{Sweep, SweepArgs};
use std::path::Path;
use std::time::Instant;

fn env(name: &str, default: usize) -> usize {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn plan(n_freq: usize, n_snr: usize, out: &Path) -> Result<Sweep, Box<dyn std::error::Error>> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let file = root.join("examples/design-frequency.toml");
    let text = std::fs::read_to_string(&file)?;
    // `SWEEP_BENCH_CROSS_CHECKS=light` (or `off`): every task's `[select] cross_checks`
    let select = std::env::var("SWEEP_BENCH_CROSS_CHECKS")
        .map(|c| vec![("cross_checks", toml::Value::String(c))])
        .unwrap_or_default();
    let args = SweepArgs {
        axes: Some(vec![
            parse_axis(&format!("experiment.scan.x1.freq=log:1e-4:1:{n_freq}"))?,
            parse_axis(&format!("simulation.target_snr=log:10:1000:{n_snr}"))?,
        ]),
        realisations: Some(1),
        output: Some(out.to_path_buf()),
        select,
        ..Default::default()
    };
    Ok(Sweep::from_text(
        &text,
        &file.display().to_string(),
        &root.join("examples"),
        args,
    )?)
}

fn timed(s: &Sweep, workers: usize) -> Result<f64, Box<dyn std::error::Error>> {
    let t0 = Instant::now();
    let r = s
        .run(&Threads::new(workers)?, false)?
        .ok_or("the thread executor is always the root")?;
    let failed: usize = r.points.iter().map(|p| p.failed).sum();
    if failed > 0 {
        return Err(format!("{failed} task(s) failed").into());
    }
    Ok(t0.elapsed().as_secs_f64())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let n = env("SWEEP_BENCH_N", 20);
    let n_eff = env("SWEEP_BENCH_EFF", 24);
    let dir = tempfile::tempdir()?;

    // efficiency: the same tasks (a 6 × k slice of the grid) on 1 and on 2 workers
    let k = n_eff.div_ceil(6).max(1);
    let small = |name: &str| plan(6, k, &dir.path().join(name));
    let t1 = timed(&small("eff1")?, 1)?;
    let t2 = timed(&small("eff2")?, 2)?;
    println!(
        "{} tasks: 1 worker {t1:.1} s, 2 workers {t2:.1} s; speed-up {:.2}, parallel efficiency {:.0} %",
        6 * k,
        t1 / t2,
        100.0 * t1 / (2.0 * t2)
    );

    let s = plan(n, n, &dir.path().join("grid"))?;
    let t = timed(&s, 2)?;
    println!(
        "{n} × {n} grid ({} tasks, full model selection each, cross-checks {}) on 2 workers: {t:.1} s ({:.2} s per task)",
        s.task_count(),
        std::env::var("SWEEP_BENCH_CROSS_CHECKS").unwrap_or_else(|_| "full".into()),
        t / s.task_count() as f64
    );
    Ok(())
}
