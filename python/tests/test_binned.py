"""occam.Likelihood(binned=True) and map(): the command line's relative-binned ln L and MAP
search, against the numbers its runs store; and the cost of a point, exact and binned."""

import json
import time

import numpy as np
import pytest

import occam
from conftest import SMALL, TN3045

RTOL = 1e-12


def rel(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return np.max(np.abs(a - b) / np.maximum(np.abs(b), 1e-300))


def test_binned_fit_model_is_the_fit_chains_ln_l(relbin_study, cli_relbin):
    fit_dir, _ = cli_relbin
    s = json.loads((fit_dir / "summary.json").read_text())
    assert s["likelihood"] == "relbin"
    lik = occam.Likelihood.from_study(relbin_study, binned=True)
    assert lik.binned and "binned=True" in repr(lik)
    z = np.load(fit_dir / "chains.npz")
    pts = z["samples"].reshape(-1, lik.ndim)
    assert rel(lik.ln_likelihood(pts[::7]), z["ln_likelihood"].reshape(-1)[::7]) < RTOL
    assert rel(lik.ln_posterior(pts[::7]), z["ln_posterior"].reshape(-1)[::7]) < RTOL
    b = lik.binning
    assert b["n_coarse"] == s["n_coarse_bins"] and b["n_bins"] == s["n_bins"]
    assert 0 < b["worst_abs_delta_ln_l"] <= b["limit"] == 0.05
    assert b["n_points"] > 1 and set(b["coverage"]) == set(lik.param_names)
    np.testing.assert_array_equal(b["fiducial"], [r["map"] for r in s["rows"]])
    # an approximation: near, not equal to, the exact ln L
    exact = occam.Likelihood.from_study(relbin_study)
    assert exact.binning is None and not exact.binned
    d = np.abs(lik.ln_likelihood(pts[::50]) - exact.ln_likelihood(pts[::50]))
    assert 0 < d.max() < b["limit"]


def test_binned_select_models_are_their_chains_ln_l(relbin_study, cli_relbin):
    _, sel_dir = cli_relbin
    s = json.loads((sel_dir / "summary.json").read_text())
    for m in s["models"]:
        lik = occam.Likelihood.from_study(relbin_study, model=m["name"], binned=True)
        z = np.load(sel_dir / f"chains_{m['name']}.npz")
        pts = z["samples"].reshape(-1, lik.ndim)
        assert rel(lik.ln_likelihood(pts[::7]), z["ln_likelihood"].reshape(-1)[::7]) < RTOL
        assert lik.binning["n_coarse"] == m["relbin"]["n_coarse"]
        assert lik.binning["worst_abs_delta_ln_l"] == m["relbin"]["worst_abs_delta_ln_l"]


def test_binned_needs_the_whittle_statistic(tmp_path):
    study = tmp_path / "t.toml"
    study.write_text(
        SMALL.read_text().replace('likelihood = "exact"', 'likelihood = "exact"\nstatistic = "student_t"', 1)
    )
    with pytest.raises(occam.OccamError, match="approximates the Whittle likelihood only"):
        occam.Likelihood.from_study(study, binned=True)


def test_map_is_the_fits_map(cli_fit):
    s = json.loads((cli_fit / "summary.json").read_text())
    lik = occam.Likelihood.from_study(SMALL)
    m = lik.map()
    np.testing.assert_array_equal(m.theta, [r["map"] for r in s["rows"]])
    assert m.ln_posterior == s["map_ln_posterior"]
    assert m.converged and m.iterations == s["map_iterations"]
    assert rel(m.sigma, [r["cramer_rao"] for r in s["rows"]]) < 1e-10
    assert rel(m.fisher, np.array(s["fisher"])) < 1e-10
    assert list(m.as_dict()) == lik.param_names
    # from another start: the same maximum
    again = lik.map(start=lik.reference)
    assert rel(again.theta, m.theta) < 1e-6
    with pytest.raises(ValueError, match="start is one point"):
        lik.map(start=np.tile(lik.reference, (2, 1)))
    with pytest.raises(ValueError, match="theta has 3 values"):
        lik.map(start=[1.0, 2.0, 3.0])


def test_per_bin_ln_l_sums_to_ln_l():
    lik = occam.Likelihood.from_study(SMALL)
    exps = lik.experiments
    assert [e["name"] for e in exps] == ["a", "b"]
    assert sum(len(e["freqs"]) for e in exps) == lik.n_bins
    assert exps[0]["data_abs"].shape == (len(exps[0]["freqs"]), len(exps[0]["channels"]))
    one = lik.ln_likelihood_per_bin(lik.reference)
    assert {k: v.shape for k, v in one.items()} == {e["name"]: (len(e["freqs"]),) for e in exps}
    total = sum(v.sum() for v in one.values())
    assert abs(total - lik.ln_likelihood(lik.reference)) <= 1e-12 * abs(total)
    pts = lik.reference + np.outer(np.linspace(-1, 1, 5), 1e-2 * np.abs(lik.reference))
    many = lik.ln_likelihood_per_bin(pts)
    sums = sum(v.sum(axis=1) for v in many.values())
    assert rel(sums, lik.ln_likelihood(pts)) < 1e-12


def test_cost_of_a_point_exact_and_binned():
    """Not a timed assertion: prints evaluations per second (the guide quotes them)."""
    exact = occam.Likelihood.from_study(TN3045)
    binned = occam.Likelihood.from_study(TN3045, binned=True)
    rng = np.random.default_rng(3)
    cov = np.linalg.inv(exact.fisher(exact.reference))
    pts = rng.multivariate_normal(exact.reference, cov, size=4000)
    lines = [f"TN3045 ({exact.n_bins} bins, {binned.binning['n_coarse']} coarse bins):"]
    for name, lik, n in (("exact", exact, 400), ("binned", binned, 4000)):
        for label, f in (
            ("one point at a time", lambda p: [lik.ln_likelihood(t) for t in p]),
            ("2-D batch", lik.ln_likelihood),
        ):
            f(pts[:20])
            t0 = time.perf_counter()
            f(pts[:n])
            rate = n / (time.perf_counter() - t0)
            lines.append(f"  {name:<6} {label:<20} {rate:>12,.0f} evaluations/s")
    d = np.abs(binned.ln_likelihood(pts[:200]) - exact.ln_likelihood(pts[:200]))
    lines.append(
        f"  max |ln L_binned − ln L_exact| over 200 posterior draws: {d.max():.2e} "
        f"(validation: {binned.binning['worst_abs_delta_ln_l']:.2e} ≤ {binned.binning['limit']})"
    )
    print("\n".join(lines))
    assert d.max() < binned.binning["limit"]
