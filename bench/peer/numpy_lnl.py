#!/usr/bin/env python3
"""numpy peer of occam's exact full-band ln L (LtpLikelihood::ln_likelihood_full).

    bench/peer/.venv/bin/python bench/peer/numpy_lnl.py INPUTS.npz

benches/likelihood.rs writes INPUTS.npz (the in-band spectra of every experiment of the
Table I study and the Rust ln L at a few parameter points), runs this script and parses the
line starting with "PEER ". The script

1. evaluates the same closed-loop model (shared/design/ltp-model.md §3.2, §8.2),
       P = D + E M A K S,   h = E S P⁻¹ M A K T I,   R = Y − h,
       ln L = −Σ_k R_kᴴ C_k⁻¹ R_k − Σ_k ln(π² det C_k),
   vectorised over all bins (no Python loop over bins), with everything that does not
   depend on θ prepared once (`Prepared`; the algebra is in the comment above `Phasor`);
2. checks it against the Rust values to 1e−9 relative (exit status 1 if not);
3. times it: best of REPEATS runs of EVALS evaluations (the median run is printed too),
   θ changed slightly at every evaluation (as the Rust bench does) so nothing can be
   reused between calls.

`Direct` is the project's first peer, kept unchanged: the plain transcription of the loop
(one complex expression per matrix element, `np.exp` for the delays). bench/peer/
compare_peers.py checks the fast path against it and times the two side by side.

BLAS is pinned to one thread (OPENBLAS_NUM_THREADS=1, set before numpy is imported) so that
the peer and the single-threaded Rust kernel are compared core for core.
"""

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

REL_TOL = 1e-9
REPEATS = 7
EVALS = 50


def load(path):
    """The raw per-experiment inputs written by benches/likelihood.rs."""
    z = np.load(path)
    n_exp = int(z["n_experiments"][0])
    exps = []
    for j in range(n_exp):
        y, inj = z[f"e{j}.y"], z[f"e{j}.inj"]
        exps.append(
            dict(
                freqs=np.ascontiguousarray(z[f"e{j}.freqs"], dtype=np.float64),
                y=[np.ascontiguousarray(y[:, c], dtype=np.complex128) for c in range(2)],
                inj=[np.ascontiguousarray(inj[:, c], dtype=np.complex128) for c in range(2)],
                a=np.ascontiguousarray(z[f"e{j}.cinv_a"], dtype=np.float64),
                b=np.ascontiguousarray(z[f"e{j}.cinv_b"], dtype=np.complex128),
                c=np.ascontiguousarray(z[f"e{j}.cinv_c"], dtype=np.float64),
                cdf=np.ascontiguousarray(z[f"e{j}.cdf"], dtype=np.complex128),
                csus=np.ascontiguousarray(z[f"e{j}.csus"], dtype=np.complex128),
                eoms=np.ascontiguousarray(z[f"e{j}.e_oms"], dtype=np.complex128),
            )
        )
    m1, m2, msc = (float(x) for x in z["masses"])
    return z, exps, (m1, m2, msc)


def ln_norm_of(exps):
    """−Σ ln(π² det C_k); C_k⁻¹ = [[a, b], [b*, c]] ⇒ det C_k = 1/(a c − |b|²)."""
    s = 0.0
    for e in exps:
        det_inv = e["a"] * e["c"] - (e["b"].real ** 2 + e["b"].imag ** 2)
        s -= np.sum(2.0 * np.log(np.pi) - np.log(det_inv))
    return s


# ----------------------------------------------------------------------------------------
# The plain transcription (the project's first peer): whole-array complex expressions.
# ----------------------------------------------------------------------------------------


class Direct:
    def __init__(self, exps, masses):
        m1, m2, msc = masses
        cat = lambda f: np.concatenate([f(e) for e in exps])  # noqa: E731
        omega = 2.0 * np.pi * cat(lambda e: e["freqs"])
        eoms = cat(lambda e: e["eoms"])
        cdf, csus = cat(lambda e: e["cdf"]), cat(lambda e: e["csus"])
        self.d = dict(
            omega=omega,
            s2=-omega * omega,
            y0=cat(lambda e: e["y"][0]),
            y1=cat(lambda e: e["y"][1]),
            i0=cat(lambda e: e["inj"][0]),
            i1=cat(lambda e: e["inj"][1]),
            cdf=cdf,
            csus=csus,
            eoms=eoms,
            ecdf=eoms * cdf,
            ecsus=eoms * csus,
            a=cat(lambda e: e["a"]),
            b=cat(lambda e: e["b"]),
            c=cat(lambda e: e["c"]),
            e1=m1 / msc,
            e2=m2 / msc,
        )

    def residual_power(self, th):
        """Σ_k R_kᴴ C_k⁻¹ R_k over every in-band bin."""
        d = self.d
        w1, w2, dt1, dt2, adf, asus, d21 = th
        e1, e2 = d["e1"], d["e2"]
        # P = D + E M A K S, D = −ω² + W, M A K = [[k1, e2 k2], [0, k2]], S = [[1, 0], [δ21, 1]]
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


# ----------------------------------------------------------------------------------------
# The fast path.
# ----------------------------------------------------------------------------------------
#
# Write σ = −ω², u = E C_df, v = E C_sus (E = OMS phasor), α = A_df, β = A_sus, δ = δ21,
# e1 = m1/m_sc, e2 = m2/m_sc and the stiffness combinations of LoopKernel
#     a00 = w1 (1 + e1) + w2 e2,  a01 = w2 e2,  a10 = w2 − w1.
# Expanding Cramer's rule for P = [[α u + β δ e2 v + σ + a00, β e2 v + a01],
#                                  [β δ v + a10,             β v + σ + w2 ]]
# the β² terms of det P cancel and every piece becomes a linear combination, with real
# θ-only coefficients, of fixed per-bin arrays:
#     det P = αβ·uv + α·uσ + α w2·u + βρ·vσ + β w1 μ·v + σ² + (a00 + w2)·σ + w1 w2 μ,
#     ρ = δ e2 + 1,  μ = 1 + e1 + e2   (a00 w2 − a01 a10 = w1 w2 μ, a00 − e2 a10 = w1 μ),
# and, with A = E C_df I1, B = E C_sus I12 (injection DFTs), t_j = e^{−iωΔt_j},
#     det P · h_o1  = t1 [αβ·vA + α w2·A + α·σA] + t2 [β e2·σB]
#     det P · h_o12 = t1 [α(δ w2 − a10)·A + αδ·σA] + t2 [αβ·uB + β(a00 − e2 a10)·B + βρ·σB].
# The quadratic form is diagonalised once per bin, C⁻¹ = [[a, b], [b*, c]]:
#     Rᴴ C⁻¹ R = a |R0 + γ R1|² + c' |R1|²,  γ = b/a,  c' = c − |b|²/a,
# and √a, √a γ, √c' are folded into Y and into the fixed arrays, so that per θ
#     Σ_k Rᴴ C⁻¹ R = Σ_k (|Z0|² + |Z1|²) / |det P|²,   Z = Ỹ det P − Σ_j t_j Ñ_j.
# The fixed arrays are stored as rows of float64 matrices (complex viewed as interleaved
# re, im), so each of det P (5 rows; its real polynomial in σ is added separately), Ñ_o1
# (6 rows: √a·X and √a γ·X) and Ñ_o12 (3 rows) is one matrix–vector product (BLAS dgemv;
# one 3-row product with a block-sparse coefficient matrix was several times slower). Only
# injection channels that are non-zero in an experiment get arrays. With one active
# channel j, |Z_r| = |Ỹ_r det P t_j* − Ñ_r|: one phasor product per bin. Experiments with the
# same number of bins and of active channels are stacked on a leading axis (one numpy call
# for all of them); if they also share ω and the controllers, det P is computed once.
#
# Delay phasors on the uniform DFT grid ω_k = ω_0 + k dω: with k = q·BLOCK + l,
#     e^{−iω_k Δt} = e^{−iω_{qBLOCK} Δt} · e^{−i(ω_l − ω_0) Δt},
# an outer product of two short exp's (≈ 2√n exponentials instead of n), one rounding per
# bin. Non-uniform grids fall back to np.exp on the whole array.


def _block(n):
    return max(1, int(np.ceil(np.sqrt(n))))


def _uniform(omega):
    d = np.diff(omega)
    return omega.size > 1 and bool(np.all(np.abs(d - d[0]) <= 1e-12 * np.abs(omega).max()))


class Phasor:
    """e^{+iωΔt_e} (the conjugate of the delay phasor, which is what is used) on the grids
    ω (E, n) of a stack of E experiments, one Δt_e per experiment, into a reused buffer."""

    def __init__(self, omega):
        n_e, n = omega.shape
        self.uniform = all(_uniform(w) for w in omega)
        if self.uniform:
            bl = _block(n)
            nq = -(-n // bl)
            self.coarse = np.ascontiguousarray(1j * omega[:, ::bl])  # i ω_{q·BLOCK}
            self.fine = np.ascontiguousarray(1j * (omega[:, :bl] - omega[:, :1]))  # i (ω_l − ω_0)
            self.buf = np.empty((n_e, nq, bl), dtype=np.complex128)
            self.flat = self.buf.reshape(n_e, -1)[:, :n]
        else:
            self.iomega = np.ascontiguousarray(1j * omega)
            self.flat = np.empty((n_e, n), dtype=np.complex128)

    def conj(self, dt):
        dt = dt[:, None]
        if self.uniform:
            c = np.exp(self.coarse * dt)
            f = np.exp(self.fine * dt)
            np.multiply(c[:, :, None], f[:, None, :], out=self.buf)
        else:
            np.exp(self.iomega * dt, out=self.flat)
        return self.flat


def _rows(rows):
    """Complex per-bin arrays as the rows of one float64 matrix (re, im interleaved)."""
    return np.ascontiguousarray(np.stack(rows)).view(np.float64)


class Group:
    """E experiments with the same number of bins and of active injection channels, stacked
    on a leading axis so that each step is one numpy call for all of them."""

    def __init__(self, exps, masses):
        m1, m2, msc = masses
        self.e1, self.e2 = m1 / msc, m2 / msc
        n = exps[0]["freqs"].size
        self.n = n
        self.n_exp = len(exps)
        omega = np.stack([2.0 * np.pi * e["freqs"] for e in exps])
        self.sig = -omega * omega  # (E, n)
        self.chans = np.array([_active(e) for e in exps])  # (E, n_chan)
        nch = self.chans.shape[1]
        det_b, b0, b1, ytil = [], [], [], []
        for e, sig in zip(exps, self.sig):
            eoms = e["eoms"]
            u = eoms * e["cdf"]
            v = eoms * e["csus"]
            a, b, c = e["a"], e["b"], e["c"]
            sa = np.sqrt(a)
            gam = b / a
            sc = np.sqrt(c - (b.real**2 + b.imag**2) / a)
            # det P without its real polynomial in σ (added per θ)
            det_b.append(_rows([u * v, u * sig, u, v * sig, v]))
            inj_fac = (eoms * e["cdf"] * e["inj"][0], eoms * e["csus"] * e["inj"][1])
            r0, r1 = [], []
            for ch in _active(e):
                x = inj_fac[ch]
                # X: (vA, A, σA) for channel 0; (uB, B, σB) for channel 1
                xs = [(v if ch == 0 else u) * x, x, sig * x]
                r0.append(_rows([sa * xi for xi in xs] + [sa * gam * xi for xi in xs]))
                r1.append(_rows([sc * xi for xi in xs]))
            b0.append(np.stack(r0))
            b1.append(np.stack(r1))
            ytil.append(np.stack([sa * (e["y"][0] + gam * e["y"][1]), sc * e["y"][1]]))
        # experiments on one grid with the same controllers (as in the Table I study) share
        # det P: it is then computed once for the group and broadcast
        shared = all(np.array_equal(d, det_b[0]) for d in det_b)
        self.det_basis = np.ascontiguousarray(np.stack(det_b[:1] if shared else det_b))
        n_det = self.det_basis.shape[0]  # (n_det, 5, 2n), n_det = 1 or E
        self.sig_det = np.ascontiguousarray(self.sig[:n_det])
        self.b0 = np.ascontiguousarray(np.stack(b0))  # (E, n_chan, 6, 2n)
        self.b1 = np.ascontiguousarray(np.stack(b1))  # (E, n_chan, 3, 2n)
        self.ytil = np.ascontiguousarray(np.stack(ytil))  # (E, 2, n)
        self.phasor = Phasor(omega)
        # outputs: det P and (Ñ_o1, Ñ_o12) per channel, complex viewed as interleaved float64
        self.dout = np.empty((n_det, 2 * n))
        self.det = self.dout.view(np.complex128)
        self.det_re = self.dout[:, 0::2]
        self.out = np.empty((self.n_exp, 2 * nch, 2 * n))
        self.g = self.out.view(np.complex128)
        self.dd = np.empty((n_det, 2 * n))
        self.z = np.empty((self.n_exp, 2, n), dtype=np.complex128)
        self.y2 = np.empty((self.n_exp, 2 * n))
        self.p = np.empty((self.n_exp, n), dtype=np.complex128)
        self.r1 = np.empty((self.n_exp, n))
        self.r2 = np.empty((n_det, n))

    def residual_power(self, w1, w2, dt1, dt2, adf, asus, d21):
        e1, e2 = self.e1, self.e2
        a00 = w1 * (1.0 + e1) + w2 * e2
        a10 = w2 - w1
        ab = adf * asus
        rho = d21 * e2 + 1.0
        mu = 1.0 + e1 + e2
        out, g, sig = self.out, self.g, self.sig_det
        # det P = αβ·uv + α·uσ + α w2·u + βρ·vσ + β w1 μ·v + σ² + (a00 + w2)σ + w1 w2 μ
        cdet = np.array((ab, adf, adf * w2, asus * rho, asus * w1 * mu))
        np.matmul(cdet, self.det_basis, out=self.dout)
        r1, r2 = self.r1, self.r2
        np.add(sig, a00 + w2, out=r2)
        np.multiply(r2, sig, out=r2)
        r2 += w1 * w2 * mu
        np.add(self.det_re, r2, out=self.det_re)
        # Ñ coefficients per channel: on (vA, A, σA) / (uB, B, σB), row o1 then row o12
        n1 = np.array(
            ((0.0, adf * (d21 * w2 - a10), adf * d21), (ab, asus * (a00 - e2 * a10), asus * rho))
        )
        n0 = np.array(((ab, adf * w2, adf), (0.0, 0.0, asus * e2)))
        n01 = np.concatenate((n0, n1), axis=1)  # row o1 with its γ-mixed copies
        for i in range(self.chans.shape[1]):
            ch = self.chans[:, i]
            np.matmul(n01[ch][:, None, :], self.b0[:, i], out=out[:, 2 * i : 2 * i + 1])
            np.matmul(n1[ch][:, None, :], self.b1[:, i], out=out[:, 2 * i + 1 : 2 * i + 2])
        det = self.det
        z, p = self.z, self.p
        dts = np.array((dt1, dt2))
        if self.chans.shape[1] == 1:
            # |Z_r| = |Ỹ_r det t* − Ñ_r|
            np.multiply(det, self.phasor.conj(dts[self.chans[:, 0]]), out=p)
            np.multiply(self.ytil, p[:, None, :], out=z)
            np.subtract(z, g[:, 0:2], out=z)
        else:
            # t1* common: |Z_r| = |Ỹ_r det t1* − Ñ_r1 − (t2 t1*) Ñ_r2|
            np.multiply(det, self.phasor.conj(np.full(self.n_exp, dt1)), out=p)
            np.multiply(self.ytil, p[:, None, :], out=z)
            np.subtract(z, g[:, 0:2], out=z)
            t21 = np.conj(self.phasor.conj(np.full(self.n_exp, dt2 - dt1)))
            z -= g[:, 2:4] * t21[:, None, :]
        # Σ_k (|Z0|² + |Z1|²)/|det|²: squares on the float64 views, strided pair sums
        zf = z.view(np.float64)
        np.multiply(zf, zf, out=zf)  # in place: Z is not needed any more
        np.add(zf[:, 0], zf[:, 1], out=self.y2)
        np.add(self.y2[:, 0::2], self.y2[:, 1::2], out=r1)
        dd = self.dd
        np.multiply(self.dout, self.dout, out=dd)
        np.add(dd[:, 0::2], dd[:, 1::2], out=r2)  # |det P|², broadcast if shared
        np.divide(r1, r2, out=r1)
        return r1.sum()


def _active(e):
    chans = [ch for ch in (0, 1) if np.any(e["inj"][ch] != 0)]
    if not chans:
        raise ValueError("an experiment without injections")
    return chans


class Prepared:
    """The fast path: experiments grouped by (bins, active channels), one Group each."""

    def __init__(self, exps, masses):
        groups = {}
        for e in exps:
            groups.setdefault((e["freqs"].size, len(_active(e))), []).append(e)
        self.groups = [Group(g, masses) for g in groups.values()]
        self.n_bins = sum(e["freqs"].size for e in exps)

    def residual_power(self, th):
        th = [float(x) for x in th]
        return sum(g.residual_power(*th) for g in self.groups)


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: numpy_lnl.py INPUTS.npz (written by `cargo bench --bench likelihood`)")
    z, exps, masses = load(sys.argv[1])
    prep = Prepared(exps, masses)
    ln_norm = ln_norm_of(exps)
    n_bins = prep.n_bins
    print(f"numpy {np.__version__}, {n_bins} bins")

    # 1. agreement with the Rust ln L at every check point
    thetas, lnl_rust = z["theta"], z["lnl"]
    ln_norm_rust = float(z["ln_norm"][0])
    ok = True
    worst = 0.0
    for th, want in zip(thetas, lnl_rust):
        rp_got = prep.residual_power(th)
        got = -rp_got + ln_norm
        rel = abs(got - want) / abs(want)
        # the θ-dependent part alone, so a large constant cannot hide a disagreement
        rp_rust = ln_norm_rust - want
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
    prep.residual_power(th)  # warm-up
    times = []
    k = 0
    for _ in range(REPEATS):
        acc = 0.0
        t0 = time.perf_counter()
        for _ in range(EVALS):
            k += 1
            th[4] = truth[4] + 1e-9 * (k % 7)
            acc += -prep.residual_power(th) + ln_norm
        times.append((time.perf_counter() - t0) / EVALS)
    assert np.isfinite(acc)
    best = min(times)
    median = float(np.median(times))
    print(
        f"PEER agreement=ok max_rel={worst:.3e} evals_per_s={1.0 / best:.6g}"
        f" time_per_eval_s={best:.6g} median_evals_per_s={1.0 / median:.6g}"
        f" numpy={np.__version__} bins={n_bins}"
        f" repeats={REPEATS} evals={EVALS}"
    )


if __name__ == "__main__":
    main()
