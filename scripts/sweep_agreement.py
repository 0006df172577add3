#!/usr/bin/env python3
"""How well two estimators' error bars agree over the realisations of the recorded sweeps
(tests/golden/sweep-*.json): for every realisation's pair where both rows have a number,
z = (row − against) / √(σ_row² + σ_against²), and the RMS of z, its 1σ coverage and mean.
Two unbiased rows with honest errors give RMS ≈ 1 and coverage ≈ 0.683.

    python3 scripts/sweep_agreement.py [ROW] [AGAINST]
        # defaults: "Bridge sampling" against "RJMCMC bridge"; pairs split by whether both
        # models were visited (two-sided jump rows) or not (one-sided)
"""

import json
import math
import re
import sys
from pathlib import Path


def load(path):
    g = json.loads(Path(path).read_text())
    t = g["sweep.json"]
    t = "\n".join(t) if isinstance(t, list) else t
    return json.loads(re.sub(r",(\s*[}\]])", r"\1", t))


def main():
    row = sys.argv[1] if len(sys.argv) > 1 else "Bridge sampling"
    against = sys.argv[2] if len(sys.argv) > 2 else "RJMCMC bridge"
    for path in sorted(Path("tests/golden").glob("sweep-*.json")):
        z = {"two-sided": [], "one-sided": []}
        for point in load(path)["points"]:
            for r in point["realisations"]:
                for p in (r.get("outcome") or {}).get("pairs", []):
                    e = {x["method"]: x for x in p["estimates"]}
                    a, b = e.get(row), e.get(against)
                    if not a or not b or a["ln_b"] is None or b["ln_b"] is None:
                        continue
                    side = "two-sided" if e["RJMCMC visits"]["ln_b"] is not None else "one-sided"
                    z[side].append((a["ln_b"] - b["ln_b"]) / math.hypot(a["std_err"], b["std_err"]))
        for side, v in z.items():
            if v:
                rms = math.sqrt(sum(x * x for x in v) / len(v))
                cover = sum(abs(x) < 1 for x in v) / len(v)
                print(
                    f"{path.stem} {side}: {len(v)} pairs, RMS z {rms:.2f}, 1σ coverage {cover:.2f}, "
                    f"mean z {sum(v) / len(v):+.2f}, |z| > 2: {sum(abs(x) > 2 for x in v)}"
                )


if __name__ == "__main__":
    main()
