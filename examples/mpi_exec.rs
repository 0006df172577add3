//! Checks the MPI executor against the thread executor; run it under `mpirun` (CI does):
//!
//! ```sh
//! cargo build --features mpi --example mpi_exec
//! mpirun -n 2 target/debug/examples/mpi_exec           # results equal, exits 0
//! mpirun -n 2 target/debug/examples/mpi_exec fail 1    # every task on rank 1 fails:
//!                                                      # every rank reports it, exits 3
//! ```
//!
//! The tasks are uneven (task i does work proportional to (i mod 7) + 1) and their bytes depend
//! only on the index, like a sweep's. The todo list is out of order and has gaps, as on a
//! resumed sweep. Run as `mpirun -n 1` (or without mpirun) it stops with an error: a one-rank
//! world is not an MPI job.

use anyhow::{Result, bail};
use mpi::collective::CommunicatorCollectives;
use occam::jobs::exec::{Executor, Threads};
use occam::jobs::mpi::Mpi;
use rand::{RngExt, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Task i's bytes: a JSON line with a few numbers drawn from a stream seeded by i alone.
fn task(i: usize) -> Vec<u8> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(0x5eed ^ i as u64);
    let mut acc = 0.0f64;
    for _ in 0..((i % 7) + 1) * 2_000_000 {
        acc += rng.random::<f64>().ln();
    }
    format!(
        "{{\"task\":{i},\"acc\":{acc:e},\"bits\":{}}}",
        acc.to_bits()
    )
    .into_bytes()
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let threads = std::env::var("MPI_EXEC_THREADS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1);
    let mpi = match Mpi::init().and_then(|m| match m {
        Some(m) => m.with_threads(threads),
        None => bail!("run this under `mpirun -n N` with N > 1"),
    }) {
        Ok(m) => m,
        Err(e) => {
            eprintln!("mpi_exec: error: {e:#}");
            std::process::exit(3);
        }
    };
    let out = match args.first().map(String::as_str) {
        None => check(&mpi),
        Some("fail") => {
            let bad: usize = args.get(1).and_then(|v| v.parse().ok()).unwrap_or(1);
            fail(&mpi, bad)
        }
        Some(other) => Err(anyhow::anyhow!(
            "unknown mode {other:?} (none, or `fail R`)"
        )),
    };
    if let Err(e) = &out {
        eprintln!("mpi_exec rank {}: error: {e:#}", mpi.rank());
    }
    // Every rank has returned from `run` (a hang would stop here, and CI's timeout would
    // catch it); meet so that every rank's line is out before the first non-zero exit makes
    // mpirun kill the others.
    mpi::topology::SimpleCommunicator::world().barrier();
    drop(mpi);
    if out.is_err() {
        std::process::exit(3);
    }
}

/// The results of `Mpi` equal those of `Threads`, in index order; a second run on the same
/// executor with nothing to do returns nothing.
fn check(mpi: &Mpi) -> Result<()> {
    let n = 61;
    // out of order, every third index already "done"
    let todo: Vec<usize> = (0..n).rev().filter(|i| i % 3 != 1).collect();
    let ran = AtomicUsize::new(0);
    let f = |i: usize| -> Result<Vec<u8>> {
        ran.fetch_add(1, Ordering::Relaxed);
        Ok(task(i))
    };
    let t0 = std::time::Instant::now();
    let got = mpi.run(&todo, &f)?;
    let secs = t0.elapsed().as_secs_f64();
    println!(
        "mpi_exec rank {}: ran {} of {} tasks",
        mpi.rank(),
        ran.load(Ordering::Relaxed),
        todo.len()
    );
    let again = mpi.run(&[], &f)?;
    if !mpi.is_root() {
        if !got.is_empty() || !again.is_empty() {
            bail!("a non-root rank returned results");
        }
        return Ok(());
    }
    let want = Threads::new(2)?.run(&todo, &|i| Ok(task(i)))?;
    let mut sorted = todo.clone();
    sorted.sort_unstable();
    let idx: Vec<usize> = got.iter().map(|(i, _)| *i).collect();
    if idx != sorted {
        bail!("Mpi returned tasks {idx:?}, want {sorted:?}");
    }
    if got != want {
        let (i, _) = got.iter().zip(&want).find(|(a, b)| a != b).unwrap().0;
        bail!("task {i}: Mpi's bytes differ from Threads'");
    }
    if !again.is_empty() {
        bail!("an empty todo returned {} results", again.len());
    }
    println!(
        "mpi_exec: {} tasks on {} ranks ({} workers) in {secs:.2} s: bit-identical to Threads, in index order",
        todo.len(),
        mpi.ranks(),
        mpi.workers()
    );
    Ok(())
}

/// Every task run on rank `bad` fails; every rank must return the error (none hangs).
fn fail(mpi: &Mpi, bad: usize) -> Result<()> {
    let me = mpi.rank();
    let todo: Vec<usize> = (0..40).collect();
    let f = |i: usize| -> Result<Vec<u8>> {
        if me == bad {
            bail!("task {i} failed on purpose (every task on rank {bad} fails)")
        }
        Ok(task(i))
    };
    let got = mpi.run(&todo, &f)?;
    bail!(
        "the job succeeded ({} results here) although rank {bad} fails every task; \
         did rank {bad} get no task?",
        got.len()
    )
}
