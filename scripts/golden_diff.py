#!/usr/bin/env python3
"""Every difference between the recorded golden outputs at a git revision and those in the
working tree (tests/golden/*.json), number by number: what a commit that re-records goldens
shows in its message.

    python3 scripts/golden_diff.py [REV]        # REV defaults to HEAD

For each golden case and each output file it records:
* JSON files (summary.json, sweep.json, …): every leaf that was added, removed or changed,
  numbers with their old and new value and the difference (wall-clock fields — `seconds`,
  `seconds_*`, `*_per_second`, byte counts — are left out, as tests/golden.rs leaves them out);
* text files (tables, resolved studies): the changed lines;
* binary files (npz, png, svg; recorded as SHA-256): whether the bytes changed.
A changed number that has an error bar in the same output is shown beside it, with the change
in units of the old and new error bars combined in quadrature (two independent runs): `std_err` (or `err`) beside an `ln_b`, `ln_z` or `ln_z_shift`; the posterior
`sd` beside an estimate's `map` and `mean` (and a model's `map[j]`, whose sd is that of
`estimates[j]`).

    python3 scripts/golden_diff.py --bars [REV]  # only the numbers that have an error bar,
                                                 # and a count of the other changes per file
    python3 scripts/golden_diff.py --references [REV]
                                                 # only the select pairs whose reference row
                                                 # changed: its ln B before and after, in units
                                                 # of the two rows' errors combined
    python3 scripts/golden_diff.py --errors [REV]
                                                 # only the changed error bars (`std_err`,
                                                 # `err`), each with new ÷ old, and per file
                                                 # the range of those ratios

Exit status 0 always; the last line counts the changes.
"""

import json
import re
import subprocess
import sys
from pathlib import Path

GOLDEN = Path("tests/golden")
WALL_CLOCK = ("seconds", "bytes")


def wall_clock(key):
    return key == "seconds" or key.startswith("seconds_") or key.endswith("_per_second") or key in WALL_CLOCK


def leaves(v, path=""):
    if v == {} or v == []:
        yield path, v
    elif isinstance(v, dict):
        for k, x in v.items():
            if wall_clock(k):
                continue
            yield from leaves(x, f"{path}.{k}" if path else k)
    elif isinstance(v, list):
        for i, x in zip(labels(v), v):
            yield from leaves(x, f"{path}[{i}]")
    else:
        yield path, v


def labels(v):
    """The labels of a list's entries: a select pair's estimator rows by their `method` (so a
    row added or moved shows as that, not as every later row changed), else their indices."""
    methods = [x.get("method") if isinstance(x, dict) else None for x in v]
    if v and all(isinstance(m, str) for m in methods) and len(set(methods)) == len(methods):
        return methods
    return range(len(v))


def show(v):
    s = json.dumps(v, ensure_ascii=False)
    return s if len(s) <= 160 else s[:157] + "..."


def lookup(v, path):
    """The value at a leaf path such as `models[0].estimates[2].sd`, or None."""
    for part in re.findall(r"[^.\[\]]+|\[[^\]]+\]", path):
        if part.startswith("["):
            label = part[1:-1]
            if not isinstance(v, list):
                v = None
            elif label.isdigit():
                i = int(label)
                v = v[i] if i < len(v) else None
            else:
                v = next((x for x in v if isinstance(x, dict) and x.get("method") == label), None)
        else:
            v = v.get(part) if isinstance(v, dict) else None
        if v is None:
            return None
    return v


def error_bar(new, path):
    """The error bar of the number at `path` in the new output, or None if it has none."""
    head, _, key = path.rpartition(".")
    m = re.fullmatch(r"(.*)\.map\[(\d+)\]", path)
    if m:
        candidates = [f"{m.group(1)}.estimates[{m.group(2)}].sd"]
    elif key in ("ln_b", "ln_z", "ln_z_shift"):
        candidates = [f"{head}.std_err", f"{head}.err"]
    elif key in ("map", "mean"):
        candidates = [f"{head}.sd"]
    else:
        return None
    for c in candidates:
        e = lookup(new, c.lstrip("."))
        if isinstance(e, (int, float)) and not isinstance(e, bool) and e > 0:
            return e
    return None


def compare_json(old, new, bars_only=False):
    a, b = dict(leaves(old)), dict(leaves(new))
    out = []
    others = 0
    for k in a.keys() | b.keys():
        if k not in b:
            out.append(f"    removed {k} = {show(a[k])}")
        elif k not in a:
            out.append(f"    added   {k} = {show(b[k])}")
        elif a[k] != b[k]:
            x, y = a[k], b[k]
            if isinstance(x, (int, float)) and isinstance(y, (int, float)) and not isinstance(x, bool):
                e_old, e = error_bar(old, k), error_bar(new, k)
                if e is not None:
                    both = e if e_old is None else (e * e + e_old * e_old) ** 0.5
                    out.append(
                        f"    changed {k}: {x!r} -> {y!r} (diff {y - x:+.6g}; error bar {e:.4g}, "
                        f"diff = {(y - x) / both:+.2f} combined σ)"
                    )
                    continue
                if not bars_only:
                    out.append(f"    changed {k}: {x!r} -> {y!r} (diff {y - x:+.6g})")
                    continue
            elif not bars_only:
                out.append(f"    changed {k}: {show(x)} -> {show(y)}")
                continue
            others += 1
    if bars_only and others:
        out.append(f"    other   {others} changed leaves without an error bar")
    return sorted(out, key=lambda l: l.split()[1])


def error_changes(old, new):
    """The changed error-bar leaves (last key `std_err` or `err`): (path, old, new)."""
    a, b = dict(leaves(old)), dict(leaves(new))
    out = []
    for k in sorted(a.keys() & b.keys()):
        if not re.search(r"(^|\.)(std_err|err)$", k):
            continue
        x, y = a[k], b[k]
        if isinstance(x, (int, float)) and isinstance(y, (int, float)) and x != y and x:
            out.append((k, x, y))
    return out


def json_pair(old, new):
    """An entry's recorded JSON text before and after, parsed leniently (the golden drops the
    wall-clock lines, which can leave a comma before a closing bracket); None unless both are
    JSON text."""
    o, n = text_of(old), text_of(new)
    if o is None or n is None or o.startswith("sha256:") or not o.lstrip().startswith("{"):
        return None
    lenient = lambda t: json.loads(re.sub(r",(\s*[}\]])", r"\1", t))
    return lenient(o), lenient(n)


def text_of(v):
    """A recorded output as text: goldens keep each text as the list of its lines (earlier ones
    as one string)."""
    return "\n".join(v) if isinstance(v, list) else v


def compare_entry(name, old, new, bars_only=False):
    old, new = text_of(old), text_of(new)
    if old == new:
        return []
    if old is None or new is None:
        return [f"  {name}: {'added' if old is None else 'removed'}"]
    if old.startswith("sha256:") or new.startswith("sha256:"):
        return [f"  {name}: bytes changed"]
    # the recorded JSON has its wall-clock lines cut out (tests/golden.rs), which can leave a
    # comma before a closing bracket
    lenient = lambda t: json.loads(re.sub(r",(\s*[}\]])", r"\1", t))
    try:
        o, n = lenient(old), lenient(new)
    except ValueError:
        ol, nl = old.splitlines(), new.splitlines()
        lines = [f"    - {l}" for l in ol if l not in nl] + [f"    + {l}" for l in nl if l not in ol]
        return [f"  {name}: text changed"] + lines
    return [f"  {name}:"] + compare_json(o, n, bars_only)


def pairs_in(v, path=""):
    """Every select pair (a dict with `reference` and `estimates`) in a JSON tree, by path."""
    if isinstance(v, dict):
        if "reference" in v and isinstance(v.get("estimates"), list):
            yield path, v
        for k, x in v.items():
            yield from pairs_in(x, f"{path}.{k}" if path else k)
    elif isinstance(v, list):
        for i, x in enumerate(v):
            yield from pairs_in(x, f"{path}[{i}]")


def reference_changes(old, new):
    """The pairs whose reference row changed: name, ln B ± σ before and after."""
    before = dict(pairs_in(old))
    out = []
    for path, p in pairs_in(new):
        q = before.get(path)
        if q is None or q["reference"] == p["reference"]:
            continue
        row = lambda pair: next((e for e in pair["estimates"] if e["method"] == pair["reference"]), {})
        a, b = row(q), row(p)
        va, vb, ea, eb = a.get("ln_b"), b.get("ln_b"), a.get("std_err") or 0.0, b.get("std_err") or 0.0
        if va is None or vb is None:
            out.append(f"    {path} {p['x']}/{p['y']}: {q['reference']} -> {p['reference']}")
            continue
        both = (ea * ea + eb * eb) ** 0.5
        z = f"{(vb - va) / both:+.2f} combined σ" if both > 0 else "no error bar"
        out.append(
            f"    {path} {p['x']}/{p['y']}: {q['reference']} {va:.4f} ± {ea:.4f} -> "
            f"{p['reference']} {vb:.4f} ± {eb:.4f} (diff {vb - va:+.4f} = {z})"
        )
    return out


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    bars_only = "--bars" in sys.argv[1:]
    references = "--references" in sys.argv[1:]
    errors = "--errors" in sys.argv[1:]
    rev = args[0] if args else "HEAD"
    files = sorted({p.name for p in GOLDEN.glob("*.json")} | set(
        Path(p).name
        for p in subprocess.run(
            ["git", "ls-tree", "--name-only", f"{rev}:{GOLDEN}"], capture_output=True, text=True
        ).stdout.split()
    ))
    changes = 0
    for f in files:
        old = subprocess.run(["git", "show", f"{rev}:{GOLDEN}/{f}"], capture_output=True, text=True)
        old = json.loads(old.stdout) if old.returncode == 0 else {}
        path = GOLDEN / f
        new = json.loads(path.read_text()) if path.exists() else {}
        lines = []
        for entry in sorted(old.keys() | new.keys()):
            if errors or references:
                both = json_pair(old.get(entry), new.get(entry))
                if both is None:
                    continue
                if errors:
                    found = error_changes(*both)
                    if found:
                        r = [y / x for _, x, y in found]
                        lines.append(f"  {entry}: {len(found)} error bars changed, new ÷ old {min(r):.3f}–{max(r):.3f}")
                        lines += [f"    {k}: {x:.6g} -> {y:.6g} (×{y / x:.3f})" for k, x, y in found]
                else:
                    found = reference_changes(*both)
                    lines += [f"  {entry}:"] + found if found else []
                continue
            lines += compare_entry(entry, old.get(entry), new.get(entry), bars_only)
        if lines:
            print(f"{f}:")
            print("\n".join(lines))
            changes += sum(1 for l in lines if l.startswith("    ") or l.endswith(("changed", "added", "removed")))
    print(f"{changes} change(s) against {rev}")


if __name__ == "__main__":
    main()
