"""A real cross-check: emcee driving occam.Likelihood on the Table I study (TN3045 experiment 1,
K14 Table I truth) recovers the posterior means of occam's own sampler (`occam.fit`).

Criterion, fixed before looking at the numbers: for every parameter
``|mean_emcee − mean_occam| < K · sqrt(MCSE_emcee² + MCSE_occam²)`` with ``K = 4`` (seven
parameters: a false alarm for correct samplers has probability ≈ 7 × 6e-5), where
``MCSE = sd / sqrt(ESS)``; occam's ESS is its summary's (over its chains), emcee's is
``steps × walkers / τ`` with τ the largest integrated autocorrelation time over parameters
(emcee.autocorr). The same test with ``K_SD = 4`` on the standard deviations, whose relative
Monte-Carlo error is ``≈ 1 / sqrt(2 ESS)``. occam.fit samples the study's relative-binned
likelihood; emcee samples the exact one through occam.Likelihood, so the check also covers the
relative-binning approximation.
"""

import numpy as np
import pytest

import occam
from conftest import TN3045

emcee = pytest.importorskip("emcee")

K = 4.0
K_SD = 4.0
WALKERS = 32
BURN = 600
STEPS = 3000


def test_emcee_recovers_occams_posterior(tmp_path):
    fit = occam.fit(TN3045, output=tmp_path / "fit")
    rows = fit.summary["rows"]
    lik = occam.Likelihood.from_study(TN3045)
    assert lik.param_names == [r["name"] for r in rows]
    p = lik.ndim
    # start: a small ball from the Fisher covariance at the reference (the Table I truth)
    cov = np.linalg.inv(lik.fisher(lik.reference))
    rng = np.random.default_rng(11)
    p0 = rng.multivariate_normal(lik.reference, cov, size=WALKERS)
    assert np.all(np.isfinite(lik.ln_posterior(p0)))
    sampler = emcee.EnsembleSampler(WALKERS, p, lik.ln_posterior, vectorize=True)
    sampler.random_state = np.random.RandomState(12).get_state()
    sampler.run_mcmc(p0, BURN + STEPS, progress=False)
    chain = sampler.get_chain(discard=BURN)  # (steps, walkers, p)
    tau = emcee.autocorr.integrated_time(chain, quiet=True)
    ess_e = STEPS * WALKERS / np.max(tau)
    flat = chain.reshape(-1, p)
    mean_e, sd_e = flat.mean(axis=0), flat.std(axis=0, ddof=1)
    lines = [
        f"emcee: {WALKERS} walkers × {STEPS} steps after {BURN}, acceptance "
        f"{np.mean(sampler.acceptance_fraction):.2f}, tau max {np.max(tau):.1f}, ESS {ess_e:.0f}",
        f"{'param':<6} {'occam mean ± MCSE':>28} {'emcee mean ± MCSE':>28} {'z':>6} "
        f"{'sd occam':>10} {'sd emcee':>10} {'z_sd':>6}",
    ]
    bad = []
    for k, r in enumerate(rows):
        mcse_o = r["sd"] / np.sqrt(r["ess"])
        mcse_e = sd_e[k] / np.sqrt(ess_e)
        z = (mean_e[k] - r["mean"]) / np.hypot(mcse_o, mcse_e)
        z_sd = (sd_e[k] / r["sd"] - 1) / np.sqrt(1 / (2 * r["ess"]) + 1 / (2 * ess_e))
        lines.append(
            f"{r['name']:<6} {r['mean']:>14.6e} ± {mcse_o:<10.2e} {mean_e[k]:>14.6e} ± "
            f"{mcse_e:<10.2e} {z:>6.2f} {r['sd']:>10.3e} {sd_e[k]:>10.3e} {z_sd:>6.2f}"
        )
        if not abs(z) < K:
            bad.append(f"{r['name']}: mean z = {z:.2f}")
        if not abs(z_sd) < K_SD:
            bad.append(f"{r['name']}: sd z = {z_sd:.2f}")
    print("\n".join(lines))
    assert not bad, "\n".join(lines + bad)
