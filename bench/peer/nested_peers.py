#!/usr/bin/env python3
"""dynesty and nautilus on occam's exact guidance-delay likelihood (issue 12's peers).

    bench/peer/.venv/bin/python bench/peer/nested_peers.py PREFIX [--tool dynesty|nautilus]...

PREFIX.npz / PREFIX.json are written by `cargo run --release --example peer_inputs -- STUDY
PREFIX`: the in-band spectra of every experiment of the study, the Rust ln L at check points
spread over the prior box, and the `[[select.model]]` models (free parameters, fixed values)
with their uniform prior boxes. The script

1. builds the numpy ln L (numpy_lnl.Prepared, the fast vectorised peer of the exact
   likelihood) and checks it against the Rust values at every check point to 1e−9 relative, on
   ln L and on its θ-dependent part Σ RᴴC⁻¹R (exit status 1 if not);
2. runs each tool on each model with the prior transform u ↦ lo + u (hi − lo) of the free
   parameters (fixed parameters at their values), single process (no pool; BLAS and OpenMP
   pinned to one thread before numpy is imported), and records ln Z, the tool's own error
   estimate, likelihood calls and wall time;
3. writes one JSON record per (tool, model) and ln B = ln Z_X − ln Z_Y of the first two models,
   σ = √(σ_X² + σ_Y²), time = t_X + t_Y, to --out.

Error estimates, each tool's own: dynesty's `logzerr` (static nested sampling, √(H/nlive) plus
the remaining-volume term); nautilus's statistical error 1/√N_eff (its documentation's estimate
of the run-to-run scatter of ln Z).
"""

import os

for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from numpy_lnl import Prepared, ln_norm_of, load  # noqa: E402

REL_TOL = 1e-9
DYNESTY_NLIVE = 500
DYNESTY_SAMPLE = "rwalk"
DYNESTY_BOUND = "multi"


class Problem:
    """ln L of one model: the free parameters in θ, fixed ones at their values."""

    def __init__(self, prep, ln_norm, model, lo, hi):
        self.prep = prep
        self.ln_norm = ln_norm
        self.name = model["name"]
        self.free = np.array(model["free"], dtype=int)
        self.base = np.array(model["base"], dtype=float)
        self.lo = lo[self.free]
        self.width = hi[self.free] - lo[self.free]
        self.ndim = self.free.size
        self.calls = 0

    def prior_transform(self, u):
        return self.lo + np.asarray(u) * self.width

    def ln_like(self, x):
        self.calls += 1
        th = self.base.copy()
        th[self.free] = x
        return -self.prep.residual_power(th) + self.ln_norm


def check(prep, ln_norm, z):
    """The numpy ln L against the Rust values at every check point."""
    worst = 0.0
    ln_norm_rust = float(z["ln_norm"][0])
    for th, want in zip(z["theta"], z["lnl"]):
        rp = prep.residual_power(th)
        got = -rp + ln_norm
        rp_rust = ln_norm_rust - want
        rel = abs(got - want) / abs(want)
        rel_rp = abs(rp - rp_rust) / abs(rp_rust)
        worst = max(worst, rel, rel_rp)
        flag = "ok" if max(rel, rel_rp) <= REL_TOL else "MISMATCH"
        print(f"  ln L rust {want:.12e} numpy {got:.12e} rel {rel:.1e}; Σ RᴴC⁻¹R rel {rel_rp:.1e} {flag}")
        if flag != "ok":
            sys.exit(f"numpy ln L disagrees with Rust ({max(rel, rel_rp):.3e} > {REL_TOL:.0e})")
    return worst


def run_dynesty(p, seed):
    import dynesty

    sampler = dynesty.NestedSampler(
        p.ln_like,
        p.prior_transform,
        p.ndim,
        nlive=DYNESTY_NLIVE,
        bound=DYNESTY_BOUND,
        sample=DYNESTY_SAMPLE,
        rstate=np.random.default_rng(seed),
    )
    t0, c0 = time.perf_counter(), time.process_time()
    sampler.run_nested(print_progress=False)
    secs, cpu = time.perf_counter() - t0, time.process_time() - c0
    r = sampler.results
    return dict(
        ln_z=float(r["logz"][-1]),
        err=float(r["logzerr"][-1]),
        seconds=secs,
        cpu_seconds=cpu,
        settings=dict(
            nlive=DYNESTY_NLIVE,
            bound=DYNESTY_BOUND,
            sample=DYNESTY_SAMPLE,
            walks=p.ndim + 20,
            dlogz=1e-3 * (DYNESTY_NLIVE - 1) + 0.01,
            kind="static",
        ),
        iterations=int(r["niter"]),
    )


def run_nautilus(p, seed):
    from nautilus import Sampler

    sampler = Sampler(p.prior_transform, p.ln_like, n_dim=p.ndim, pool=None, seed=seed)
    t0, c0 = time.perf_counter(), time.process_time()
    sampler.run(verbose=False)
    secs, cpu = time.perf_counter() - t0, time.process_time() - c0
    n_eff = float(sampler.n_eff)
    return dict(
        ln_z=float(sampler.log_z),
        err=1.0 / np.sqrt(n_eff),
        seconds=secs,
        cpu_seconds=cpu,
        settings=dict(n_live=2000, n_eff_target=10000, f_live=0.01, n_networks=4, defaults=True),
        n_eff=n_eff,
    )


RUNNERS = dict(dynesty=run_dynesty, nautilus=run_nautilus)


def versions():
    import dynesty
    import nautilus
    import scipy
    import sklearn

    return dict(
        python=platform.python_version(),
        numpy=np.__version__,
        scipy=scipy.__version__,
        sklearn=sklearn.__version__,
        dynesty=dynesty.__version__,
        nautilus=nautilus.__version__,
    )


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("prefix", help="PREFIX of PREFIX.npz / PREFIX.json (examples/peer_inputs.rs)")
    ap.add_argument("--tool", action="append", choices=sorted(RUNNERS), help="default: both")
    ap.add_argument("--seed", type=int, default=12)
    ap.add_argument("--out", help="JSON file for the results (default PREFIX.<tool>.json)")
    ap.add_argument("--check-only", action="store_true", help="only check ln L against Rust")
    a = ap.parse_args()

    z, exps, masses = load(a.prefix + ".npz")
    with open(a.prefix + ".json") as f:
        meta = json.load(f)
    prep = Prepared(exps, masses)
    ln_norm = ln_norm_of(exps)
    print(f"{meta['study']}: {prep.n_bins} bins, rho_opt {meta['rho_opt_at_truth']:.1f} at the truth")
    worst = check(prep, ln_norm, z)
    print(f"agreement with Rust: max rel {worst:.2e} (tolerance {REL_TOL:.0e})")
    if a.check_only:
        return
    lo, hi = np.array(meta["prior_lo"]), np.array(meta["prior_hi"])
    models = meta["models"][:2]

    # the likelihood's own rate on this machine now, for the sampler-overhead column
    p0 = Problem(prep, ln_norm, models[0], lo, hi)
    x0 = p0.prior_transform(np.full(p0.ndim, 0.5))
    t0 = time.perf_counter()
    n_rate = 300
    for _ in range(n_rate):
        p0.ln_like(x0)
    lnl_rate = n_rate / (time.perf_counter() - t0)
    print(f"numpy ln L: {lnl_rate:.0f} evals/s")

    for tool in a.tool or ["dynesty", "nautilus"]:
        recs = []
        for m in models:
            p = Problem(prep, ln_norm, m, lo, hi)
            load0 = os.getloadavg()
            r = RUNNERS[tool](p, a.seed)
            r.update(
                tool=tool,
                model=p.name,
                ndim=int(p.ndim),
                calls=p.calls,
                load_before=load0,
                load_after=os.getloadavg(),
            )
            r["lnl_share"] = p.calls / lnl_rate / r["seconds"]
            print(
                f"{tool} {p.name} ({p.ndim} params): ln Z {r['ln_z']:.4f} ± {r['err']:.4f},"
                f" {p.calls} calls, {r['seconds']:.1f} s, CPU {r['cpu_seconds']:.1f} s (load {load0[0]:.2f} → {r['load_after'][0]:.2f})",
                flush=True,
            )
            recs.append(r)
        x, y = recs
        out = dict(
            study=meta["study"],
            rho_opt_at_truth=meta["rho_opt_at_truth"],
            tool=tool,
            seed=a.seed,
            versions=versions(),
            numpy_lnl_evals_per_s=lnl_rate,
            check_max_rel=worst,
            single_process=True,
            models=recs,
            pair=[x["model"], y["model"]],
            ln_b=x["ln_z"] - y["ln_z"],
            err=float(np.hypot(x["err"], y["err"])),
            seconds=x["seconds"] + y["seconds"],
            cpu_seconds=x["cpu_seconds"] + y["cpu_seconds"],
            calls=x["calls"] + y["calls"],
            nproc=os.cpu_count(),
            when=time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime()),
        )
        print(
            f"{tool}: ln B_{x['model']}{y['model']} = {out['ln_b']:.4f} ± {out['err']:.4f}"
            f" in {out['seconds']:.1f} s, CPU {out['cpu_seconds']:.1f} s ({out['calls']} calls)",
            flush=True,
        )
        path = a.out or f"{a.prefix}.{tool}.json"
        if a.out and len(a.tool or [1, 2]) > 1:
            path = a.out.replace(".json", f".{tool}.json")
        with open(path, "w") as f:
            json.dump(out, f, indent=1)
        print(f"wrote {path}")


if __name__ == "__main__":
    main()
