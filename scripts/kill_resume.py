#!/usr/bin/env python3
"""Kill/resume trials: `occam fit|select|sweep` killed with SIGKILL at spread-out moments,
then continued with --resume; every trial's outputs must equal an uninterrupted run's.

usage: scripts/kill_resume.py COMMAND STUDY TRIALS [--bin target/release/occam]

Numbers are compared with the timing fields (seconds, iterations per second) removed; npz
files and tables byte for byte. Prints one line per trial and a summary; exits 1 on any
mismatch.
"""
import json, os, random, shutil, signal, subprocess, sys, tempfile, time

def strip_timing(v):
    if isinstance(v, dict):
        return {k: strip_timing(x) for k, x in v.items()
                if not (k.startswith("seconds") or k.endswith("per_second") or k == "took")}
    if isinstance(v, list):
        return [strip_timing(x) for x in v]
    return v

COMPARE = {
    "fit": ["chains.npz", "table.txt", "summary.json"],
    "select": ["summary.json", "table.txt", "residual_psd.npz"],
    "sweep": ["sweep.json", "sweep.npz", "table.txt"],
}

def same(a, b, name):
    pa, pb = os.path.join(a, name), os.path.join(b, name)
    if not (os.path.exists(pa) and os.path.exists(pb)):
        return os.path.exists(pa) == os.path.exists(pb)
    if name.endswith(".json"):
        return strip_timing(json.load(open(pa))) == strip_timing(json.load(open(pb)))
    return open(pa, "rb").read() == open(pb, "rb").read()

def run(binary, cmd, study, out, resume=False):
    args = [binary, cmd, study, "-o", out, "-q"] + (["--resume"] if resume else [])
    return subprocess.run(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)

def main():
    cmd, study, trials = sys.argv[1], sys.argv[2], int(sys.argv[3])
    binary = sys.argv[sys.argv.index("--bin") + 1] if "--bin" in sys.argv else "target/release/occam"
    work = tempfile.mkdtemp(prefix=f"kill-{cmd}-")
    ref = os.path.join(work, "ref")
    t0 = time.time()
    r = run(binary, cmd, study, ref)
    full = time.time() - t0
    if r.returncode != 0:
        print(r.stderr); sys.exit(2)
    rng = random.Random(12345)
    bad = resumed = fresh = 0
    for k in range(trials):
        out = os.path.join(work, f"t{k}")
        # kill moments spread over the whole run (stratified), never before it starts
        at = full * (k + rng.random()) / trials
        p = subprocess.Popen([binary, cmd, study, "-o", out, "-q"],
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(at)
        p.send_signal(signal.SIGKILL)
        p.wait()
        r = run(binary, cmd, study, out, resume=True)
        if r.returncode != 0 and "nothing to resume" in r.stderr:
            fresh += 1
            r = run(binary, cmd, study, out)
        else:
            resumed += 1
        ok = r.returncode == 0 and all(same(ref, out, f) for f in COMPARE[cmd])
        leftovers = [f for f in os.listdir(out) if ".tmp" in f or f == ".staging"]
        ok = ok and not leftovers
        bad += not ok
        print(f"trial {k}: killed at {at:.2f} s of {full:.2f} s; "
              f"{'resumed' if 'resuming from' in r.stdout else 'started afresh'}; "
              f"{'identical' if ok else 'MISMATCH ' + r.stderr[-300:] + str(leftovers)}")
        shutil.rmtree(out, ignore_errors=True)
    print(f"{cmd} {study}: {trials} trials, {resumed} resumed, {fresh} had nothing to resume, "
          f"{bad} mismatches (uninterrupted run {full:.1f} s)")
    shutil.rmtree(work, ignore_errors=True)
    sys.exit(1 if bad else 0)

main()
