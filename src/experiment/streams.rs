//! The simulator's random streams: one per (seed, index), so that each experiment's noise
//! and gaps are drawn independently of threads, processes and each other.

use rand::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;

/// An RNG stream for (seed, stream index), independent of threads and of the other streams.
pub fn stream(seed: u64, index: u64) -> Xoshiro256PlusPlus {
    let mut r = Xoshiro256PlusPlus::seed_from_u64(seed);
    for _ in 0..index {
        r.jump();
    }
    r
}
