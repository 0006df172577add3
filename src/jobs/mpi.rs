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

// Wire format (little-endian u64 words): a request is `0, capacity, n, (index, len, bytes)*n`
// or `1` followed by the UTF-8 error; a batch is `n, index*n`; an outcome is `0` or `1` + error.

#[derive(Debug, PartialEq)]
enum Request {
    Done {
        capacity: usize,
        results: Vec<(usize, Vec<u8>)>,
    },
    Failed(String),
}

fn put(buf: &mut Vec<u8>, x: usize) {
    buf.extend_from_slice(&(x as u64).to_le_bytes());
}

/// Reads the words of a message in order, failing (not panicking) on a short message.
struct Reader<'a>(&'a [u8]);

impl Reader<'_> {
    fn word(&mut self) -> Result<usize> {
        let (w, rest) = self
            .0
            .split_first_chunk::<8>()
            .ok_or_else(|| anyhow!("message ends early"))?;
        self.0 = rest;
        usize::try_from(u64::from_le_bytes(*w)).context("word does not fit in usize")
    }

    fn bytes(&mut self, n: usize) -> Result<&[u8]> {
        if self.0.len() < n {
            bail!(
                "message ends early: {n} bytes announced, {} left",
                self.0.len()
            );
        }
        let (b, rest) = self.0.split_at(n);
        self.0 = rest;
        Ok(b)
    }

    fn end(&self) -> Result<()> {
        if !self.0.is_empty() {
            bail!("{} stray bytes at the end of the message", self.0.len());
        }
        Ok(())
    }
}

fn encode_done(capacity: usize, results: &[(usize, Vec<u8>)]) -> Vec<u8> {
    let mut buf = Vec::new();
    put(&mut buf, 0);
    put(&mut buf, capacity);
    put(&mut buf, results.len());
    for (i, b) in results {
        put(&mut buf, *i);
        put(&mut buf, b.len());
        buf.extend_from_slice(b);
    }
    buf
}

fn encode_failed(msg: &str) -> Vec<u8> {
    let mut buf = Vec::new();
    put(&mut buf, 1);
    buf.extend_from_slice(msg.as_bytes());
    buf
}

fn decode_request(bytes: &[u8]) -> Result<Request> {
    let mut r = Reader(bytes);
    match r.word()? {
        0 => {
            let capacity = r.word()?;
            let n = r.word()?;
            let mut results = Vec::with_capacity(n.min(bytes.len() / 16));
            for _ in 0..n {
                let i = r.word()?;
                let len = r.word()?;
                results.push((i, r.bytes(len)?.to_vec()));
            }
            r.end()?;
            Ok(Request::Done { capacity, results })
        }
        1 => Ok(Request::Failed(String::from_utf8_lossy(r.0).into_owned())),
        s => bail!("unknown request status {s}"),
    }
}

fn encode_indices(batch: &[usize]) -> Vec<u8> {
    let mut buf = Vec::with_capacity(8 * (batch.len() + 1));
    put(&mut buf, batch.len());
    for &i in batch {
        put(&mut buf, i);
    }
    buf
}

fn decode_indices(bytes: &[u8]) -> Result<Vec<usize>> {
    let mut r = Reader(bytes);
    let n = r.word()?;
    if n > r.0.len() / 8 {
        bail!(
            "message ends early: {n} indices announced, {} bytes left",
            r.0.len()
        );
    }
    let out = (0..n).map(|_| r.word()).collect::<Result<Vec<_>>>()?;
    r.end()?;
    Ok(out)
}

fn encode_outcome(failure: Option<&str>) -> Vec<u8> {
    match failure {
        None => encode_indices(&[]),
        Some(e) => encode_failed(e),
    }
}

fn decode_outcome(bytes: &[u8]) -> Result<Option<String>> {
    let mut r = Reader(bytes);
    match r.word()? {
        0 => {
            r.end()?;
            Ok(None)
        }
        1 => Ok(Some(String::from_utf8_lossy(r.0).into_owned())),
        s => bail!("unknown outcome status {s}"),
    }
}

#[cfg(test)]
mod tests {
    //! The wire format, without MPI (the ranks themselves are exercised by
    //! `examples/mpi_exec.rs` under `mpirun -n 2`, in CI).
    use super::*;

    #[test]
    fn requests_round_trip_including_empty_and_binary_results() {
        let results = vec![
            (3, b"{\"x\":1}".to_vec()),
            (0, Vec::new()),
            (usize::MAX >> 1, vec![0, 255, 1, 0]),
        ];
        let got = decode_request(&encode_done(4, &results)).unwrap();
        assert_eq!(
            got,
            Request::Done {
                capacity: 4,
                results
            }
        );
        let empty = decode_request(&encode_done(1, &[])).unwrap();
        assert_eq!(
            empty,
            Request::Done {
                capacity: 1,
                results: vec![]
            }
        );
        let failed = decode_request(&encode_failed("task 7: disk full")).unwrap();
        assert_eq!(failed, Request::Failed("task 7: disk full".into()));
    }

    #[test]
    fn batches_and_outcomes_round_trip() {
        for b in [vec![], vec![5], vec![9, 1, 4]] {
            assert_eq!(decode_indices(&encode_indices(&b)).unwrap(), b);
        }
        assert_eq!(decode_outcome(&encode_outcome(None)).unwrap(), None);
        assert_eq!(
            decode_outcome(&encode_outcome(Some("rank 1: task 2 failed"))).unwrap(),
            Some("rank 1: task 2 failed".into())
        );
    }

    #[test]
    fn truncated_or_padded_messages_are_errors_not_panics() {
        let good = encode_done(2, &[(1, b"abc".to_vec())]);
        for cut in 0..good.len() {
            assert!(decode_request(&good[..cut]).is_err(), "cut at {cut}");
        }
        let mut long = good.clone();
        long.push(0);
        let e = decode_request(&long).unwrap_err();
        assert!(e.to_string().contains("stray"), "{e}");
        let e = decode_request(&encode_indices(&[7, 8])).unwrap_err(); // first word 2
        assert!(e.to_string().contains("status"), "{e}");
        assert!(decode_indices(&encode_indices(&[1, 2])[..12]).is_err());
        // A length word far beyond the message must not allocate or read past the end.
        let mut huge = Vec::new();
        for w in [0usize, 1, 1, 0, usize::MAX >> 8] {
            put(&mut huge, w);
        }
        assert!(decode_request(&huge).is_err());
    }
}
