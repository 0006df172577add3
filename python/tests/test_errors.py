"""OccamError carries exactly the command line's message."""

import pytest

import occam
from conftest import SMALL, cli_error


def test_occam_error_is_a_runtime_error():
    assert issubclass(occam.OccamError, RuntimeError)


def test_missing_study(occam_bin, tmp_path):
    want = cli_error(occam_bin, "fit", tmp_path / "nope.toml", cwd=tmp_path)
    for call in (
        lambda: occam.Likelihood.from_study(tmp_path / "nope.toml"),
        lambda: occam.fit(tmp_path / "nope.toml"),
        lambda: occam.select(tmp_path / "nope.toml"),
        lambda: occam.simulate(tmp_path / "nope.toml"),
    ):
        with pytest.raises(occam.OccamError) as e:
            call()
        assert str(e.value) == want
    assert str(tmp_path / "nope.toml") in want


def test_bad_key_names_file_and_field(occam_bin, tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(SMALL.read_text().replace("burn_in = 1000", "burn_inn = 1000", 1))
    want = cli_error(occam_bin, "fit", bad, cwd=tmp_path)
    assert str(bad) in want and "burn_inn" in want, want
    for call in (
        lambda: occam.Likelihood.from_study(bad),
        lambda: occam.fit(bad, output=tmp_path / "f"),
        lambda: occam.select(bad, output=tmp_path / "s"),
    ):
        with pytest.raises(occam.OccamError) as e:
            call()
        assert str(e.value) == want


def test_bad_value_names_file_and_field(occam_bin, tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(SMALL.read_text().replace("chains = 2\niterations = 4000", "chains = 0\niterations = 4000", 1))
    want = cli_error(occam_bin, "fit", bad, "-o", tmp_path / "f", cwd=tmp_path)
    assert "fit.chains" in want, want
    with pytest.raises(occam.OccamError) as e:
        occam.fit(bad, output=tmp_path / "f")
    assert str(e.value) == want


def test_resume_without_checkpoint(occam_bin, tmp_path):
    want = cli_error(occam_bin, "fit", SMALL, "-o", tmp_path / "f", "--resume", cwd=tmp_path)
    with pytest.raises(occam.OccamError) as e:
        occam.fit(SMALL, output=tmp_path / "f", resume=True)
    assert str(e.value) == want and "nothing to resume" in want


def test_unknown_select_model(tmp_path):
    with pytest.raises(occam.OccamError) as e:
        occam.Likelihood.from_study(SMALL, model="nope")
    assert str(e.value) == (
        f"{SMALL}: `select.model`: there is no [[select.model]] named `nope`; "
        "the models are [\"nodelay\", \"full\"] (model=None is the [fit] model)"
    )
