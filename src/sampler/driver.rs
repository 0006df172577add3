//! The one loop every sampler runs in: Metropolis–Hastings chains, the tempering ladder and the
//! reversible-jump chains each describe how their state advances ([`Sampler`]); the [`Driver`]
//! owns what happens between iterations — blocks, progress, checkpoints and stopping — the way
//! argmin's executor owns a solver's loop.
//!
//! A sampler's numbers never depend on where the driver cuts its blocks: every sampler
//! advances to exactly the iteration it is asked for (synchronising internally where it must,
//! such as the reversible jump's pilot), so a run stopped after any block and resumed from its
//! checkpoint ends with the numbers of an uninterrupted run, bit for bit.
//!
//! ```
//! use occam::sampler::{Driver, Ended, Sampler};
//!
//! /// A counter that doubles a number every iteration.
//! struct Doubler { done: usize, total: usize, x: u64 }
//! impl Sampler for Doubler {
//!     type Error = String;
//!     fn done(&self) -> usize { self.done }
//!     fn total(&self) -> usize { self.total }
//!     fn advance(&mut self, until: usize) -> Result<(), String> {
//!         while self.done < until { self.x *= 2; self.done += 1; }
//!         Ok(())
//!     }
//! }
//!
//! let mut saved = Vec::new();
//! let mut s = Doubler { done: 0, total: 10, x: 1 };
//! let mut save = |s: &Doubler| -> Result<(), String> { saved.push(s.done); Ok(()) };
//! let ended = Driver::new(4).save(&mut save).run(&mut s).unwrap();
//! assert_eq!(ended, Ended::Finished);
//! assert_eq!((s.x, saved), (1024, vec![4, 8, 10]));
//! ```

use std::time::{Duration, Instant};

/// A sampler whose state advances iteration by iteration (emcee's walkers, argmin's solver
/// state): it knows how far it is and how far it goes, and runs the iterations it is asked for.
pub trait Sampler {
    /// What can go wrong while advancing (and while saving a checkpoint of it).
    type Error;
    /// Iterations done (per chain, where there are several).
    fn done(&self) -> usize;
    /// Iterations the run does in all.
    fn total(&self) -> usize;
    /// Runs iterations `done() + 1 ..= until` (`until ≤ total()`), ending exactly there.
    fn advance(&mut self, until: usize) -> Result<(), Self::Error>;
}

/// How a driven run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ended {
    /// All iterations are done.
    Finished,
    /// The stop hook asked to stop after `iterations` iterations; the state is saved if a
    /// checkpoint hook was set.
    Stopped {
        /// Iterations done.
        iterations: usize,
    },
    /// The convergence hook ([`Driver::until`]) was met after `iterations` iterations, before
    /// the last; the state is saved if a checkpoint hook was set. The run is over.
    Converged {
        /// Iterations done.
        iterations: usize,
    },
}

/// The checkpoint hook and how often it runs.
type Save<'a, S> = &'a mut dyn FnMut(&S) -> Result<(), <S as Sampler>::Error>;

/// The convergence hook and the iterations it is asked at: `first`, then every `every`.
struct Until<'a, S> {
    first: usize,
    every: usize,
    converged: &'a dyn Fn(&S) -> bool,
}

impl<S> Until<'_, S> {
    /// Whether the hook is asked after `n` of `total` iterations (never at the last).
    fn asked(&self, n: usize, total: usize) -> bool {
        n >= self.first && n < total && (n - self.first).is_multiple_of(self.every)
    }

    /// The first iteration after `done` the hook is asked at.
    fn next_after(&self, done: usize) -> usize {
        if done < self.first {
            self.first
        } else {
            let k = (done - self.first) / self.every + 1;
            self.first.saturating_add(k.saturating_mul(self.every))
        }
    }
}

/// Runs a [`Sampler`] in blocks of `block` iterations. After each block: the checkpoint hook
/// saves the state (at most every [`save_every`](Self::save_every); always after the last block
/// and before a stop), the observer sees it, and the stop hook may end the run.
pub struct Driver<'a, S: Sampler> {
    block: usize,
    observer: Option<&'a mut dyn FnMut(&S)>,
    save: Option<Save<'a, S>>,
    save_every: Duration,
    stop: Option<&'a dyn Fn(usize) -> bool>,
    until: Option<Until<'a, S>>,
}

impl<'a, S: Sampler> Driver<'a, S> {
    /// A driver of blocks of `block` iterations (0 is taken as 1).
    pub fn new(block: usize) -> Self {
        Self {
            block: block.max(1),
            observer: None,
            save: None,
            save_every: Duration::ZERO,
            stop: None,
            until: None,
        }
    }

    /// Called with the state after every block.
    pub fn observer(mut self, f: &'a mut dyn FnMut(&S)) -> Self {
        self.observer = Some(f);
        self
    }

    /// Saves the state after every block (see [`save_every`](Self::save_every)).
    pub fn save(mut self, f: Save<'a, S>) -> Self {
        self.save = Some(f);
        self
    }

    /// Saves at most this often (wall-clock), and always after the last block and before a
    /// stop: a kill loses at most this interval and one block. Default: every block.
    pub fn save_every(mut self, interval: Duration) -> Self {
        self.save_every = interval;
        self
    }

    /// Asked after each block but the last (after its checkpoint, if one was due) with the
    /// iterations done; `true` saves the state (if it was not just saved) and stops the run.
    pub fn stop_when(mut self, f: &'a dyn Fn(usize) -> bool) -> Self {
        self.stop = Some(f);
        self
    }

    /// Ends the run early once `converged` says so, asked at every multiple of `every`
    /// iterations (0 is taken as 1) before the last: blocks are cut there too, so where a run
    /// ends depends on its state alone, never on the block length or on where it was resumed.
    /// A run resumed at such a multiple is asked first, as the uninterrupted run was there.
    pub fn until(self, every: usize, converged: &'a dyn Fn(&S) -> bool) -> Self {
        let every = every.max(1);
        self.until_from(every, every, converged)
    }

    /// As [`until`](Self::until), asked first at `first` (0 is taken as `every`) and then at
    /// every `every` after it.
    pub fn until_from(
        mut self,
        first: usize,
        every: usize,
        converged: &'a dyn Fn(&S) -> bool,
    ) -> Self {
        let every = every.max(1);
        let first = if first == 0 { every } else { first };
        self.until = Some(Until {
            first,
            every,
            converged,
        });
        self
    }

    /// Runs `sampler` from where it is to its end, or until the stop or convergence hook says
    /// so.
    pub fn run(mut self, sampler: &mut S) -> Result<Ended, S::Error> {
        let total = sampler.total();
        let mut last_save = Instant::now();
        if let Some(u) = &self.until {
            let done = sampler.done();
            if u.asked(done, total) && (u.converged)(sampler) {
                return Ok(Ended::Converged { iterations: done });
            }
        }
        loop {
            let done = sampler.done();
            if done >= total {
                return Ok(Ended::Finished);
            }
            let mut until = done.saturating_add(self.block).min(total);
            if let Some(u) = &self.until {
                until = until.min(u.next_after(done));
            }
            sampler.advance(until)?;
            let converged = self
                .until
                .as_ref()
                .is_some_and(|u| u.asked(until, total) && (u.converged)(sampler));
            let mut saved = false;
            if let Some(save) = self.save.as_mut()
                && (until == total || converged || last_save.elapsed() >= self.save_every)
            {
                save(sampler)?;
                (saved, last_save) = (true, Instant::now());
            }
            // after the save: an observer that ends the process loses nothing
            if let Some(f) = self.observer.as_mut() {
                f(sampler);
            }
            if converged {
                return Ok(Ended::Converged { iterations: until });
            }
            if until < total && self.stop.is_some_and(|stop| stop(until)) {
                if let Some(save) = self.save.as_mut()
                    && !saved
                {
                    save(sampler)?;
                }
                return Ok(Ended::Stopped { iterations: until });
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Adds `done` to a running sum: the result depends on every iteration running once.
    struct Sum {
        done: usize,
        total: usize,
        sum: u64,
        fail_at: Option<usize>,
    }
    impl Sampler for Sum {
        type Error = String;
        fn done(&self) -> usize {
            self.done
        }
        fn total(&self) -> usize {
            self.total
        }
        fn advance(&mut self, until: usize) -> Result<(), String> {
            while self.done < until {
                self.done += 1;
                if Some(self.done) == self.fail_at {
                    return Err(format!("failed at {}", self.done));
                }
                self.sum += self.done as u64;
            }
            Ok(())
        }
    }

    fn sum(total: usize) -> Sum {
        Sum {
            done: 0,
            total,
            sum: 0,
            fail_at: None,
        }
    }

    #[test]
    fn blocks_observer_saves_and_the_last_partial_block() {
        let mut s = sum(10);
        let (mut seen, mut saved) = (Vec::new(), Vec::new());
        let mut obs = |s: &Sum| seen.push(s.done);
        let mut save = |s: &Sum| -> Result<(), String> {
            saved.push(s.done);
            Ok(())
        };
        let end = Driver::new(3)
            .observer(&mut obs)
            .save(&mut save)
            .run(&mut s)
            .unwrap();
        assert_eq!(end, Ended::Finished);
        assert_eq!(s.sum, 55);
        assert_eq!(seen, vec![3, 6, 9, 10]);
        assert_eq!(saved, vec![3, 6, 9, 10]);
    }

    #[test]
    fn a_stopped_run_saves_then_resumes_to_the_same_end() {
        let mut s = sum(10);
        let mut saved = Vec::new();
        let mut save = |s: &Sum| -> Result<(), String> {
            saved.push(s.done);
            Ok(())
        };
        let stop = |n: usize| n >= 4;
        let end = Driver::new(2)
            .save(&mut save)
            .save_every(Duration::from_secs(3600))
            .stop_when(&stop)
            .run(&mut s)
            .unwrap();
        assert_eq!(end, Ended::Stopped { iterations: 4 });
        // throttled: no save after block 1, but one before the stop
        assert_eq!(saved, vec![4]);
        let end = Driver::new(5).run(&mut s).unwrap();
        assert_eq!(end, Ended::Finished);
        assert_eq!((s.done, s.sum), (10, 55));
        // a finished sampler runs nothing more
        assert_eq!(Driver::new(5).run(&mut s).unwrap(), Ended::Finished);
        assert_eq!(s.sum, 55);
    }

    #[test]
    fn the_convergence_hook_ends_the_run_at_a_multiple_of_its_interval_whatever_the_blocks() {
        // converged once the sum passes 40: first asked true at 9 (sum 45), a multiple of 3
        let converged = |s: &Sum| s.sum > 40;
        for block in [1, 2, 4, 7, 100] {
            let mut s = sum(20);
            let mut saved = Vec::new();
            let mut save = |s: &Sum| -> Result<(), String> {
                saved.push(s.done);
                Ok(())
            };
            let end = Driver::new(block)
                .save(&mut save)
                .save_every(Duration::from_secs(3600))
                .until(3, &converged)
                .run(&mut s)
                .unwrap();
            assert_eq!(end, Ended::Converged { iterations: 9 }, "block {block}");
            assert_eq!((s.done, saved), (9, vec![9]), "block {block}");
            // resumed where it converged, it is asked first and runs nothing more
            let end = Driver::new(block).until(3, &converged).run(&mut s).unwrap();
            assert_eq!((end, s.done), (Ended::Converged { iterations: 9 }, 9));
        }
        // blocks end at the multiples too, so a stop asked for after 5 comes at 6; resumed,
        // the run converges where the whole run did
        let mut s = sum(20);
        let stop = |n: usize| n >= 5;
        let end = Driver::new(4)
            .until(3, &converged)
            .stop_when(&stop)
            .run(&mut s);
        assert_eq!(end, Ok(Ended::Stopped { iterations: 6 }));
        let end = Driver::new(4).until(3, &converged).run(&mut s).unwrap();
        assert_eq!(
            (end, s.done, s.sum),
            (Ended::Converged { iterations: 9 }, 9, 45)
        );
        // never asked at the last iteration: a run that converges only there finishes
        let mut s = sum(9);
        let end = Driver::new(4).until(3, &converged).run(&mut s).unwrap();
        assert_eq!((end, s.done), (Ended::Finished, 9));
        // a hook never met leaves the run to its end
        let never = |_: &Sum| false;
        let mut s = sum(10);
        assert_eq!(
            Driver::new(4).until(3, &never).run(&mut s).unwrap(),
            Ended::Finished
        );
        assert_eq!(s.sum, 55);
    }

    #[test]
    fn a_hook_asked_first_later_ends_there_or_at_its_interval_after() {
        // converged from the sum 45 on (after 9); asked first at 10, then every 4
        let converged = |s: &Sum| s.sum > 40;
        for block in [1, 3, 4, 100] {
            let mut s = sum(30);
            let end = Driver::new(block)
                .until_from(10, 4, &converged)
                .run(&mut s)
                .unwrap();
            assert_eq!(end, Ended::Converged { iterations: 10 }, "block {block}");
            // not met at 10 (sum 55 > 60 fails): the next asks are 14, 18 …
            let late = |s: &Sum| s.sum > 60;
            let mut s = sum(30);
            let end = Driver::new(block)
                .until_from(10, 4, &late)
                .run(&mut s)
                .unwrap();
            assert_eq!(end, Ended::Converged { iterations: 14 }, "block {block}");
        }
        // resumed before the first ask, from a stop at 6, it still ends at 10
        let mut s = sum(30);
        let stop = |n: usize| n >= 5;
        let end = Driver::new(3)
            .until_from(10, 4, &converged)
            .stop_when(&stop)
            .run(&mut s);
        assert_eq!(end, Ok(Ended::Stopped { iterations: 6 }));
        let end = Driver::new(3).until_from(10, 4, &converged).run(&mut s);
        assert_eq!(end, Ok(Ended::Converged { iterations: 10 }));
        // a first ask at or past the end is never made
        let mut s = sum(10);
        let end = Driver::new(3).until_from(10, 4, &converged).run(&mut s);
        assert_eq!((end, s.sum), (Ok(Ended::Finished), 55));
    }

    #[test]
    fn the_stop_hook_is_not_asked_after_the_last_block_and_errors_pass_through() {
        let mut s = sum(4);
        let stop = |_: usize| true;
        assert_eq!(
            Driver::new(4).stop_when(&stop).run(&mut s).unwrap(),
            Ended::Finished
        );
        let mut s = Sum {
            fail_at: Some(3),
            ..sum(5)
        };
        assert_eq!(Driver::new(2).run(&mut s), Err("failed at 3".to_string()));
        let mut s = sum(3);
        let mut save = |_: &Sum| -> Result<(), String> { Err("disk full".into()) };
        assert_eq!(
            Driver::new(1).save(&mut save).run(&mut s),
            Err("disk full".to_string())
        );
    }
}
