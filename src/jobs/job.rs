//! The contract every job keeps ([`Job`]), what it runs with ([`Context`]) and the driver
//! that holds, stages and publishes its run directory ([`execute`]).

use super::progress::Work;
use crate::data::rundir::RunDir;
use std::path::Path;

/// Where a job reports lines a user should see while it runs (what is resumed, where the
/// data come from). The command line prints them; Python drops or logs them.
pub type Log<'a> = &'a dyn Fn(&str);

/// What a job runs with: everything that is not the study.
#[derive(Clone, Copy)]
pub struct Context<'a> {
    /// The run directory (held, staged and published by [`execute`]).
    pub out: &'a Path,
    /// Continue from the checkpoint in `out` (an error when there is none).
    pub resume: bool,
    /// Lines for the user.
    pub log: Log<'a>,
    /// The work counters a progress bar polls.
    pub work: Option<&'a Work>,
}

impl<'a> Context<'a> {
    /// A context that logs nothing and counts nothing.
    pub fn quiet(out: &'a Path, resume: bool) -> Self {
        Context {
            out,
            resume,
            log: &|_| {},
            work: None,
        }
    }
}

/// One job of occam (see the module docs).
pub trait Job {
    /// What the job computed.
    type Outcome;
    /// The command that writes the directory (`manifest.json`'s `command`).
    const COMMAND: &'static str;
    /// The files the command wrote before `manifest.json` existed (see
    /// [`RunDir::publish`]).
    const LEGACY_OUTPUTS: &'static [&'static str];
    /// Computes, checkpointing into `ctx.out` as it goes.
    fn run(&mut self, ctx: &Context) -> anyhow::Result<Self::Outcome>;
    /// Writes the outcome into the staging directory, which is published as `run_dir`.
    fn write(&self, outcome: &Self::Outcome, staging: &Path, run_dir: &Path) -> anyhow::Result<()>;
}

/// What [`execute`] returns: the job's outcome and the files it published.
pub struct Done<T> {
    /// What the job computed.
    pub outcome: T,
    /// The files published into the run directory.
    pub written: Vec<String>,
}

/// Holds the run directory, runs the job, writes its outcome into a fresh staging directory
/// and publishes it whole.
pub fn execute<J: Job>(job: &mut J, ctx: &Context) -> anyhow::Result<Done<J::Outcome>> {
    let run = RunDir::open(ctx.out)?;
    let outcome = job.run(ctx)?;
    // one staging directory: asking for it again starts it afresh
    let staged = run.staging()?;
    job.write(&outcome, &staged, ctx.out)?;
    let written = run.publish(J::COMMAND, J::LEGACY_OUTPUTS)?;
    Ok(Done { outcome, written })
}
