#!/usr/bin/env python3
"""numpy peer of occam's exact full-band ln L (LtpLikelihood::ln_likelihood_full).

    bench/peer/.venv/bin/python bench/peer/numpy_lnl.py INPUTS.npz

benches/likelihood.rs writes INPUTS.npz (the in-band spectra of every experiment of the
Table I study and the Rust ln L at a few parameter points), runs this script and parses the
line starting with "PEER ". The script

1. evaluates the same closed-loop model (shared/design/ltp-model.md §3.2, §8.2),
       P = D + E M A K S,   h = E S P⁻¹ M A K T I,   R = Y − h,
       ln L = −Σ_k R_kᴴ C_k⁻¹ R_k − Σ_k ln(π² det C_k),
   vectorised over all bins of all experiments at once (no Python loop over bins);
2. checks it against the Rust values to 1e−9 relative (exit status 1 if not);
3. times it: best of REPEATS runs of EVALS evaluations, θ changed slightly at every
   evaluation (as the Rust bench does) so nothing can be reused between calls.

The θ-independent inputs (ω, −ω², E·C_df, E·C_sus, the packed C_k⁻¹ and the constant) are
prepared once, as the Rust code prepares them once per likelihood.
"""

import sys
import time

import numpy as np

REL_TOL = 1e-9
REPEATS = 7
EVALS = 50


def load(path):
    z = np.load(path)
    n_exp = int(z["n_experiments"][0])

    def cat(key):
        return np.concatenate([z[f"e{j}.{key}"] for j in range(n_exp)])

    freqs = cat("freqs")
    y = cat("y")  # (n, 2) complex: DFT of (o1, o12)
    inj = cat("inj")  # (n, 2) complex: DFT of the commanded (i1, i12)
    cdf, csus, eoms = cat("cdf"), cat("csus"), cat("e_oms")
    m1, m2, msc = z["masses"]
    omega = 2.0 * np.pi * freqs
    data = dict(
        omega=omega,
        s2=-omega * omega,
        y0=np.ascontiguousarray(y[:, 0]),
        y1=np.ascontiguousarray(y[:, 1]),
        i0=np.ascontiguousarray(inj[:, 0]),
        i1=np.ascontiguousarray(inj[:, 1]),
        cdf=cdf,
        csus=csus,
        eoms=eoms,
        ecdf=eoms * cdf,
        ecsus=eoms * csus,
        a=cat("cinv_a"),
        b=cat("cinv_b"),
        c=cat("cinv_c"),
        e1=m1 / msc,
        e2=m2 / msc,
    )
    # C_k⁻¹ = [[a, b], [b*, c]]  ⇒  det C_k = 1/(a c − |b|²)
    det_inv = data["a"] * data["c"] - (data["b"].real ** 2 + data["b"].imag ** 2)
    data["ln_norm"] = -np.sum(2.0 * np.log(np.pi) - np.log(det_inv))
    return z, data


def residual_power(th, d):
    """Σ_k R_kᴴ C_k⁻¹ R_k over every in-band bin."""
    w1, w2, dt1, dt2, adf, asus, d21 = th
    e1, e2 = d["e1"], d["e2"]
    # P = D + E M A K S with D = −ω² + W, M A K = [[k1, e2 k2], [0, k2]], S = [[1, 0], [δ21, 1]]
    ek1 = adf * d["ecdf"]
    ek2 = asus * d["ecsus"]
    p00 = ek1 + (d21 * e2) * ek2 + (d["s2"] + (w1 * (1.0 + e1) + w2 * e2))
    p01 = e2 * ek2 + w2 * e2
    p10 = d21 * ek2 + (w2 - w1)
    p11 = ek2 + (d["s2"] + w2)
    # w = M A K T I, T = diag(e^{−iωΔt1}, e^{−iωΔt2})
    v1 = np.exp(-1j * dt1 * d["omega"]) * d["i0"]
    v2 = np.exp(-1j * dt2 * d["omega"]) * d["i1"]
    k2v2 = (asus * d["csus"]) * v2
    w0 = (adf * d["cdf"]) * v1 + e2 * k2v2
    # x = P⁻¹ w (2×2 by Cramer), h = E S x
    inv_det = 1.0 / (p00 * p11 - p01 * p10)
    x0 = (p11 * w0 - p01 * k2v2) * inv_det
    x1 = (p00 * k2v2 - p10 * w0) * inv_det
    r0 = d["y0"] - d["eoms"] * x0
    r1 = d["y1"] - d["eoms"] * (d21 * x0 + x1)
    q = (
        d["a"] * (r0.real**2 + r0.imag**2)
        + d["c"] * (r1.real**2 + r1.imag**2)
        + 2.0 * (d["b"] * r0.conj() * r1).real
    )
    return q.sum()


def ln_likelihood(th, d):
    return -residual_power(th, d) + d["ln_norm"]


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: numpy_lnl.py INPUTS.npz (written by `cargo bench --bench likelihood`)")
    z, d = load(sys.argv[1])
    n_bins = d["omega"].size
    print(f"numpy {np.__version__}, {n_bins} bins")

    # 1. agreement with the Rust ln L at every check point
    thetas, lnl_rust = z["theta"], z["lnl"]
    ln_norm_rust = float(z["ln_norm"][0])
    ok = True
    worst = 0.0
    for th, want in zip(thetas, lnl_rust):
        got = ln_likelihood(th, d)
        rel = abs(got - want) / abs(want)
        # the θ-dependent part alone, so a large constant cannot hide a disagreement
        rp_rust = ln_norm_rust - want
        rp_got = residual_power(th, d)
        rel_rp = abs(rp_got - rp_rust) / abs(rp_rust)
        worst = max(worst, rel, rel_rp)
        flag = "ok" if rel <= REL_TOL and rel_rp <= REL_TOL else "MISMATCH"
        print(
            f"  ln L rust {want:.12e}  numpy {got:.12e}  rel {rel:.1e};"
            f"  Σ RᴴC⁻¹R rust {rp_rust:.12e}  numpy {rp_got:.12e}  rel {rel_rp:.1e}  {flag}"
        )
        ok &= flag == "ok"
    if not ok:
        print(f"PEER agreement=fail max_rel={worst:.3e} tol={REL_TOL:.0e}")
        sys.exit(1)

    # 2. timing
    truth = np.array(z["theta_truth"], dtype=float)
    th = truth.copy()
    ln_likelihood(th, d)  # warm-up
    best = float("inf")
    k = 0
    for _ in range(REPEATS):
        acc = 0.0
        t0 = time.perf_counter()
        for _ in range(EVALS):
            k += 1
            th[4] = truth[4] + 1e-9 * (k % 7)
            acc += ln_likelihood(th, d)
        best = min(best, (time.perf_counter() - t0) / EVALS)
    assert np.isfinite(acc)
    print(
        f"PEER agreement=ok max_rel={worst:.3e} evals_per_s={1.0 / best:.6g}"
        f" time_per_eval_s={best:.6g} numpy={np.__version__} bins={n_bins}"
        f" repeats={REPEATS} evals={EVALS}"
    )


if __name__ == "__main__":
    main()
