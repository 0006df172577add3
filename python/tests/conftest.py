"""Shared fixtures: the command-line binary, a small study run once by the CLI per session."""

import os
import subprocess
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
SMALL = HERE / "data" / "small.toml"
TN3045 = ROOT / "examples" / "tn3045.toml"


@pytest.fixture(scope="session")
def occam_bin():
    """The `occam` command line (built by .ci/python-check; OCCAM_BIN overrides)."""
    p = Path(os.environ.get("OCCAM_BIN", ROOT / "target" / "release" / "occam"))
    if not p.exists():
        pytest.fail(f"{p}: no occam binary: run `cargo build --release` or set OCCAM_BIN")
    return p


def run_cli(occam_bin, *args, cwd):
    """Runs the command line: the CompletedProcess (text)."""
    return subprocess.run(
        [str(occam_bin), *map(str, args)], cwd=cwd, capture_output=True, text=True
    )


def cli_error(occam_bin, *args, cwd):
    """The message the command line prints for a failing command, without `error: `."""
    r = run_cli(occam_bin, *args, cwd=cwd)
    assert r.returncode != 0, f"{args} succeeded:\n{r.stdout}"
    lines = [l for l in r.stderr.splitlines() if l.startswith("error: ")]
    assert len(lines) == 1, r.stderr
    return r.stderr[r.stderr.index("error: ") + len("error: ") :].rstrip("\n")


@pytest.fixture(scope="session")
def cli_fit(occam_bin, tmp_path_factory):
    """`occam fit small.toml`'s run directory."""
    d = tmp_path_factory.mktemp("cli")
    r = run_cli(occam_bin, "fit", SMALL, "-o", d / "fit", "-q", cwd=d)
    assert r.returncode == 0, r.stderr
    return d / "fit"


@pytest.fixture(scope="session")
def cli_select(occam_bin, tmp_path_factory):
    """`occam select small.toml`'s run directory."""
    d = tmp_path_factory.mktemp("cli")
    r = run_cli(occam_bin, "select", SMALL, "-o", d / "select", "-q", cwd=d)
    assert r.returncode == 0, r.stderr
    return d / "select"


@pytest.fixture(scope="session")
def relbin_study(tmp_path_factory):
    """small.toml on the relative-binned likelihood (the command line's default)."""
    d = tmp_path_factory.mktemp("relbin")
    p = d / "relbin.toml"
    p.write_text(SMALL.read_text().replace('likelihood = "exact"', 'likelihood = "relbin"', 1))
    return p


@pytest.fixture(scope="session")
def cli_relbin(occam_bin, relbin_study):
    """`occam fit` and `occam select` of the relative-binned study: their run directories."""
    d = relbin_study.parent
    for job in ("fit", "select"):
        r = run_cli(occam_bin, job, relbin_study, "-o", d / job, "-q", cwd=d)
        assert r.returncode == 0, r.stderr
    return d / "fit", d / "select"
