//! Where a job's independent tasks run: on threads of this process ([`Threads`]), or on the
//! ranks of an MPI job (the `mpi` feature).
//!
//! A task is an index into the job's task list; its result is the bytes the job will parse
//! (JSON), so results can cross process boundaries unchanged. A task's numbers depend only on
//! its index (seeds derive from the run seed and the task, never from the worker), so every
//! executor returns the same bytes.

use rayon::prelude::*;

/// A task's body: the index in, the result's bytes out. A task that fails in a way the job
/// wants to report returns its report as bytes; an `Err` stops the job.
pub type TaskFn<'a> = dyn Fn(usize) -> anyhow::Result<Vec<u8>> + Sync + 'a;

/// Runs a job's tasks.
pub trait Executor: Sync {
    /// Runs `f` on every index of `todo` and returns every `(index, bytes)` in index order on
    /// the root process; other processes get an empty list. Only the root's `todo` is used
    /// (an MPI executor broadcasts it), so only the root needs to decide what is left to do.
    fn run(&self, todo: &[usize], f: &TaskFn) -> anyhow::Result<Vec<(usize, Vec<u8>)>>;

    /// Whether this process writes the job's outputs.
    fn is_root(&self) -> bool;

    /// Number of workers (threads or ranks).
    fn workers(&self) -> usize;

    /// Whether tasks also run in other processes (then this one cannot count them all, and
    /// draws no progress bar).
    fn is_distributed(&self) -> bool {
        false
    }
}

/// Tasks on the threads of this process (rayon), `threads` of them (0: rayon's default).
pub struct Threads {
    pool: rayon::ThreadPool,
}

impl Threads {
    /// A pool of `threads` workers (0 means one per core).
    pub fn new(threads: usize) -> anyhow::Result<Self> {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .map_err(|e| anyhow::anyhow!("cannot start {threads} worker threads: {e}"))?;
        Ok(Self { pool })
    }
}

impl Executor for Threads {
    fn run(&self, todo: &[usize], f: &TaskFn) -> anyhow::Result<Vec<(usize, Vec<u8>)>> {
        let mut out: Vec<(usize, Vec<u8>)> = self.pool.install(|| {
            todo.par_iter()
                .with_max_len(1)
                .map(|&i| f(i).map(|b| (i, b)))
                .collect::<anyhow::Result<Vec<_>>>()
        })?;
        out.sort_by_key(|(i, _)| *i);
        Ok(out)
    }

    fn is_root(&self) -> bool {
        true
    }

    fn workers(&self) -> usize {
        self.pool.current_num_threads()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn threads_return_every_result_in_index_order_whatever_the_pool() {
        let todo = [7, 2, 5, 0, 3];
        let f = |i: usize| Ok(format!("task {i}").into_bytes());
        let one = Threads::new(1).unwrap().run(&todo, &f).unwrap();
        let two = Threads::new(2).unwrap().run(&todo, &f).unwrap();
        assert_eq!(one, two);
        let idx: Vec<usize> = one.iter().map(|(i, _)| *i).collect();
        assert_eq!(idx, vec![0, 2, 3, 5, 7]);
        assert_eq!(one[1].1, b"task 2");
    }

    #[test]
    fn a_failing_task_stops_the_job_with_its_message() {
        let f = |i: usize| {
            if i == 3 {
                anyhow::bail!("task 3 cannot write its file")
            }
            Ok(vec![])
        };
        let e = Threads::new(2).unwrap().run(&[1, 3, 4], &f).unwrap_err();
        assert!(e.to_string().contains("task 3"), "{e}");
    }
}
