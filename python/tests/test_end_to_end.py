"""A new user's path, end to end: their own model (a user-defined [[model]]) on their own data
(files they wrote), model selection from Python, the answer in the log's first lines, the
posterior plotted with ArviZ and the models compared with `az.compare`."""

import numpy as np
import pytest

import occam
from conftest import ROOT, SMALL

# the user-defined 7-parameter closed loop of examples/user-model-closed-loop.toml: its
# [[model]] table and its [prior] (a user model has no default priors)
EXAMPLE = (ROOT / "examples" / "user-model-closed-loop.toml").read_text()
MODEL = EXAMPLE[EXAMPLE.index("[prior]") :]


def own_data(tmp_path):
    """Data files as a user would have them: one npz of the experiment's channels and one of
    its noise-only stretch per experiment (written here from a simulation)."""
    sim = occam.simulate(SMALL, output=tmp_path / "sim", progress=False).dataset
    for e in ("a", "b"):
        np.savez(tmp_path / f"{e}.npz", **{c: sim[f"{e}.{c}"] for c in ("o1", "o12", "i1", "i12")})
        n = len(sim[f"{e}.noise_o1"])
        np.savez(
            tmp_path / f"{e}_noise.npz",
            o1=sim[f"{e}.noise_o1"], o12=sim[f"{e}.noise_o12"], i1=np.zeros(n), i12=np.zeros(n),
        )


STUDY = """
seed = 5
output = "runs"

[analysis]
band = [1e-3, 0.4]

[fit]
model = "cl_user"
free = ["w1sq", "w2sq", "a_df", "a_sus", "d21"]
fixed = {{ dt1 = 0.2, dt2 = 0.2 }}

[select]
iterations = 2000
burn_in = 500
chains = 2
rj_iterations = 20000
rj_burn_in = 1000
pt_temperatures = 4
pt_iterations = 600
pt_burn_in = 200

[[select.model]]
name = "nodelay"
model = "cl_user"
free = ["w1sq", "w2sq", "a_df", "a_sus", "d21"]
fixed = {{ dt1 = 0.2, dt2 = 0.2 }}

[[select.model]]
name = "full"
model = "cl_user"
free = ["w1sq", "w2sq", "dt1", "dt2", "a_df", "a_sus", "d21"]

[[experiment]]
name = "a"
fs = 1.0
data = "a.npz"
noise_data = "a_noise.npz"

[[experiment]]
name = "b"
fs = 1.0
data = "b.npz"
noise_data = "b_noise.npz"

{model}
"""


def test_own_model_on_own_data_to_az_compare(tmp_path, monkeypatch):
    az = pytest.importorskip("arviz")
    monkeypatch.chdir(tmp_path)
    own_data(tmp_path)
    study = tmp_path / "mine.toml"
    study.write_text(STUDY.format(model=MODEL))
    sel = occam.select(study, progress=False)
    assert sel.output.resolve() == tmp_path / "runs" / "select"
    # the answer in the first lines: where the data came from, the models, the answer
    assert sel.log[0].startswith(f"data: {tmp_path}") or sel.log[0].startswith("data: ")
    answer = next(l for l in sel.log if l.startswith("answer: "))
    assert " preferred" in answer
    assert sel.log.index(answer) < 10
    verdict = next(l for l in sel.log if l.startswith("nodelay/full: reference"))
    assert "preferred model" in verdict
    p = sel.model_probabilities
    assert set(p) == {"nodelay", "full"} and abs(sum(p.values()) - 1) < 1e-12
    data = {m: sel.to_arviz(m, max_draws=400) for m in sel.model_names}
    table = az.compare(data)
    assert set(table.index) == {"nodelay", "full"} and np.all(np.isfinite(table["elpd_loo"]))
    import matplotlib

    matplotlib.use("Agg")
    axes = az.plot_posterior(data["full"], var_names=["a_df", "dt1"])
    fig = np.ravel(axes)[0].get_figure()
    fig.savefig(tmp_path / "posterior.png")
    assert (tmp_path / "posterior.png").stat().st_size > 1000
    page = occam.report(sel.output)
    assert page.exists()
