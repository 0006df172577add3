//! LTPDA's heat schedule β(n) and search-jump scales (ltp-model.md §9.1).
//!
//! Jump rule, for `n ≤ tc1`, checked in this order:
//! * `n % 5 == 0`, `n % 25 ≠ 0`, `n % 40 ≠ 0`: `jumps[1]` (10×);
//! * else `n % 20 == 0`, `n % 50 ≠ 0`: `jumps[2]` (1e3×);
//! * else `n % 10 == 0`: `jumps[3]` (1e4×);
//! * otherwise `jumps[0]` (2×).
//!
//! These are the moduli of LTPDA's RJMCMC `propose`. The moduli quoted for `mhsample`
//! (10 / 20 / 50 with exclusions 25 and 100) never reach the 1e3× branch, since
//! `n % 20 == 0 ∧ n % 25 == 0` implies `n % 100 == 0`; the RJMCMC set reaches all three
//! (per 200 iterations: 28 × 10×, 4 × 1e3×, 4 × 1e4×). Big jumps fall on multiples of 5
//! only, so two big jumps never follow each other: LTPDA's `hjump` flag holds by
//! construction here because our counter advances on every iteration (LTPDA's RJMCMC counter
//! stalls on out-of-range proposals, which is why it needed the flag).

use super::settings::Anneal;

impl Anneal {
    /// Inverse temperature at iteration `n` (1-based).
    pub fn beta(&self, n: usize) -> f64 {
        let (tc1, tc2) = (self.tc1 as f64, self.tc2 as f64);
        if n <= self.tc1 {
            10f64.powf(-self.heat * (1.0 - tc1 / tc2))
        } else if n <= self.tc2 {
            10f64.powf(-self.heat * (1.0 - n as f64 / tc2))
        } else {
            1.0
        }
    }

    /// Multiplier of the proposal's standard deviations at iteration `n` (1-based):
    /// the jump rule for `n ≤ tc1`, `√jumps[0]` (LTPDA's `jumps(1)·Σ`) for `tc1 < n ≤ tc2`,
    /// 1 afterwards.
    pub fn step_scale(&self, n: usize) -> f64 {
        if n <= self.tc1 {
            self.jumps[jump_index(n)]
        } else if n <= self.tc2 {
            self.jumps[0].sqrt()
        } else {
            1.0
        }
    }
}

/// Which entry of `jumps` iteration `n` of the search uses (0 = normal step).
fn jump_index(n: usize) -> usize {
    if n.is_multiple_of(5) && !n.is_multiple_of(25) && !n.is_multiple_of(40) {
        1
    } else if n.is_multiple_of(20) && !n.is_multiple_of(50) {
        2
    } else if n.is_multiple_of(10) {
        3
    } else {
        0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn heat_schedule_matches_ltpda() {
        let a = Anneal {
            heat: 2.0,
            ..Anneal::new(100, 400)
        };
        let hot = 10f64.powf(-2.0 * 0.75);
        assert_eq!(a.beta(1), hot);
        assert_eq!(a.beta(100), hot);
        assert!((a.beta(200) - 10f64.powf(-2.0 * 0.5)).abs() < 1e-15);
        assert_eq!(a.beta(400), 1.0);
        assert_eq!(a.beta(401), 1.0);
        // β rises monotonically through the cool-down.
        for n in 100..400 {
            assert!(a.beta(n + 1) >= a.beta(n));
        }
    }

    #[test]
    fn jumps_reach_every_size_and_never_twice_in_a_row() {
        let a = Anneal::new(200, 300);
        let mut counts = [0usize; 4];
        let mut prev_big = false;
        for n in 1..=200 {
            let s = a.step_scale(n);
            let k = a.jumps.iter().position(|&j| j == s).unwrap();
            counts[k] += 1;
            let big = k > 0;
            assert!(!(big && prev_big), "two big jumps in a row at n = {n}");
            prev_big = big;
        }
        assert_eq!(counts, [164, 28, 4, 4]);
        assert_eq!(a.step_scale(250), 2f64.sqrt());
        assert_eq!(a.step_scale(301), 1.0);
    }
}
