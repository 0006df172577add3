"""occam.Likelihood against the command line's own numbers, and its handling of bad input."""

import json
from statistics import NormalDist

import numpy as np
import pytest

import occam
from conftest import SMALL

# every comparison with the command line: relative, on ln L of order 1e5
RTOL = 1e-12


def rel(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return np.max(np.abs(a - b) / np.maximum(np.abs(b), 1e-300))


@pytest.fixture(scope="module")
def lik():
    return occam.Likelihood.from_study(SMALL)


def test_ln_likelihood_equals_the_fit_chains_ln_l(lik, cli_fit):
    z = np.load(cli_fit / "chains.npz")
    summary = json.loads((cli_fit / "summary.json").read_text())
    assert lik.param_names == [r["name"] for r in summary["rows"]]
    samples = z["samples"]
    pts = samples.reshape(-1, samples.shape[-1])
    assert len(pts) == 2 * 3000
    batch = lik.ln_likelihood(pts)
    assert batch.shape == (len(pts),)
    assert rel(batch, z["ln_likelihood"].reshape(-1)) < RTOL
    assert rel(lik.ln_posterior(pts), z["ln_posterior"].reshape(-1)) < RTOL
    # one point at a time: the same numbers as the batch, bit for bit
    one = np.array([lik.ln_likelihood(t) for t in pts[::25]])
    assert isinstance(lik.ln_likelihood(pts[0]), float)
    np.testing.assert_array_equal(one, batch[::25])
    assert rel(one, z["ln_likelihood"].reshape(-1)[::25]) < RTOL


def test_fisher_and_reference_match_the_fit_summary(lik, cli_fit):
    s = json.loads((cli_fit / "summary.json").read_text())
    theta_map = np.array([r["map"] for r in s["rows"]])
    f = lik.fisher(theta_map)
    assert f.shape == (5, 5)
    assert rel(f, np.array(s["fisher"])) < 1e-10
    np.testing.assert_array_equal(f, f.T)
    # simulated data: the reference is the injected truth ([truth] defaults: Table I)
    assert lik.reference_source == "truth"
    np.testing.assert_array_equal(lik.reference, [r["truth"] for r in s["rows"]])
    assert lik.fixed == {"dt1": 0.2, "dt2": 0.2}
    assert rel(lik.ln_posterior(theta_map), s["map_ln_posterior"]) < RTOL


def test_select_model_ln_l_at_its_map_equals_the_command_lines(cli_select):
    s = json.loads((cli_select / "summary.json").read_text())
    for m in s["models"]:
        lm = occam.Likelihood.from_study(SMALL, model=m["name"])
        assert lm.model == m["name"] and lm.param_names == m["free"]
        full = dict(zip(m["params"], m["map"]))
        theta = np.array([full[n] for n in m["free"]])
        assert rel(lm.ln_likelihood(theta), m["ln_l_map"]) < RTOL
        assert set(lm.fixed) == set(m["params"]) - set(m["free"])


def test_select_model_ln_l_equals_its_chains(cli_select):
    """The in-model chains of `select` (chains_<model>.npz) against the Python ln L."""
    for name in ("nodelay", "full"):
        p = cli_select / f"chains_{name}.npz"
        assert p.exists(), f"select wrote no {p.name}"
        z = np.load(p)
        lm = occam.Likelihood.from_study(SMALL, model=name)
        if "param_names" in z.files:
            assert [str(n) for n in z["param_names"]] == lm.param_names
        pts = z["samples"].reshape(-1, lm.ndim)
        assert rel(lm.ln_likelihood(pts), z["ln_likelihood"].reshape(-1)) < RTOL


def test_prior_bounds_priors_and_ln_prior(lik):
    b = lik.prior_bounds
    # the built-in model's default boxes (docs/src/guide/study-files.md: [prior])
    np.testing.assert_array_equal(
        b, [[-5e-6, 5e-6], [-5e-6, 5e-6], [0.5, 1.5], [0.5, 1.5], [-1e-3, 1e-3]]
    )
    assert [p["kind"] for p in lik.priors] == ["uniform"] * 5
    want = -np.sum(np.log(b[:, 1] - b[:, 0]))
    assert abs(lik.ln_prior(lik.reference) - want) < 1e-12 * abs(want)
    out = lik.reference.copy()
    out[2] = 1.6  # a_df above its box
    assert lik.ln_prior(out) == -np.inf
    assert lik.ln_posterior(out) == -np.inf
    lp = lik.ln_prior(np.stack([lik.reference, out]))
    assert lp[0] == pytest.approx(want, rel=1e-12) and lp[1] == -np.inf


def test_batches_of_any_size_and_layout(lik):
    ref = lik.reference
    assert lik.ln_likelihood(np.empty((0, 5))).shape == (0,)
    # a list, a Fortran-ordered array, a strided view: the same numbers
    pts = ref + np.outer(np.linspace(-1, 1, 7), 1e-3 * np.abs(ref))
    want = lik.ln_likelihood(pts)
    np.testing.assert_array_equal(lik.ln_likelihood(np.asfortranarray(pts)), want)
    np.testing.assert_array_equal(lik.ln_likelihood(pts.tolist()), want)
    wide = np.repeat(pts, 2, axis=1)[:, ::2]
    np.testing.assert_array_equal(lik.ln_likelihood(wide), want)
    assert lik.ln_likelihood(list(ref)) == want[3]


@pytest.mark.parametrize(
    "theta, message",
    [
        (np.zeros(4), "theta has 4 values; model `ltp` has 5 free parameters"),
        (np.zeros((3, 6)), "theta has shape (3, 6): each row is one point and needs 5 values"),
        (np.zeros((2, 2, 5)), "theta must be 1-D (one point, 5 values) or 2-D"),
        (np.float64(1.0), "theta must be 1-D (one point, 5 values) or 2-D"),
    ],
)
def test_wrong_shapes_are_value_errors(lik, theta, message):
    for f in (lik.ln_likelihood, lik.ln_prior, lik.ln_posterior):
        with pytest.raises(ValueError) as e:
            f(theta)
        assert str(e.value).startswith(message), str(e.value)


def test_non_finite_values_are_value_errors(lik):
    t = lik.reference.copy()
    t[1] = np.nan
    with pytest.raises(ValueError, match=r"^theta\[1\] \(`w2sq`\) is NaN: parameters must be finite"):
        lik.ln_likelihood(t)
    pts = np.tile(lik.reference, (3, 1))
    pts[2, 4] = np.inf
    with pytest.raises(ValueError, match=r"^theta\[2, 4\] \(`d21`\) is inf"):
        lik.ln_posterior(pts)
    with pytest.raises(ValueError, match="fisher takes one point"):
        lik.fisher(pts[:2])


def test_repr_names_the_model(lik):
    r = repr(lik)
    assert r.startswith("occam.Likelihood(study=") and "model='ltp'" in r and "n_bins=" in r
    assert lik.n_bins > 0 and lik.statistic == "whittle" and lik.parent_model == "ltp"


def test_pickles_by_rebuilding_from_the_study(lik):
    import pickle

    again = pickle.loads(pickle.dumps(lik))
    assert again.param_names == lik.param_names and again.model == lik.model
    assert again.ln_likelihood(lik.reference) == lik.ln_likelihood(lik.reference)
    sel = occam.Likelihood.from_study(SMALL, model="full")
    assert pickle.loads(pickle.dumps(sel)).param_names == sel.param_names


def test_prior_transform_of_each_kind(tmp_path):
    study = tmp_path / "priors.toml"
    study.write_text(
        SMALL.read_text().replace(
            "[analysis]\n",
            '[prior]\nw1sq = { kind = "gaussian", mu = -1.3e-6, sigma = 1e-7 }\n'
            'a_df = { kind = "log_uniform", lo = 0.5, hi = 2.0 }\n\n[analysis]\n',
            1,
        )
    )
    lik = occam.Likelihood.from_study(study)
    assert [p["kind"] for p in lik.priors] == ["gaussian", "uniform", "log_uniform", "uniform", "uniform"]
    b = lik.prior_bounds
    assert b[0, 0] == -np.inf and b[0, 1] == np.inf and list(b[2]) == [0.5, 2.0]
    phi1 = 0.8413447460685429  # Φ(1)
    x = lik.prior_transform([phi1, 0.25, 0.5, 0.0, 1.0])
    np.testing.assert_allclose(x, [-1.2e-6, -2.5e-6, 1.0, 0.5, 1e-3], rtol=1e-9)
    many = lik.prior_transform(np.array([[0.5, 0.5, 0.0, 0.5, 0.5], [0.0, 1.0, 1.0, 0.5, 0.5]]))
    assert many[0, 0] == -1.3e-6 and many[1, 0] == -np.inf and many[1, 2] == 2.0
    # the transform's image has the prior's density: ln π of log-uniform at 1 is −ln ln 4
    lp = lik.ln_prior(x)
    want = (
        np.log(NormalDist(-1.3e-6, 1e-7).pdf(-1.2e-6))
        - np.log(1e-5)  # w2sq: uniform box of width 1e-5
        - np.log(np.log(4.0))  # a_df: log-uniform on [0.5, 2] at 1
        - np.log(1.0)  # a_sus: [0.5, 1.5]
        - np.log(2e-3)  # d21: [-1e-3, 1e-3]
    )
    assert lp == pytest.approx(want, rel=1e-12)
    with pytest.raises(ValueError, match=r"u must lie in \[0, 1\]"):
        lik.prior_transform([1.5, 0.5, 0.5, 0.5, 0.5])
    with pytest.raises(ValueError, match=r"u must have shape \(5,\)"):
        lik.prior_transform([0.5])
