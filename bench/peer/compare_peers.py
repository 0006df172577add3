#!/usr/bin/env python3
"""Times the first numpy peer against the optimised one, side by side in one process.

    bench/peer/.venv/bin/python bench/peer/compare_peers.py [INPUTS.npz] [ROUNDS]

INPUTS.npz is what `cargo bench --bench likelihood` writes (default
target/tmp/numpy_peer_inputs.npz). Both peers come from numpy_lnl.py: `Direct` is the
project's first peer (whole-array complex expressions, `np.exp` delays, unchanged), and
`Prepared` is the optimised one the bench runs. Each round times EVALS evaluations of each,
alternating which goes first, with θ moved as the Rust bench moves it; the script prints every
round and the medians of the rates and of the per-round ratio (the ratio is steadier than the
rates on a shared machine).

The old peer allocates about 25 temporaries of 0.3–0.6 MB per evaluation. glibc serves
allocations that large with fresh mmap pages unless its (adaptive) mmap threshold has risen,
so its speed depends on the allocator's history: about 3× slower with fresh pages (page
faults and zeroing), which is what a standalone run of the old peer mostly gets. This script
fixes the threshold at 32 MiB with mallopt, so the old peer is timed at its best (its
temporaries reuse heap memory) whatever ran before. The new peer writes into preallocated
buffers and does not care.

Before timing it checks the two against each other (and against the Rust values in the file)
at random points around the truth, including delays far from it, and on two synthetic
variants of the data that exercise the code paths the Table I study does not: an experiment
with both injection channels active, experiments whose controllers differ (so that det P is
not shared) and a non-uniform frequency grid.
"""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import ctypes  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import numpy_lnl as peer  # noqa: E402

EVALS = {"direct": 20, "prepared": 200}


def rel(a, b):
    return abs(a - b) / abs(b)


def check(exps, masses, thetas, label):
    old = peer.Direct(exps, masses)
    new = peer.Prepared(exps, masses)
    worst = max(rel(new.residual_power(th), old.residual_power(th)) for th in thetas)
    print(f"  {label}: max rel. difference of Σ RᴴC⁻¹R, new vs old, {worst:.1e}")
    return worst


def random_thetas(truth, rng, n):
    out = []
    for _ in range(n):
        th = truth * (1.0 + 0.2 * rng.standard_normal(truth.size))
        th[2:4] = rng.uniform(0.0, 1.0, 2)  # delays anywhere in [0, 1] s
        th[6] = rng.uniform(-1e-3, 1e-3)
        out.append(th)
    return out


def rate(f, th, truth, evals, k0):
    t0 = time.perf_counter()
    acc = 0.0
    for k in range(evals):
        th[4] = truth[4] + 1e-9 * ((k0 + k) % 7)
        acc += f(th)
    dt = time.perf_counter() - t0
    assert np.isfinite(acc)
    return evals / dt


def main():
    args = sys.argv[1:]
    path = args[0] if args else "target/tmp/numpy_peer_inputs.npz"
    rounds = int(args[1]) if len(args) > 1 else 9
    libc = ctypes.CDLL("libc.so.6")
    m_trim_threshold, m_mmap_threshold = -1, -3
    ok = libc.mallopt(m_mmap_threshold, 32 << 20) and libc.mallopt(m_trim_threshold, 1 << 30)
    print(f"malloc: mmap threshold fixed at 32 MiB ({'ok' if ok else 'mallopt FAILED'})")
    z, exps, masses = peer.load(path)
    truth = np.array(z["theta_truth"], dtype=float)
    rng = np.random.default_rng(3045)
    print(f"numpy {np.__version__}, {sum(e['freqs'].size for e in exps)} bins; agreement:")

    worst = check(exps, masses, [truth] + random_thetas(truth, rng, 20), "Table I data")
    ln_norm = peer.ln_norm_of(exps)
    new = peer.Prepared(exps, masses)
    worst_rust = max(
        rel(-new.residual_power(th) + ln_norm, want) for th, want in zip(z["theta"], z["lnl"])
    )
    print(f"  Table I data: max rel. difference of ln L, new vs Rust, {worst_rust:.1e}")
    # both channels injected in one experiment
    both = [dict(e) for e in exps]
    both[0]["inj"] = [exps[0]["inj"][0], exps[1]["inj"][1]]
    worst = max(worst, check(both, masses, random_thetas(truth, rng, 5), "two channels"))
    # experiments that do not share det P (different suspension controllers)
    own = [dict(e) for e in exps]
    own[1]["csus"] = exps[1]["csus"] * (1.0 + 0.1j)
    worst = max(worst, check(own, masses, random_thetas(truth, rng, 5), "unshared det P"))
    # a non-uniform grid (every third bin dropped)
    keep = np.arange(exps[0]["freqs"].size) % 3 != 2
    sub = []
    for e in exps:
        s = {k: (v[keep] if isinstance(v, np.ndarray) else [x[keep] for x in v])
             for k, v in e.items()}
        sub.append(s)
    worst = max(worst, check(sub, masses, random_thetas(truth, rng, 5), "non-uniform grid"))
    if worst > 1e-12:
        sys.exit(f"the peers disagree: {worst:.1e} > 1e-12")

    old = peer.Direct(exps, masses)
    fns = {"direct": old.residual_power, "prepared": new.residual_power}
    for f in fns.values():
        f(truth.copy())  # warm-up
    rates = {k: [] for k in fns}
    print(f"{rounds} rounds ({EVALS['direct']} old / {EVALS['prepared']} new evaluations each):")
    for r in range(rounds):
        order = list(fns) if r % 2 == 0 else list(fns)[::-1]
        for k in order:
            rates[k].append(rate(fns[k], truth.copy(), truth, EVALS[k], r))
        print(
            f"  round {r + 1}: old {rates['direct'][-1]:8.1f}/s  new {rates['prepared'][-1]:8.1f}/s"
            f"  ratio {rates['prepared'][-1] / rates['direct'][-1]:5.1f}"
        )
    ratios = [b / a for a, b in zip(rates["direct"], rates["prepared"])]
    print(
        f"median: old {statistics.median(rates['direct']):.1f} evals/s, new "
        f"{statistics.median(rates['prepared']):.1f} evals/s, ratio {statistics.median(ratios):.1f}"
        f" (range {min(ratios):.1f}–{max(ratios):.1f})"
    )


if __name__ == "__main__":
    main()
