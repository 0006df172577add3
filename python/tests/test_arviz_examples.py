"""ArviZ on every shipped select example (issue 52): `az.loo` and `az.compare` give finite
numbers for each model's chains and for the reversible-jump chain, on the same observations.

Before the observations were grouped, `az.loo` on examples/guidance-delays.toml gave
`elpd_loo = nan`: one bin's ln L moved by 3e-12 over the posterior and ArviZ's Pareto fit of
its weights divided by zero. The runs here are the examples with short chains (`reduced`):
what breaks ArviZ is the bins, not the run length."""

import re
import subprocess
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

import occam
from conftest import ROOT

# every example that compares models, but the design studies (their `[[select.model]]`
# feed `occam design`, and their select is the one of guidance-delays)
EXAMPLES = sorted(
    p.stem
    for p in (ROOT / "examples").glob("*.toml")
    if "[[select.model]]" in p.read_text() and not p.stem.startswith("design-")
)

SHORT = {
    "chains": "2",
    "iterations": "600",
    "burn_in": "200",
    "rj_iterations": "4000",
    "rj_burn_in": "1000",
    "cross_checks": '"off"',
    # the run length of the chains, not their convergence (`[select] until` would lengthen
    # them): ArviZ's trouble was the bins
    "until": "false",
}


def reduced(text):
    """`text` (a study) with the `[select]` run lengths of ``SHORT``."""
    keys = re.compile(r"^\s*(%s)\s*=" % "|".join(SHORT))
    out, table, done = [], None, False
    for line in text.splitlines():
        header = re.match(r"^\s*\[+\s*([^\]]+?)\s*\]+", line)
        if header:
            if table == "select":
                out += [f"{k} = {v}" for k, v in SHORT.items()]
                done = True
            table = header.group(1)
        elif table == "select" and keys.match(line):
            continue
        out.append(line)
    if not done:
        out += ([] if table == "select" else ["[select]"]) + [
            f"{k} = {v}" for k, v in SHORT.items()
        ]
    return "\n".join(out) + "\n"


def test_observation_groups_end_at_bins_that_carry_information():
    from occam._arviz import INFORMATIVE_SD, observation_groups

    exps = [{"name": "a", "freqs": np.arange(1.0, 7.0)}, {"name": "b", "freqs": [1.0, 2.0]}]
    on, off = INFORMATIVE_SD, 0.99 * INFORMATIVE_SD
    one = {"a": np.array([0, on, off, 0, 1e-3, 0]), "b": np.array([0.0, 0.0])}
    g = observation_groups(exps, [one])
    # each informative bin closes a group; the bins after the last join it
    np.testing.assert_array_equal(g["a"][0], [0, 0, 1, 1, 1, 1])
    np.testing.assert_array_equal(g["a"][1], [1, 4])
    # an experiment with no informative bin is one group
    np.testing.assert_array_equal(g["b"][0], [0, 0])
    np.testing.assert_array_equal(g["b"][1], [0])
    # a bin must carry information in every model whose ln L moves at all...
    other = {"a": np.array([0, 0, 0, 0, 1.0, 0]), "b": np.array([0.0, 0.0])}
    g2 = observation_groups(exps, [one, other])
    np.testing.assert_array_equal(g2["a"][0], [0] * 6)
    np.testing.assert_array_equal(g2["a"][1], [4])
    # ...and a model that never moves (every parameter fixed) has no say
    still = {"a": np.zeros(6), "b": np.zeros(2)}
    for a, b in zip(observation_groups(exps, [one, still])["a"], g["a"]):
        np.testing.assert_array_equal(a, b)
    # no model moves: one group per experiment
    np.testing.assert_array_equal(observation_groups(exps, [still])["a"][0], [0] * 6)


def test_reduced_sets_the_run_lengths_and_keeps_the_rest():
    # by lines, not by parsing: tomllib reads TOML 1.0, and the examples use 1.1's multi-line
    # inline tables (occam itself refuses a repeated key when the runs below load them)
    keys = re.compile(r"^\s*(%s)\s*=" % "|".join(SHORT))

    def tables(lines):
        """Each line with the table it is in."""
        t = None
        for x in lines:
            h = re.match(r"^\s*\[+\s*([^\]]+?)\s*\]+", x)
            t = h.group(1) if h else t
            yield t, x

    for name in EXAMPLES:
        a = (ROOT / "examples" / f"{name}.toml").read_text().splitlines()
        b = reduced("\n".join(a)).splitlines()
        got = [x for t, x in tables(b) if t == "select" and keys.match(x)]
        assert sorted(got) == sorted(f"{k} = {v}" for k, v in SHORT.items()), (name, got)
        rest = lambda ls: [(t, x) for t, x in tables(ls) if not (t == "select" and keys.match(x))]  # noqa: E731,E501
        assert [x for _, x in rest(a)] == [
            x for _, x in rest(b) if x != "[select]" or "[select]" in a
        ], name


@pytest.fixture(scope="module")
def runs(occam_bin, tmp_path_factory):
    d = tmp_path_factory.mktemp("examples")

    def run(name):
        study = d / f"{name}.toml"
        study.write_text(reduced((ROOT / "examples" / f"{name}.toml").read_text()))
        # one thread each, two at a time: the numbers do not depend on it
        r = subprocess.run(
            [str(occam_bin), "select", str(study), "-o", str(d / name), "-q", "--threads", "1"],
            cwd=d, capture_output=True, text=True,
        )
        assert r.returncode == 0, f"{name}: {r.stderr}"
        return name, occam.SelectResult.read(d / name)

    with ThreadPoolExecutor(2) as pool:
        return dict(pool.map(run, EXAMPLES))


def test_the_examples_are_found():
    assert len(EXAMPLES) >= 12 and "guidance-delays" in EXAMPLES and "cross-talk" in EXAMPLES


@pytest.mark.parametrize("name", EXAMPLES)
def test_loo_and_compare_are_finite_on_every_select_example(runs, name):
    az = pytest.importorskip("arviz")
    sel = runs[name]
    data = {
        m: sel.to_arviz(m, max_draws=100, prior=False, observed_data=False)
        for m in sel.model_names
    }
    loos = {}
    for m, idata in data.items():
        ll = idata.log_likelihood["spectrum"]
        assert ll.dims == ("chain", "draw", "observation"), (m, ll.dims)
        loo = az.loo(idata, pointwise=True)
        assert np.isfinite(loo.elpd_loo) and np.all(np.isfinite(loo.loo_i.values)), (m, loo)
        assert np.all(np.isfinite(loo.pareto_k.values)), m
        loos[m] = loo
        # the grouping loses nothing: summed, the observations are the draws' exact ln L
        lik = sel._likelihood(sel.output / "study.resolved.toml", m)
        chains = sel.models[m]
        pts = chains.samples[:, ll["draw"].values].reshape(-1, len(chains.param_names))
        np.testing.assert_allclose(
            ll.sum("observation").values.reshape(-1), lik.ln_likelihood(pts), rtol=1e-10
        )
    # the same observations for every model, as az.compare needs
    n_obs = {loo.n_data_points for loo in loos.values()}
    assert len(n_obs) == 1
    table = az.compare(loos)
    assert set(table.index) == set(sel.model_names)
    assert np.all(np.isfinite(table["elpd_loo"])) and np.all(np.isfinite(table["elpd_diff"]))
    # the jump chain: the model-averaged leave-one-out predictive
    rj = sel.to_arviz(max_draws=100, observed_data=False)
    assert "prior" not in rj.groups()
    loo = az.loo(rj)
    assert np.isfinite(loo.elpd_loo) and loo.n_data_points == n_obs.pop()
