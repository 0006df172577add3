"""occam.simulate/fit/select: the command line's runs, read back as arrays and ArviZ data."""

import json

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
        assert c.samples.shape == (2, 1500, free)
        assert c.param_names == next(m["free"] for m in s["models"] if m["name"] == name)


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
