"""occam.simulate/fit/select: the command line's runs, read back as arrays and ArviZ data."""

import json
import re

import numpy as np
import pytest

import occam
from conftest import SMALL


@pytest.fixture(scope="module")
def py_fit(tmp_path_factory):
    return occam.fit(SMALL, output=tmp_path_factory.mktemp("py") / "fit")


@pytest.fixture(scope="module")
def py_select(tmp_path_factory):
    return occam.select(SMALL, output=tmp_path_factory.mktemp("py") / "select")


def test_fit_is_the_command_lines_run(py_fit, cli_fit):
    """Same study, same seed: the same chains bit for bit, the same files."""
    z = np.load(cli_fit / "chains.npz")
    for k in ("samples", "ln_posterior", "ln_likelihood"):
        np.testing.assert_array_equal(getattr(py_fit, k), z[k])
    s = json.loads((cli_fit / "summary.json").read_text())
    assert [r["mean"] for r in py_fit.summary["rows"]] == [r["mean"] for r in s["rows"]]
    assert sorted(py_fit.files) == sorted(
        f["name"] for f in json.loads((cli_fit / "manifest.json").read_text())["files"]
    )
    assert py_fit.log and py_fit.log[0].startswith("data: simulated from")


def test_fit_result_arrays(py_fit):
    r = py_fit
    assert r.param_names == ["w1sq", "w2sq", "a_df", "a_sus", "d21"]
    assert r.samples.shape == (2, 3000, 5)
    assert r.ln_posterior.shape == r.ln_likelihood.shape == (2, 3000)
    assert r.summary["kept_per_chain"] == 3000
    if r.accepted is not None:
        assert r.accepted.shape == (2, 3000) and r.accepted.dtype == bool
        # a draw that was not accepted repeats the previous state
        moved = np.any(r.samples[:, 1:] != r.samples[:, :-1], axis=2)
        np.testing.assert_array_equal(moved, r.accepted[:, 1:])
    again = occam.FitResult.read(r.output)
    np.testing.assert_array_equal(again.samples, r.samples)


def test_fit_to_arviz(py_fit):
    az = pytest.importorskip("arviz")
    idata = py_fit.to_arviz()
    post = idata.posterior
    assert list(post.data_vars) == py_fit.param_names
    assert dict(post.sizes)["chain"] == 2 and dict(post.sizes)["draw"] == 3000
    np.testing.assert_array_equal(post["a_df"].values, py_fit.samples[:, :, 2])
    np.testing.assert_array_equal(idata.sample_stats["lp"].values, py_fit.ln_posterior)
    np.testing.assert_array_equal(
        idata.sample_stats["ln_likelihood"].values, py_fit.ln_likelihood
    )
    table = az.summary(idata, round_to="none")
    assert list(table.index) == py_fit.param_names
    # ArviZ's mean is the chains' mean occam reports
    for row in py_fit.summary["rows"]:
        assert table.loc[row["name"], "mean"] == pytest.approx(row["mean"], rel=1e-3, abs=1e-12)


def test_select_result(py_select, cli_select):
    r = py_select
    assert r.model_names == ["nodelay", "full"]
    s = json.loads((cli_select / "summary.json").read_text())
    assert r.summary["rj"]["visits"] == s["rj"]["visits"]
    assert r.summary["pairs"][0]["estimates"] == s["pairs"][0]["estimates"]
    # select writes chains_<model>.npz: their absence is a regression, not a skip
    assert r.models, "select wrote no per-model chains (chains_<model>.npz)"
    for name, free in (("nodelay", 5), ("full", 7)):
        c = r.models[name]
        m = next(m for m in s["models"] if m["name"] == name)
        # the chains' iterations (at least small.toml's 2 000, more until converged) less its
        # burn-in of 500
        assert m["mcmc_iterations"] >= 2000
        assert c.samples.shape == (2, m["mcmc_iterations"] - 500, free)
        assert c.param_names == m["free"]


def test_select_rj_chain_and_arviz(py_select):
    r = py_select
    assert r.rj is not None, "select wrote no rj_chain.npz"
    rj = r.rj
    visits = np.array(r.summary["rj"]["visits"])
    n_chains = r.summary["rj"]["n_chains"]
    assert rj.model_names == r.model_names
    assert rj.model_index.shape[0] == n_chains
    assert set(np.unique(rj.model_index)) <= {0, 1}
    # every stored draw is one of `thin` iterations: the counts match the summary's visits
    assert np.all(np.abs(rj.visits() * rj.thin - visits) <= rj.thin * n_chains)
    if rj.thin == 1:
        np.testing.assert_array_equal(rj.visits(), visits)
    # NaN exactly where the current model lacks the parameter
    for k, m in enumerate(r.summary["models"]):
        here = rj.model_index == k
        for j, p in enumerate(rj.param_names):
            col = rj.samples[:, :, j][here]
            assert np.all(np.isnan(col)) == (p not in m["free"])
    az = pytest.importorskip("arviz")
    idata = r.to_arviz()
    table = az.summary(idata, round_to="none")
    assert "model_index" in table.index
    share = visits / visits.sum()
    for k, name in enumerate(r.model_names):
        assert table.loc[f"is_{name}", "mean"] == pytest.approx(share[k], abs=0.01)
    m = r.to_arviz("full")
    assert list(m.posterior.data_vars) == r.models["full"].param_names


def test_simulate_result(tmp_path):
    r = occam.simulate(SMALL, output=tmp_path / "sim")
    assert sorted(r.files) == ["dataset.json", "dataset.npz"]
    assert r.dataset["a.o1"].ndim == 1 and r.dataset["a.o1"].size == r.dataset["a.i1"].size
    assert [e["name"] for e in r.metadata["experiments"]] == ["a", "b"]
    # the study read from that dataset has the likelihood of the study simulated in memory
    study = tmp_path / "from_dataset.toml"
    study.write_text(
        SMALL.read_text().replace("[analysis]\n", f'[analysis]\ndataset = "{tmp_path / "sim"}"\n', 1)
    )
    a = occam.Likelihood.from_study(SMALL)
    b = occam.Likelihood.from_study(study)
    assert b.reference_source == "truth"
    np.testing.assert_array_equal(a.reference, b.reference)
    assert b.ln_likelihood(b.reference) == a.ln_likelihood(a.reference)


def test_select_log_is_every_line_the_command_line_prints(occam_bin, py_select, tmp_path):
    from conftest import run_cli

    r = run_cli(occam_bin, "select", SMALL, "-o", tmp_path / "s", "-q", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    cli = r.stdout.replace(str(tmp_path / "s"), str(py_select.output)).splitlines()
    log = py_select.log
    # the same lines; warnings (stderr on the command line) as `warning: …`
    # the timing apart: the `took` line and the reversible jump's iterations per second
    strip = lambda ls: [  # noqa: E731
        re.sub(r"\(\d+ iterations/s\)", "(…)", l) for l in ls if not l.startswith("took ")
    ]
    assert strip([l for l in log if not l.startswith("warning: ")]) == strip(cli)
    assert [l for l in log if l.startswith("warning: ")] == r.stderr.splitlines()
    assert any(l.startswith("nodelay/full: reference") for l in log)
    assert any(l.startswith("posterior model probabilities (prior equal): ") for l in log)
    assert log[-2].startswith("wrote ") and log[-1].startswith("took ")


def test_fit_log_is_every_line_the_command_line_prints(occam_bin, py_fit, tmp_path):
    from conftest import run_cli

    r = run_cli(occam_bin, "fit", SMALL, "-o", tmp_path / "f", "-q", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    r.stdout = r.stdout.replace(str(tmp_path / "f"), str(py_fit.output))
    strip = lambda ls: [  # noqa: E731
        l for l in ls if not (l.startswith("took ") or l.startswith("MCMC: ") or l.startswith("rho_opt at MAP"))
    ]
    log = [l for l in py_fit.log if not l.startswith("warning: ")]
    assert strip(log) == strip(r.stdout.splitlines())
    assert any(l.startswith("parameter ") for l in log)


def test_select_model_probabilities_are_named(py_select):
    p = py_select.model_probabilities
    assert list(p) == ["nodelay", "full"]
    assert list(p.values()) == py_select.summary["posterior_model_probabilities"]
    assert py_select.posterior_model_probabilities == list(p.values())
    assert abs(sum(p.values()) - 1) < 1e-12


def test_fit_arviz_groups_and_loo(py_fit):
    az = pytest.importorskip("arviz")
    idata = py_fit.to_arviz(max_draws=500)
    assert {"posterior", "sample_stats", "log_likelihood", "prior", "observed_data"} <= set(
        idata.groups()
    )
    n_bins = occam.Likelihood.from_study(SMALL).n_bins
    # one observation per bin, as before the groups
    bins = py_fit.to_arviz(max_draws=500, observations="bins", prior=False, observed_data=False)
    ll = bins.log_likelihood["spectrum"]
    assert ll.dims == ("chain", "draw", "bin")
    assert ll.shape == (2, 250, n_bins)
    assert set(ll["experiment"].values) == {"a", "b"} and ll["frequency"].values.min() >= 1e-3
    # summed over bins: the chains' (exact) ln L at the kept draws
    kept = ll["draw"].values
    np.testing.assert_array_equal(kept, np.arange(0, 3000, 12))
    np.testing.assert_allclose(ll.sum("bin").values, py_fit.ln_likelihood[:, kept], rtol=1e-12)
    # the default: groups of bins, each ending in a bin that carries information
    g = idata.log_likelihood["spectrum"]
    assert g.dims == ("chain", "draw", "observation") and g.shape[:2] == (2, 250)
    assert 0 < g.shape[2] <= n_bins and int(g["n_bins"].sum()) == n_bins
    assert np.all(g["f_lo"].values <= g["frequency"].values)
    assert np.all(g["frequency"].values <= g["f_hi"].values)
    np.testing.assert_allclose(g.sum("observation").values, ll.sum("bin").values, rtol=1e-12)
    assert "observations" in idata.log_likelihood.attrs
    prior = idata.prior
    assert list(prior.data_vars) == py_fit.param_names and prior.sizes["draw"] == 1000
    b = occam.Likelihood.from_study(SMALL).prior_bounds
    for k, n in enumerate(py_fit.param_names):
        assert b[k, 0] <= prior[n].values.min() and prior[n].values.max() <= b[k, 1]
    obs = idata.observed_data["spectrum"]
    assert obs.dims == ("bin", "channel") and obs.shape[0] == n_bins
    loo = az.loo(idata, pointwise=True)
    assert np.isfinite(loo.elpd_loo) and loo.n_data_points == g.shape[2]
    assert np.all(np.isfinite(loo.pareto_k.values))
    # one variable per experiment
    per = py_fit.to_arviz(per_experiment=True, max_draws=100)
    assert set(per.log_likelihood.data_vars) == {"a", "b"}
    assert per.log_likelihood["a"].dims == ("chain", "draw", "a_observation")
    assert np.isfinite(az.loo(per, var_name="a").elpd_loo)
    per_bin = py_fit.to_arviz(per_experiment=True, max_draws=100, observations="bins")
    assert per_bin.log_likelihood["a"].dims == ("chain", "draw", "a_bin")
    # memory cap: values (draws × bins) bounded
    small = py_fit.to_arviz(max_values=10 * n_bins, prior=False, observed_data=False)
    assert small.log_likelihood["spectrum"].shape[:2] == (2, 5)
    assert "prior" not in small.groups()
    with pytest.raises(ValueError, match="observations must be one of"):
        py_fit.to_arviz(observations="bin")


def test_select_models_compare_with_arviz(py_select):
    az = pytest.importorskip("arviz")
    data = {m: py_select.to_arviz(m, max_draws=400) for m in py_select.model_names}
    table = az.compare(data)
    assert set(table.index) == {"nodelay", "full"}
    assert np.all(np.isfinite(table["elpd_loo"]))
    full = data["full"]
    assert list(full.prior.data_vars) == py_select.models["full"].param_names
    ll = full.log_likelihood["spectrum"].sum("observation").values
    kept = full.log_likelihood["draw"].values
    np.testing.assert_allclose(ll, py_select.models["full"].ln_likelihood[:, kept], rtol=1e-12)


def test_progress_callback_sees_the_work(tmp_path):
    seen = []
    occam.fit(SMALL, output=tmp_path / "fit", progress=lambda d, t: seen.append((d, t)))
    assert seen and seen[-1] == (8000, 8000)
    assert all(t == 8000 for _, t in seen) and [d for d, _ in seen] == sorted(d for d, _ in seen)


def test_the_progress_line_in_a_log_has_no_terminal_escapes(capsys):
    # capsys's stderr is not a terminal, as a log file or a pipe is not (issue 52: the line
    # wrote "\x1b[K" and "\r" into such logs)
    from occam._progress import _Line

    line = _Line("occam fit", "iterations")
    for done in range(0, 8001, 40):
        line(done, 8000)
    line.close()
    err = capsys.readouterr().err
    assert "\x1b" not in err and "\r" not in err, repr(err[:200])
    lines = err.splitlines()
    # one line per tenth of the work: 0 %, 10 %, …, 100 %
    assert len(lines) == 11, lines
    assert lines[0].startswith("occam fit: 0/8000 iterations (0%)")
    assert lines[-1].startswith("occam fit: 8000/8000 iterations (100%)")


def test_the_progress_line_gives_the_time_left_as_a_range(capsys, monkeypatch):
    # as the command line's hint (issue 52, item 9): the low end at the pace since the counter
    # first moved, the high end at the pace of the whole call, which counts the set-up
    from occam import _progress

    clock = [100.0]
    monkeypatch.setattr(_progress.time, "monotonic", lambda: clock[0])
    line = _progress._Line("occam select", "ln L evaluations")
    for t, done in [(110.0, 0), (120.0, 1000), (122.0, 1500), (130.0, 4000)]:
        clock[0] = t
        line(done, 10_000)
    line.close()
    lines = capsys.readouterr().err.splitlines()
    # set-up 20 s, then 3000 units in 10 s: low 6000 / 300 = 20 s, high 30 s × 6000 / 4000 = 45 s
    assert lines[-1] == "occam select: 4000/10000 ln L evaluations (40%), 30 s, 20–45 s to go", lines
    # 2 s after the counter moved is too early for a range
    assert all("to go" not in l for l in lines[:-1]), lines


def test_sweep_design_report(tmp_path):
    sw = occam.sweep(
        SMALL, output=tmp_path / "sweep", axes=["simulation.target_snr=300,1000"], progress=False
    )
    assert isinstance(sw, occam.SweepResult) and "sweep.json" in sw.files
    assert len(sw.summary["points"]) == 2
    assert any("2 task(s) computed, 0 reused" in l for l in sw.log)
    again = occam.sweep(
        SMALL, output=tmp_path / "sweep", axes=["simulation.target_snr=300,1000"], resume=True,
        progress=False,
    )
    assert any("0 task(s) computed, 2 reused" in l for l in again.log)
    page = occam.report(sw.output)
    assert page == sw.output / "report.html" and page.read_text().startswith("<!DOCTYPE html>")
    from conftest import ROOT

    study = tmp_path / "d.toml"
    study.write_text(
        (ROOT / "examples" / "design-optimise.toml").read_text()
        .replace("points = 10", "points = 3").replace("segments = 7", "segments = 2")
        .replace("max_passes = 2", "max_passes = 1")
    )
    d = occam.design(study, output=tmp_path / "design")
    assert isinstance(d, occam.DesignResult) and d.design_study.exists()
    assert d.report["true_model"] == "X" and "chosen" in d.report
    assert any(l.startswith("chosen ") for l in d.log)
    with pytest.raises(occam.OccamError, match="no \\[design\\] table"):
        occam.design(SMALL, output=tmp_path / "nodesign")
