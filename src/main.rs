//! The `occam` command line.

use anyhow::{Context as _, Result};
use clap::{Parser, Subcommand};
use occam::config::Study;
use occam::jobs::progress::{Bar, HintWatch, Work};
use occam::jobs::{Context, execute};
use std::path::{Path, PathBuf};
use std::sync::Arc;
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
        /// Also write each experiment as CSV (`<experiment>.csv`, `<experiment>_noise.csv`:
        /// a time column `t` and the channels), the form `[[experiment]] data = "…"` reads.
        #[arg(long)]
        csv: bool,
        #[command(flatten)]
        run: RunFlags,
    },
    /// Fit the study's `[fit]` model by MCMC: Table I layout, chains, plots, summary.json.
    Fit {
        /// The study file (TOML).
        study: PathBuf,
        /// Output directory (default: `<output>/fit`).
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Continue from the checkpoint in the output directory (an error when there is none).
        #[arg(long)]
        resume: bool,
        #[command(flatten)]
        run: RunFlags,
    },
    /// The paper's guidance-delay investigation (7- against 5-parameter model, data with
    /// Δt1 = Δt2 = 0) in its competitive and non-competitive regimes, from built-in studies.
    Demo {
        /// Output directory.
        #[arg(short, long, default_value = "runs/demo")]
        output: PathBuf,
        #[command(flatten)]
        run: RunFlags,
    },
    /// Model selection over a grid of study keys (`[sweep]` or `--axis`) with noise
    /// realisations per point: ln B of every estimator, its band over realisations, how often
    /// each model is picked (the paper's Fig. 5 and 6). Finished points are kept in the run
    /// directory and skipped on a rerun.
    Sweep(SweepCli),
    /// Bayes factors between the study's `[[select.model]]` models with every estimator.
    Select {
        /// The study file (TOML).
        study: PathBuf,
        /// Output directory (default: `<output>/select`).
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Continue from the checkpoint in the output directory (an error when there is none):
        /// finished stages are not recomputed and the numbers equal an uninterrupted run's.
        #[arg(long)]
        resume: bool,
        #[command(flatten)]
        sizing: SelectFlags,
        #[command(flatten)]
        run: RunFlags,
    },
    /// Write a commented starting study to edit: `closed-loop`, `user-model`, `own-data` or
    /// `sweep` (without KIND: the list).
    Init {
        /// The kind of study.
        kind: Option<String>,
        /// The file to write (default: KIND.toml in the working directory).
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Replace the file if it exists.
        #[arg(long)]
        force: bool,
    },
    /// Write a self-contained HTML page of a fit, select or sweep run: tables, figures,
    /// diagnostics, warnings and the resolved study (default RUN_DIR/report.html).
    Report {
        /// The run directory (the one a fit, select or sweep wrote).
        run_dir: PathBuf,
        /// The HTML file to write (default: RUN_DIR/report.html).
        #[arg(short, long)]
        output: Option<PathBuf>,
    },
    /// Choose the injections that best separate the `[[select.model]]` models under the
    /// `[design]` budget; writes design.toml (a runnable study), baseline.toml and design.json.
    Design {
        /// The study file (TOML) with `[[select.model]]` tables and a `[design]` table.
        study: PathBuf,
        /// Output directory (default: `<output>/design`).
        #[arg(short, long)]
        output: Option<PathBuf>,
        /// Noise realisations of full model selection for the chosen design and the baseline
        /// (without a number: `[design] realisations`).
        #[arg(long, num_args = 0..=1)]
        validate: Option<Option<usize>>,
        /// Worker threads (default: one per core). The numbers do not depend on it.
        #[arg(long, default_value_t = 0)]
        threads: usize,
    },
}

/// How long a model selection runs and how much its cross-checks get; each sets the
/// `[select]` key of the same name.
#[derive(clap::Args, Clone, Default)]
struct SelectFlags {
    /// Run the reversible jump until every pair's reference error of ln B is at most this
    /// (`[select] target_error`).
    #[arg(long)]
    target_error: Option<f64>,
    /// How much of the run the tempering cross-checks get: full, light or off
    /// (`[select] cross_checks`).
    #[arg(long, value_parser = ["full", "light", "off"])]
    cross_checks: Option<String>,
}

impl SelectFlags {
    /// The `[select]` keys the flags set.
    fn keys(&self) -> Vec<(&'static str, toml::Value)> {
        let mut k = Vec::new();
        if let Some(e) = self.target_error {
            k.push(("target_error", toml::Value::Float(e)));
        }
        if let Some(c) = &self.cross_checks {
            k.push(("cross_checks", toml::Value::String(c.clone())));
        }
        k
    }
}

/// Options every long-running command takes.
#[derive(clap::Args, Clone, Copy)]
struct RunFlags {
    /// No progress bar.
    #[arg(short, long)]
    quiet: bool,
    /// Worker threads (default: one per core). The numbers do not depend on it.
    #[arg(long, default_value_t = 0)]
    threads: usize,
}

impl RunFlags {
    /// Sizes the thread pool the samplers use.
    fn apply(&self) -> Result<()> {
        if self.threads > 0 {
            rayon::ThreadPoolBuilder::new()
                .num_threads(self.threads)
                .build_global()
                .context("--threads: cannot start the thread pool")?;
        }
        Ok(())
    }
}

fn main() {
    // Rust ignores SIGPIPE, so printing into a closed pipe (`occam fit … | head`) panicked;
    // the default action ends the process quietly, as other command-line tools do.
    #[cfg(unix)]
    // SAFETY: called once at start, before any thread exists; SIG_DFL is a valid handler.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Simulate {
            study,
            output,
            csv,
            run,
        } => run.apply().and_then(|_| simulate(study, output, csv, run)),
        Command::Fit {
            study,
            output,
            resume,
            run,
        } => run.apply().and_then(|_| fit(study, output, resume, run)),
        Command::Select {
            study,
            output,
            resume,
            sizing,
            run,
        } => run
            .apply()
            .and_then(|_| select(study, output, resume, &sizing, run)),
        Command::Demo { output, run } => run.apply().and_then(|_| demo(output, run)),
        Command::Sweep(cli) => sweep(cli),
        Command::Init {
            kind,
            output,
            force,
        } => init(kind.as_deref(), output.as_deref(), force),
        Command::Report { run_dir, output } => {
            occam::jobs::report::run(&run_dir, output.as_deref()).map(|p| {
                println!("wrote {}", p.display());
                // a study's output directory is its simulation's run and holds the others
                for r in occam::html::runs_inside(&run_dir) {
                    println!(
                        "{} is a run of its own: `occam report {}`",
                        r.display(),
                        r.display()
                    );
                }
            })
        }
        Command::Design {
            study,
            output,
            validate,
            threads,
        } => RunFlags {
            quiet: false,
            threads,
        }
        .apply()
        .and_then(|_| {
            on_interrupt(
                "`occam design` stopped before writing its outputs (a run directory is never half-written); run the same command again to start over".into(),
            );
            let r = occam::jobs::design::run_cli(&study, output, validate)?;
            println!("{}", occam::jobs::design::table(&r));
            Ok(())
        }),
    };
    if let Err(e) = result {
        eprintln!("error: {}", occam::jobs::error_text(&e));
        std::process::exit(1);
    }
}

fn init(kind: Option<&str>, output: Option<&Path>, force: bool) -> Result<()> {
    let Some(kind) = kind else {
        println!("occam init KIND writes a commented starting study; the kinds:");
        for (k, what, _) in occam::jobs::init::KINDS {
            println!("  {k:<12} {what}");
        }
        return Ok(());
    };
    let p = occam::jobs::init::write(kind, output, force)?;
    println!(
        "wrote {}: read its comments, edit it, then run the commands its first lines name",
        p.display()
    );
    let names = |v: &[PathBuf]| {
        v.iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join(", ")
    };
    let (written, kept) = occam::jobs::init::write_example_data(kind, &p, force)?;
    if !written.is_empty() {
        println!(
            "wrote {}: simulated measurements (the closed-loop starter's TN3045 experiments) so that the study runs as it is; replace them with yours",
            names(&written)
        );
    }
    if !kept.is_empty() {
        println!(
            "kept {}: they exist (--force replaces them with simulated example data)",
            names(&kept)
        );
    }
    Ok(())
}

fn simulate(path: PathBuf, output: Option<PathBuf>, csv: bool, flags: RunFlags) -> Result<()> {
    let t0 = Instant::now();
    let study = Study::load(&path)?;
    let out = output.unwrap_or_else(|| study.output.clone());
    on_interrupt(format!(
        "{} is left as it was (a run directory is never half-written); run `occam simulate {}` again",
        out.display(),
        path.display()
    ));
    let work = Arc::new(Work::default());
    let bar = Bar::start(work.clone(), "experiments", flags.quiet);
    let ctx = Context {
        work: Some(&work),
        ..Context::quiet(&out, false)
    };
    let done = execute(
        &mut occam::jobs::simulate::Simulate { study: &study, csv },
        &ctx,
    )?;
    if let Some(b) = bar {
        b.finish();
    }
    let (sim, written) = (done.outcome, done.written);
    println!(
        "{:<14} {:>10} {:>10} {:>12}",
        "experiment", "samples", "noise", "rho_opt"
    );
    for (e, rho) in sim.dataset.experiments.iter().zip(&sim.snr) {
        println!(
            "{:<14} {:>10} {:>10} {:>12.4e}",
            e.name,
            e.n_samples(),
            e.n_noise_samples(),
            rho
        );
    }
    let def = study.simulation.snr_definition;
    let on_scale = match def {
        occam::experiment::SnrDefinition::Optimal => String::new(),
        _ => format!(
            " (= {:.4} as snr_definition = \"{}\")",
            def.from_optimal(sim.snr_total),
            def.name()
        ),
    };
    println!(
        "study rho_opt = {:.4e}{on_scale} over {:?} Hz (amplitude factor {:.4e})",
        sim.snr_total, study.simulation.snr_band, sim.amplitude_factor
    );
    println!("wrote {}", listing(&out, &written));
    println!("took {:.2} s", t0.elapsed().as_secs_f64());
    Ok(())
}

/// On Ctrl-C: says what the run kept and how to continue, then exits with 130 (128 + SIGINT,
/// as shells expect). Checkpoints are written atomically, so stopping at any instant is safe.
fn on_interrupt(what: String) {
    // one handler per process: a command sets it once
    let _ = ctrlc::set_handler(move || {
        eprintln!("\ninterrupted: {what}");
        std::process::exit(130);
    });
}

/// What `fit` or `select` keeps when interrupted, and the command that continues it.
fn resume_hint(command: &str, study: &Path, out: &Path) -> String {
    format!(
        "{} keeps the checkpoint of the work done; continue with `occam {command} {} -o {} --resume`",
        out.display(),
        study.display(),
        out.display()
    )
}

/// `dir/{a, b, …}`: the files a run published.
fn listing(dir: &Path, names: &[String]) -> String {
    format!("{}/{{{}}}", dir.display(), names.join(", "))
}

fn fit(path: PathBuf, output: Option<PathBuf>, resume: bool, flags: RunFlags) -> Result<()> {
    let t0 = Instant::now();
    let study = Study::load(&path)?;
    let out = output.unwrap_or_else(|| study.output.join("fit"));
    on_interrupt(resume_hint("fit", &path, &out));
    let work = Arc::new(Work::default());
    let bar = Bar::start(work.clone(), "iterations", flags.quiet);
    let _hint = HintWatch::start(
        work.clone(),
        "fit",
        "iterations",
        "[fit] chains and iterations set the length",
        flags.quiet,
        bar.as_ref(),
    );
    let say = |line: &str| match &bar {
        Some(b) => b.bar().println(line),
        None => println!("{line}"),
    };
    let ctx = Context {
        out: &out,
        resume,
        log: &say,
        work: Some(&work),
    };
    let done = execute(&mut occam::jobs::fit::Fit { study: &study }, &ctx)?;
    if let Some(b) = bar {
        b.finish();
    }
    let (outcome, written) = (done.outcome.outcome, done.written);
    let s = &outcome.summary;
    for line in occam::jobs::fit::console(s, &study) {
        println!("{line}");
    }
    // each note as it is: they differ per experiment, and are few
    for n in &s.notes {
        println!("note: {n}");
    }
    for w in occam::report::group_warnings(&s.warnings) {
        eprintln!("warning: {w}");
    }
    println!("wrote {}", listing(&out, &written));
    println!("took {:.1} s", t0.elapsed().as_secs_f64());
    Ok(())
}

fn select(
    path: PathBuf,
    output: Option<PathBuf>,
    resume: bool,
    sizing: &SelectFlags,
    flags: RunFlags,
) -> Result<()> {
    let study = Study::load_with_select(&path, &sizing.keys())?;
    let out = output.unwrap_or_else(|| study.output.join("select"));
    let mut hint = resume_hint("select", &path, &out);
    if let Some(e) = sizing.target_error {
        hint = hint.replace(" --resume`", &format!(" --target-error {e} --resume`"));
    }
    if let Some(c) = &sizing.cross_checks {
        hint = hint.replace(" --resume`", &format!(" --cross-checks {c} --resume`"));
    }
    on_interrupt(hint);
    run_select(&study, &out, resume, flags.quiet)
}

fn run_select(study: &Study, out: &std::path::Path, resume: bool, quiet: bool) -> Result<()> {
    let t0 = Instant::now();
    let work = Arc::new(Work::default());
    let bar = Bar::start(work.clone(), "ln L evaluations", quiet);
    let _hint = HintWatch::start(
        work.clone(),
        "select",
        "ln L evaluations",
        "[select] iterations, pt_iterations and rj_iterations set the length; --cross-checks light or off shortens the tempering",
        quiet,
        bar.as_ref(),
    );
    let say = |line: &str| match &bar {
        Some(b) => b.bar().println(line),
        None => println!("{line}"),
    };
    let mut on_rj = |p: &occam::evidence::RjProgress<'_>| {
        if let Some(b) = &bar {
            b.bar().set_message(format!("RJ visits {:?}", p.visits));
        }
    };
    let ctx = Context {
        out,
        resume,
        log: &say,
        work: Some(&work),
    };
    let mut job = occam::jobs::select::Select {
        study,
        on_rj: Some(&mut on_rj),
    };
    let done = execute(&mut job, &ctx)?;
    if let Some(b) = bar {
        b.finish();
    }
    let (s, written) = (done.outcome, done.written);
    println!("{}", occam::jobs::select::console(&s));
    for n in &s.notes {
        println!("note: {n}");
    }
    for w in occam::report::group_warnings(&s.warnings) {
        eprintln!("warning: {w}");
    }
    println!("wrote {}", listing(out, &written));
    println!("took {:.1} s", t0.elapsed().as_secs_f64());
    Ok(())
}

fn demo(output: PathBuf, flags: RunFlags) -> Result<()> {
    let t0 = Instant::now();
    on_interrupt(format!(
        "the demo's finished studies are in {}; `occam demo` starts over when run again (about a minute on two cores)",
        output.display()
    ));
    for (name, study) in occam::jobs::demo::studies()? {
        println!("\n=== guidance delays, {name} regime ===");
        run_select(&study, &output.join(name), false, flags.quiet)?;
    }
    println!("\ndemo took {:.1} s", t0.elapsed().as_secs_f64());
    Ok(())
}

/// `occam sweep`'s options.
#[derive(clap::Args)]
struct SweepCli {
    /// The study file (TOML) with `[[select.model]]` tables.
    study: PathBuf,
    /// An axis, replacing `[[sweep.axis]]`: `KEY=v1,v2,…`, `KEY=log:FROM:TO:N` or
    /// `KEY=lin:FROM:TO:N` (KEY a dotted study key, e.g. `experiment.inv1.x1.freq`);
    /// repeat for a 2-D grid.
    #[arg(long = "axis")]
    axis: Vec<String>,
    /// Shorthand for `--axis simulation.target_snr=…` (ρ_opt values).
    #[arg(long, value_delimiter = ',')]
    snr: Option<Vec<f64>>,
    /// Noise realisations per point (default: `[sweep] realisations`, else 1).
    #[arg(long)]
    realisations: Option<usize>,
    /// The `[[select.model]]` that generated the data.
    #[arg(long)]
    truth: Option<String>,
    /// Worker threads (default: one per core; under `mpirun`, threads per rank, default 1).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Output directory (default: `<output>/sweep`).
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Say what is resumed, and stop when the run directory holds no finished task of this
    /// sweep. (Finished tasks are reused with or without it.)
    #[arg(long)]
    resume: bool,
    /// No progress bar and no per-task lines.
    #[arg(short, long)]
    quiet: bool,
    #[command(flatten)]
    sizing: SelectFlags,
}

fn sweep(cli: SweepCli) -> Result<()> {
    use occam::jobs::sweep::{SweepRequest, executor, plan, run_request};
    let t0 = Instant::now();
    let exec = executor(cli.threads)?;
    let req = SweepRequest {
        study: cli.study,
        axes: cli.axis,
        snr: cli.snr,
        realisations: cli.realisations,
        truth: cli.truth,
        output: cli.output,
        resume: cli.resume,
        select: cli.sizing.keys(),
    };
    let planned = plan(&req, exec.as_ref())?;
    let out = planned.sweep.out.clone();
    on_interrupt(format!(
        "{} keeps every finished task, and each task in flight its checkpoint; rerun the same \
         `occam sweep` command to continue",
        out.display()
    ));
    if exec.is_root() {
        let (resume_lines, summary) = planned.lines.split_at(planned.lines.len() - 1);
        for l in resume_lines {
            println!("{l}");
        }
        for w in occam::report::group_warnings(&planned.warnings) {
            eprintln!("warning: {w}");
        }
        println!("{}", summary[0]);
    }
    let work = Arc::new(Work::default());
    let bar = (exec.is_root() && !exec.is_distributed())
        .then(|| Bar::start(work.clone(), "tasks", cli.quiet))
        .flatten();
    let say = |line: &str| match &bar {
        Some(b) => b.bar().println(line),
        None => println!("{line}"),
    };
    let done = run_request(
        planned,
        exec.as_ref(),
        (!cli.quiet).then_some(&say),
        Some(&work),
    )?;
    if let Some(b) = bar {
        b.finish();
    }
    let Some(done) = done else {
        return Ok(());
    };
    print!("{}", done.table);
    // the tasks' warnings, each kind once (all of them are in sweep.json and the report)
    for l in done.warning_lines(&out) {
        eprintln!("{l}");
    }
    println!("wrote {}", listing(&out, &done.written));
    println!(
        "{} task(s) computed, {} reused; took {:.1} s",
        done.result.computed,
        done.result.reused,
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}
