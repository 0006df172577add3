#!/usr/bin/env python3
"""Issue 12's comparison: `occam select` against dynesty and nautilus at equal ln B error.

    bash bench/peer/setup.sh                                   # once
    bench/peer/.venv/bin/python bench/peer/nested_vs_occam.py  # from the repository root

For each regime of the guidance-delay study (X: all 7 LTP parameters, Y: dt1 = dt2 = 0 fixed):
  rho5     examples/guidance-delays-low-snr.toml (`target_snr = 5`: the models cannot be told apart)
  rho60    examples/guidance-delays.toml with `[simulation] target_snr = 60`
  competitive  examples/guidance-delays.toml as shipped (rho_opt = 450: the demo's regime, where
           the two models compete)
  nominal  examples/guidance-delays-high-snr.toml (the nominal TN3045 amplitudes)
it writes the study to runs/nested-peers/<regime>/study.toml, exports the exact likelihood
(`cargo run --release --example peer_inputs`), runs dynesty and nautilus on its numpy peer
(bench/peer/nested_peers.py, single process) unless results for the same likelihood are stored
in bench/peer/results/, runs `occam select` (release build) and prints one table.

Equal error: Monte Carlo error ∝ 1/√time, so a tool that reached σ_tool in t_tool needs
t_tool · (σ_tool / σ_occam)² to reach occam's σ_occam; the ratio is that time over occam's.
occam's ln B is its reference estimator's (the RJMCMC bridge when it has a number).

Peer runs take minutes (dynesty and nautilus need 1e5–1e6 evaluations of a ~3000/s ln L), so
stored peer results are reused when the exported likelihood is the same (same ln L at the check
points to 9 digits); --rerun-peers forces new runs. `occam select` always runs anew.
"""

import argparse
import hashlib
import json
import os
import re
import resource
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
RESULTS = os.path.join(HERE, "results")
TOOLS = ("dynesty", "nautilus")


def rho60_study(text):
    new, n = re.subn(r"(?m)^target_snr\s*=\s*[0-9.eE+-]+", "target_snr = 60.0", text)
    if n != 1:
        sys.exit("examples/guidance-delays.toml has no `target_snr = …` line to set to 60")
    return new


REGIMES = {
    "rho5": ("examples/guidance-delays-low-snr.toml", lambda t: t),
    "rho60": ("examples/guidance-delays.toml", rho60_study),
    "competitive": ("examples/guidance-delays.toml", lambda t: t),
    "nominal": ("examples/guidance-delays-high-snr.toml", lambda t: t),
}


def sh(cmd, **kw):
    print("$", " ".join(cmd), flush=True)
    return subprocess.run(cmd, cwd=ROOT, check=True, **kw)


def fingerprint(prefix):
    """The exported likelihood, to 9 digits: its ln L at the check points and its bins."""
    import numpy as np

    z = np.load(prefix + ".npz")
    vals = [f"{v:.9e}" for v in np.concatenate([z["lnl"], z["ln_norm"], z["theta"].ravel()])]
    vals.append(str(sum(z[f"e{j}.freqs"].size for j in range(int(z["n_experiments"][0])))))
    return hashlib.sha256(",".join(vals).encode()).hexdigest()[:16]


def run_peer(regime, prefix, tool, fp, rerun, seed):
    path = os.path.join(RESULTS, f"{regime}.{tool}.json")
    if not rerun and os.path.exists(path):
        with open(path) as f:
            r = json.load(f)
        if r.get("fingerprint") == fp:
            print(f"{regime} {tool}: reusing {os.path.relpath(path, ROOT)} ({r['when']})")
            return r
        print(f"{regime} {tool}: stored result is for another likelihood; rerunning")
    sh(
        [sys.executable, os.path.join(HERE, "nested_peers.py"), prefix, "--tool", tool,
         "--seed", str(seed), "--out", path]
    )
    with open(path) as f:
        r = json.load(f)
    r["fingerprint"] = fp
    r["regime"] = regime
    with open(path, "w") as f:
        json.dump(r, f, indent=1)
    return r


def run_occam(study):
    def cpu():
        u = resource.getrusage(resource.RUSAGE_CHILDREN)
        return u.ru_utime + u.ru_stime

    l0, c0 = os.getloadavg(), cpu()
    sh(["target/release/occam", "select", study, "--quiet"], stdout=subprocess.DEVNULL)
    l1, c1 = os.getloadavg(), cpu()
    out = os.path.join(os.path.dirname(study), "select", "summary.json")
    with open(os.path.join(ROOT, out)) as f:
        s = json.load(f)
    p = s["pairs"][0]
    est = {e["method"]: e for e in p["estimates"]}
    ref = est[p["reference"]]
    used = ref
    if ref["std_err"] is None or ref["std_err"] <= 0:
        with_err = [e for e in p["estimates"] if e["std_err"] and e["ln_b"] is not None]
        if not with_err:
            sys.exit(f"{out}: no estimator of occam reports a standard error; nothing to compare at equal error")
        used = min(with_err, key=lambda e: e["std_err"])
    return dict(
        ln_b=used["ln_b"], err=used["std_err"], method=used["method"], reference=p["reference"],
        seconds=s["seconds"], cpu_seconds=c1 - c0, load_before=l0, load_after=l1, rho_opt=s["rho_opt"],
        estimates=p["estimates"],
    )


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--regime", action="append", choices=sorted(REGIMES), help="default: all")
    ap.add_argument("--rerun-peers", action="store_true", help="run dynesty and nautilus even if stored")
    ap.add_argument("--seed", type=int, default=12, help="seed of the peers")
    ap.add_argument("--tool", action="append", choices=TOOLS, help="default: both")
    a = ap.parse_args()
    os.makedirs(RESULTS, exist_ok=True)
    sh(["cargo", "build", "--release", "--quiet", "--bin", "occam", "--example", "peer_inputs"])
    rows = []
    for regime in a.regime or list(REGIMES):
        src, edit = REGIMES[regime]
        d = os.path.join("runs", "nested-peers", regime)
        os.makedirs(os.path.join(ROOT, d), exist_ok=True)
        with open(os.path.join(ROOT, src)) as f:
            text = edit(f.read())
        text, n = re.subn(r'(?m)^output\s*=\s*".*"', f'output = "{d}"', text)
        if n != 1:
            sys.exit(f"{src}: no `output = \"…\"` line")
        study = os.path.join(d, "study.toml")
        with open(os.path.join(ROOT, study), "w") as f:
            f.write(text)
        prefix = os.path.join(ROOT, d, "inputs")
        sh(["target/release/examples/peer_inputs", study, prefix])
        fp = fingerprint(prefix)
        occ = run_occam(study)
        rows.append(dict(regime=regime, tool="occam select", ln_b=occ["ln_b"], err=occ["err"],
                         seconds=occ["seconds"], cpu_seconds=occ["cpu_seconds"], load=occ["load_after"][0], note=occ["method"],
                         occam=occ))
        for tool in a.tool or TOOLS:
            r = run_peer(regime, prefix, tool, fp, a.rerun_peers, a.seed)
            rows.append(dict(regime=regime, tool=tool, ln_b=r["ln_b"], err=r["err"],
                             seconds=r["seconds"], cpu_seconds=r["cpu_seconds"], calls=r["calls"],
                             load=max(m["load_after"][0] for m in r["models"]),
                             note=f"{r['when']}", peer=r, occam_ref=occ))
    print()
    print("| regime | tool | ln B_XY | ± σ | wall s | CPU s | ln L calls | load | wall s at occam's σ |"
          " ratio (wall) | ratio (CPU) | agrees (2σ) |")
    print("| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- |")
    for r in rows:
        if r["tool"] == "occam select":
            occ = r["occam"]
            print(f"| {r['regime']} | occam select ({occ['method']}) | {r['ln_b']:.3f} | {r['err']:.3f} |"
                  f" {r['seconds']:.1f} | {r['cpu_seconds']:.1f} | – | {r['load']:.1f} | {r['seconds']:.1f} | 1 | 1 | – |")
            continue
        occ = r["occam_ref"]
        scale = (r["err"] / occ["err"]) ** 2
        t_eq = r["seconds"] * scale
        r["time_at_occam_err"] = t_eq
        r["ratio"] = t_eq / occ["seconds"]
        r["ratio_cpu"] = r["cpu_seconds"] * scale / occ["cpu_seconds"]
        agree = abs(r["ln_b"] - occ["ln_b"]) <= 2.0 * (r["err"] ** 2 + occ["err"] ** 2) ** 0.5
        r["agrees_2sigma"] = agree
        print(f"| {r['regime']} | {r['tool']} | {r['ln_b']:.3f} | {r['err']:.3f} | {r['seconds']:.1f} |"
              f" {r['cpu_seconds']:.1f} | {r['calls']} | {r['load']:.1f} | {t_eq:.0f} | {r['ratio']:.0f}× |"
              f" {r['ratio_cpu']:.0f}× | {'yes' if agree else 'NO'} |")
    # a run of some regimes replaces their rows and keeps the others' (each row has its `when`)
    out = os.path.join(RESULTS, "comparison.json")
    done = {r["regime"] for r in rows}
    kept = []
    if os.path.exists(out):
        with open(out) as f:
            kept = [r for r in json.load(f)["rows"] if r["regime"] not in done]
    when = time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime())
    for r in rows:
        r.setdefault("when", when)
    with open(out, "w") as f:
        json.dump(dict(when=when, rows=kept + rows), f, indent=1)
    print(f"\nwrote {os.path.relpath(out, ROOT)}; targets: occam ≥ 1000× dynesty and ≥ 100× nautilus")


if __name__ == "__main__":
    main()
