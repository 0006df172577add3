"""A model whose residual noise moves with θ (`examples/two-mass-damper.toml`: noise inputs
through the model's own dynamics). `ln_likelihood` is the exact θ-dependent Whittle likelihood,
so it depends on no reference point: built from studies whose `[fit] start` differ (the point
the noise used to be held at), it gives the same number at every θ, and `map()` finds the same
MAP. Before, the noise was held at `[fit] start` and the values differed by nats."""

import numpy as np

import occam
from conftest import ROOT

EXAMPLE = ROOT / "examples" / "two-mass-damper.toml"


def with_start(tmp_path, bc):
    text = EXAMPLE.read_text().replace(
        'model = "damper"\n', f'model = "damper"\nstart = {{ bc = {bc} }}\n', 1
    )
    p = tmp_path / f"start-{bc}.toml"
    p.write_text(text)
    return p


def test_ln_likelihood_is_exact_whatever_the_start(tmp_path):
    a = occam.Likelihood.from_study(with_start(tmp_path, 0.0), model="damper")
    b = occam.Likelihood.from_study(with_start(tmp_path, 0.045), model="damper")
    assert any("the residual noise moves with" in w for w in a.warnings), a.warnings
    ma, mb = a.map(), b.map()
    theta = ma.theta
    # the same MAP within 0.02 σ from either start (each noise point stops at 0.01 σ)
    assert np.all(np.abs(ma.theta - mb.theta) < 0.02 * ma.sigma), (ma, mb, ma.sigma)
    rng = np.random.default_rng(5)
    cov = np.linalg.inv(a.fisher(theta))
    pts = rng.multivariate_normal(theta, cov, size=8)
    la, lb = a.ln_likelihood(pts), b.ln_likelihood(pts)
    assert np.all(np.isfinite(la))
    np.testing.assert_allclose(la, lb, rtol=1e-12, atol=0)
    # away from the MAP the exact likelihood is not the fixed-noise one: the noise moves
    far = theta.copy()
    far[a.param_names.index("bc")] = 0.03
    per_bin = sum(v.sum() for v in a.ln_likelihood_per_bin(far[None, :]).values())
    assert abs(per_bin - a.ln_likelihood(far)) < 1e-9 * abs(per_bin)
    binned = occam.Likelihood.from_study(with_start(tmp_path, 0.0), model="damper", binned=True)
    assert abs(binned.ln_likelihood(far) - a.ln_likelihood(far)) > 1.0
