//! The `occam` command line.

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use occam::config::Study;
use std::path::PathBuf;
use std::time::Instant;

#[derive(Parser)]
#[command(
    name = "occam",
    version,
    about = "Bayesian model selection for LISA Pathfinder system identification"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Simulate a study's experiments and write a dataset (dataset.npz + dataset.json).
    Simulate {
        /// The study file (TOML).
        study: PathBuf,
        /// Output directory (overrides `output` in the study file).
        #[arg(short, long)]
        output: Option<PathBuf>,
    },
}

fn main() {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Simulate { study, output } => simulate(study, output),
    };
    if let Err(e) = result {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn simulate(path: PathBuf, output: Option<PathBuf>) -> Result<()> {
    let t0 = Instant::now();
    let study = Study::load(&path)?;
    let out = output.unwrap_or_else(|| study.output.clone());
    let sim = occam::experiment::simulate(&study)
        .with_context(|| format!("simulating {}", path.display()))?;
    let (npz, json) = sim.dataset.write(&out)?;
    println!(
        "{:<14} {:>10} {:>10} {:>12}",
        "experiment", "samples", "noise", "rho_opt"
    );
    for (e, rho) in sim.dataset.experiments.iter().zip(&sim.snr) {
        println!(
            "{:<14} {:>10} {:>10} {:>12.4e}",
            e.name,
            e.o[0].len(),
            e.noise[0].len(),
            rho
        );
    }
    println!(
        "study rho_opt = {:.4e} over {:?} Hz (amplitude factor {:.4e})",
        sim.snr_total, study.simulation.snr_band, sim.amplitude_factor
    );
    println!("wrote {} and {}", npz.display(), json.display());
    println!("took {:.2} s", t0.elapsed().as_secs_f64());
    Ok(())
}
