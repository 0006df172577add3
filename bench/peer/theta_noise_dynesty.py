#!/usr/bin/env python3
"""Nested sampling (dynesty) on the exact θ-dependent likelihood of the two-mass study, the
independent reference for `occam select examples/two-mass-damper.toml` (issue 46): each
`[[select.model]]`'s evidence from `occam.Likelihood.from_study(..., model=name)`, whose
`ln_likelihood` evaluates the residual noise at θ itself.

    python3 -m venv /tmp/venv && /tmp/venv/bin/pip install numpy dynesty ./python
    /tmp/venv/bin/python bench/peer/theta_noise_dynesty.py [--seeds 3] [--nlive 500]

Prints ln Z of each model per seed, their mean and scatter, and ln B(damper/springs) with the
error from dynesty's own estimate and from the scatter over seeds.
"""

import argparse
import os
import time

import dynesty
import numpy as np

import occam

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
STUDY = os.path.join(ROOT, "examples", "two-mass-damper.toml")


def ln_z(model, seed, nlive):
    lik = occam.Likelihood.from_study(STUDY, model=model)
    s = dynesty.NestedSampler(
        lik.ln_likelihood, lik.prior_transform, lik.ndim, nlive=nlive,
        rstate=np.random.default_rng(seed),
    )
    t0 = time.time()
    s.run_nested(dlogz=0.05, print_progress=False)
    r = s.results
    return r.logz[-1], r.logzerr[-1], int(np.sum(r.ncall)), time.time() - t0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--nlive", type=int, default=500)
    a = ap.parse_args()
    z = {}
    for m in ("damper", "springs"):
        z[m] = []
        for seed in range(a.seeds):
            lz, err, calls, sec = ln_z(m, seed, a.nlive)
            z[m].append((lz, err))
            print(f"{m:8s} seed {seed}: ln Z = {lz:.3f} ± {err:.3f} ({calls} calls, {sec:.0f} s)",
                  flush=True)
    mean = {m: np.mean([v for v, _ in z[m]]) for m in z}
    sd = {m: np.std([v for v, _ in z[m]], ddof=1) if a.seeds > 1 else float("nan") for m in z}
    own = {m: np.sqrt(np.mean([e * e for _, e in z[m]]) / a.seeds) for m in z}
    ln_b = mean["damper"] - mean["springs"]
    print(f"ln B(damper/springs) = {ln_b:.3f} ± {np.hypot(own['damper'], own['springs']):.3f} "
          f"(dynesty's errors of the mean of {a.seeds}); "
          f"± {np.hypot(sd['damper'], sd['springs']) / np.sqrt(a.seeds):.3f} (scatter over seeds)")


if __name__ == "__main__":
    main()
