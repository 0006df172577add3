//! Tasks on the ranks of an MPI job (`mpirun -n N occam sweep …`, the `mpi` feature).
//!
//! # Scheduling: a dynamic work queue on rank 0
//!
//! The tasks of a sweep are uneven (a high-SNR point or a hard model takes longer), so a fixed
//! split over ranks would leave ranks idle while one finishes its share. Rank 0 therefore keeps
//! the queue (the root's `todo`, in its order) and hands out indices on request: every other rank
//! asks for a batch (as many indices as it has threads), runs it on its own [`Threads`] pool,
//! and sends the results back with its next request. Rank 0 also works: a thread of its own
//! takes batches from the same queue, while rank 0's calling thread serves the requests. Which
//! rank runs which task therefore varies from run to run, but a task's bytes depend only on its
//! index, so the gathered results are bit-identical to a single process.
//!
//! Waiting ranks poll (a non-blocking probe, then a short sleep) instead of blocking in MPI,
//! because Open MPI's blocking calls spin a core at 100 % while they wait, which would take a
//! core from the tasks.
//!
//! # Failures
//!
//! A task's `Err` on any rank is sent to rank 0 with that rank's next request (a status flag in
//! the message). Rank 0 then hands out no more work: every rank's next request is answered with
//! "stop", batches already running finish, and rank 0 sends every rank the job's outcome. Every
//! rank then returns the same error (the first one rank 0 saw, naming the task and the rank), so
//! no rank waits for a message that never comes and `mpirun` exits non-zero. A panic or a killed
//! rank is not caught here: the process dies and `mpirun` aborts the whole job.
//!
//! MPI errors themselves abort (MPI's default error handler), so they cannot hang either.

use super::exec::{Executor, TaskFn, Threads};
use super::mpi_wire::{
    Request, decode_indices, decode_outcome, decode_request, encode_done, encode_failed,
    encode_indices, encode_outcome,
};
use anyhow::{Context, Result, anyhow, bail};
use mpi::environment::Universe;
use mpi::point_to_point::{Destination, MatchedReceiveVec, Source};
use mpi::topology::{Communicator, Rank};
use mpi::{Tag, Threading};
use std::collections::VecDeque;
use std::sync::Mutex;
use std::time::Duration;

/// A worker rank's request: the results of its last batch (or its error) and its capacity.
const TAG_REQUEST: Tag = 11;
/// Rank 0's answer to a request: the next batch of task indices; empty means stop.
const TAG_WORK: Tag = 12;
/// Rank 0's last message to every worker rank: the job's outcome.
const TAG_OUTCOME: Tag = 13;

/// Longest sleep between two polls of a waiting rank; short next to a task (seconds), long
/// enough that a waiting rank uses no measurable CPU.
const MAX_POLL_SLEEP: Duration = Duration::from_millis(5);

/// The ranks of the MPI job this process belongs to, each running its tasks on `threads`
/// threads. Holding it keeps MPI initialised; dropping it finalises MPI (after which MPI cannot
/// be initialised again in this process).
pub struct Mpi {
    universe: Universe,
    rank: Rank,
    size: Rank,
    threads: Threads,
    /// MPI was initialised for serialised calls only: one `run` at a time per process.
    serial: Mutex<()>,
}

impl Mpi {
    /// Initialises MPI. `Ok(None)` when the world has a single rank (no `mpirun`, or
    /// `mpirun -n 1`): the caller should then use [`Threads`], which does the same work without
    /// the message passing. Each rank runs its tasks on one thread; see [`Mpi::with_threads`].
    pub fn init() -> Result<Option<Self>> {
        let (universe, level) =
            mpi::initialize_with_threading(Threading::Serialized).ok_or_else(|| {
                anyhow!("MPI is already initialised in this process; create the Mpi executor once")
            })?;
        if !matches!(level, Threading::Serialized | Threading::Multiple) {
            bail!(
                "the MPI library offers thread level {level:?}, but the Mpi executor needs \
                 Serialized (one rank's tasks run on a worker thread while its main thread \
                 talks to the other ranks); use an MPI built with thread support"
            );
        }
        let world = universe.world();
        let (rank, size) = (world.rank(), world.size());
        if size < 2 {
            return Ok(None);
        }
        Ok(Some(Self {
            universe,
            rank,
            size,
            threads: Threads::new(1)?,
            serial: Mutex::new(()),
        }))
    }

    /// Runs each rank's tasks on `threads` threads of that rank (0: one per core; with one
    /// rank per core, as `mpirun` places them by default, keep 1).
    pub fn with_threads(mut self, threads: usize) -> Result<Self> {
        self.threads = Threads::new(threads)?;
        Ok(self)
    }

    /// This process's rank (0 is the root).
    pub fn rank(&self) -> usize {
        self.rank as usize
    }

    /// Number of ranks.
    pub fn ranks(&self) -> usize {
        self.size as usize
    }

    fn root_run(&self, todo: &[usize], f: &TaskFn) -> Result<Vec<(usize, Vec<u8>)>> {
        let world = self.universe.world();
        let queue = Mutex::new(todo.iter().copied().collect::<VecDeque<usize>>());
        let results = Mutex::new(Vec::with_capacity(todo.len()));
        // The first failure, already worded for the user; once set no work is handed out.
        let failure: Mutex<Option<String>> = Mutex::new(None);
        let take = |n: usize| -> Vec<usize> {
            if lock(&failure).is_some() {
                return Vec::new();
            }
            let mut q = lock(&queue);
            let n = n.min(q.len());
            q.drain(..n).collect()
        };
        let fail = |msg: String| {
            let mut first = lock(&failure);
            if first.is_none() {
                *first = Some(msg);
            }
        };
        std::thread::scope(|s| {
            // Rank 0's own share of the work, on its pool, while this thread serves requests.
            s.spawn(|| {
                loop {
                    let batch = take(self.threads.workers());
                    if batch.is_empty() {
                        break;
                    }
                    match self.threads.run(&batch, f) {
                        Ok(r) => lock(&results).extend(r),
                        Err(e) => {
                            fail(format!("rank 0: {e:#}"));
                            break;
                        }
                    }
                }
            });
            let mut active = self.size - 1;
            let mut sleep = Duration::from_micros(100);
            while active > 0 {
                let Some(probed) = world
                    .any_process()
                    .immediate_matched_probe_with_tag(TAG_REQUEST)
                else {
                    std::thread::sleep(sleep);
                    sleep = (sleep * 2).min(MAX_POLL_SLEEP);
                    continue;
                };
                sleep = Duration::from_micros(100);
                let (bytes, status) = probed.matched_receive_vec::<u8>();
                let from = status.source_rank();
                let batch = match decode_request(&bytes) {
                    Ok(Request::Done {
                        capacity,
                        results: r,
                    }) => {
                        lock(&results).extend(r);
                        take(capacity)
                    }
                    Ok(Request::Failed(e)) => {
                        fail(format!("rank {from}: {e}"));
                        Vec::new()
                    }
                    Err(e) => {
                        fail(format!("rank {from} sent a malformed request: {e:#}"));
                        Vec::new()
                    }
                };
                if batch.is_empty() {
                    active -= 1;
                }
                world
                    .process_at_rank(from)
                    .send_with_tag(&encode_indices(&batch)[..], TAG_WORK);
            }
        });
        let failure = failure.into_inner().unwrap_or_else(|p| p.into_inner());
        let outcome = encode_outcome(failure.as_deref());
        for r in 1..self.size {
            world
                .process_at_rank(r)
                .send_with_tag(&outcome[..], TAG_OUTCOME);
        }
        if let Some(e) = failure {
            bail!("the MPI job stopped: {e}");
        }
        let mut out = results.into_inner().unwrap_or_else(|p| p.into_inner());
        out.sort_by_key(|(i, _)| *i);
        Ok(out)
    }

    fn worker_run(&self, f: &TaskFn) -> Result<Vec<(usize, Vec<u8>)>> {
        let world = self.universe.world();
        let root = world.process_at_rank(0);
        let capacity = self.threads.workers();
        let mut request = encode_done(capacity, &[]);
        loop {
            root.send_with_tag(&request[..], TAG_REQUEST);
            let batch = decode_indices(&poll_receive(&world, TAG_WORK))
                .context("rank 0 sent a malformed batch")?;
            if batch.is_empty() {
                break;
            }
            request = match self.threads.run(&batch, f) {
                Ok(r) => encode_done(capacity, &r),
                Err(e) => encode_failed(&format!("{e:#}")),
            };
        }
        match decode_outcome(&poll_receive(&world, TAG_OUTCOME))? {
            None => Ok(Vec::new()),
            Some(e) => bail!("the MPI job stopped: {e}"),
        }
    }
}

impl Executor for Mpi {
    /// Spreads `todo` (rank 0's; the other ranks' is ignored) over the ranks; see the module
    /// docs for the scheduling and what happens when a task fails. Every rank must call `run`
    /// (the same number of times, in the same order).
    fn run(&self, todo: &[usize], f: &TaskFn) -> Result<Vec<(usize, Vec<u8>)>> {
        let _one_at_a_time = lock(&self.serial);
        if self.rank == 0 {
            self.root_run(todo, f)
        } else {
            self.worker_run(f)
        }
    }

    fn is_root(&self) -> bool {
        self.rank == 0
    }

    /// Ranks × threads per rank.
    fn workers(&self) -> usize {
        self.size as usize * self.threads.workers()
    }

    fn is_distributed(&self) -> bool {
        self.size > 1
    }
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    // A poisoned lock means a task panicked; the data (queues and results) is still whole.
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// Receives the next message with `tag` from rank 0, polling so the wait does not spin a core.
fn poll_receive(world: &mpi::topology::SimpleCommunicator, tag: Tag) -> Vec<u8> {
    let root = world.process_at_rank(0);
    let mut sleep = Duration::from_micros(100);
    loop {
        if let Some(probed) = root.immediate_matched_probe_with_tag(tag) {
            return probed.matched_receive_vec::<u8>().0;
        }
        std::thread::sleep(sleep);
        sleep = (sleep * 2).min(MAX_POLL_SLEEP);
    }
}
