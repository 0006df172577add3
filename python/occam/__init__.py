"""occam from Python: a study's likelihood for your own samplers, and occam's jobs with their
results as numpy arrays and ArviZ data.

>>> import occam
>>> lik = occam.Likelihood.from_study("examples/tn3045.toml")  # binned=True: the CLI's ln L
>>> lik.ln_posterior(lik.reference)              # one point: a float
>>> fit = occam.fit("examples/tn3045.toml")      # the same run as `occam fit`
>>> import arviz as az; az.summary(fit.to_arviz()); az.loo(fit.to_arviz())

Errors of occam raise ``occam.OccamError`` (a ``RuntimeError``) with the message the command
line prints; wrong arguments (shapes, NaN) raise ``ValueError``. Ctrl-C stops a running job at
its next safe point, keeps its checkpoint (``resume=True`` continues it) and raises
``KeyboardInterrupt``.
"""

import os

from . import _occam, _progress
from ._likelihood import Likelihood, MapResult
from ._results import (
    Chains,
    DesignResult,
    FitResult,
    RjChain,
    SelectResult,
    SimulateResult,
    SweepResult,
)

OccamError = _occam.OccamError
__version__ = _occam.__version__

__all__ = [
    "Chains",
    "DesignResult",
    "FitResult",
    "Likelihood",
    "MapResult",
    "OccamError",
    "RjChain",
    "SelectResult",
    "SimulateResult",
    "SweepResult",
    "design",
    "fit",
    "report",
    "select",
    "simulate",
    "sweep",
]


def _path(p):
    return None if p is None else os.fspath(p)


def _with_log(result, log, study=None):
    result.log = list(log)
    if study is not None:
        result.study = os.path.abspath(os.fspath(study))
    return result


def simulate(path, output=None, progress=True):
    """``occam simulate``: simulates the study's experiments into ``output`` (default: the
    study's ``output``) and returns a ``SimulateResult``.

    Every job runs exactly as the command line does (``occam::jobs``: the same numbers and
    files, the run directory's lock, staging and ``manifest.json``), on all cores with the GIL
    released. ``progress``: ``True`` draws a progress bar on stderr (tqdm when it is
    installed, else one line), ``False`` none, a callable is called with ``(done, total)``.
    The lines the command line prints (data origin, what is resumed, tables, verdicts,
    ``warning: …``, ``wrote …``) are in the result's ``log``, its warnings also in
    ``summary["warnings"]``. Relative paths in the study resolve as on the command line
    (against the current directory, or the study file's for data files). Ctrl-C stops the
    job at its next safe point and raises ``KeyboardInterrupt``."""
    out, log = _progress.run(
        _occam.simulate, (os.fspath(path), _path(output)), progress, "occam simulate", "experiments"
    )
    return _with_log(SimulateResult.read(out), log)


def fit(path, output=None, resume=False, progress=True):
    """``occam fit``: MAP, Fisher matrix and Metropolis–Hastings of the ``[fit]`` model, into
    ``output`` (default ``<output>/fit``), exactly as the command line runs it (same numbers,
    same files, same run-directory lock); ``resume=True`` continues from the checkpoint (after
    Ctrl-C too). Returns a ``FitResult``; ``progress`` as for ``simulate``."""
    out, log = _progress.run(
        _occam.fit,
        (os.fspath(path), _path(output), bool(resume)),
        progress,
        "occam fit",
        "iterations",
    )
    return _with_log(FitResult.read(out), log, path)


def select(path, output=None, resume=False, progress=True):
    """``occam select``: every Bayes-factor estimator between the ``[[select.model]]`` models,
    into ``output`` (default ``<output>/select``), exactly as the command line runs it;
    ``resume=True`` continues from the checkpoint (after Ctrl-C too). Returns a
    ``SelectResult``; its ``log`` holds every line ``occam select`` prints."""
    out, log = _progress.run(
        _occam.select,
        (os.fspath(path), _path(output), bool(resume)),
        progress,
        "occam select",
        "ln L evaluations",
    )
    return _with_log(SelectResult.read(out), log, path)


def sweep(path, output=None, resume=False, axes=None, realisations=None, truth=None,
          threads=0, progress=True):
    """``occam sweep``: model selection over the study's ``[[sweep.axis]]`` grid (or ``axes``,
    a list of ``"KEY=v1,v2"``, ``"KEY=log:FROM:TO:N"`` strings as ``--axis`` takes) with
    ``realisations`` noise realisations per point, into ``output`` (default
    ``<output>/sweep``). Finished tasks in the run directory are reused (``resume=True`` also
    requires one to exist, as ``--resume``). Ctrl-C starts no new task, lets those in flight
    finish (their records are kept) and raises ``KeyboardInterrupt``; run it again to
    continue. Returns a ``SweepResult``."""
    out, log = _progress.run(
        _occam.sweep,
        (
            os.fspath(path),
            _path(output),
            bool(resume),
            None if axes is None else [str(a) for a in axes],
            realisations,
            truth,
            int(threads),
        ),
        progress,
        "occam sweep",
        "tasks",
    )
    return _with_log(SweepResult.read(out), log, path)


def design(path, output=None, validate=None):
    """``occam design``: the injections that best separate the ``[[select.model]]`` models
    under the ``[design]`` budget, into ``output`` (default ``<output>/design``): writes
    ``design.toml`` (a runnable study), ``baseline.toml`` and ``design.json``. ``validate``:
    ``None`` no validation, ``0`` the study's ``[design] realisations`` of full model
    selection, ``R`` that many. The design search has no progress counters: no bar, and
    Ctrl-C takes effect when it returns. Returns a ``DesignResult``."""
    out, log = _occam.design(os.fspath(path), _path(output), validate, None)
    return _with_log(DesignResult.read(out), log, path)


def report(run_dir, output=None):
    """``occam report``: writes the self-contained HTML page of a fit, select or sweep run
    (default ``RUN_DIR/report.html``) and returns its path (a ``pathlib.Path``)."""
    from pathlib import Path

    return Path(_occam.report(os.fspath(run_dir), _path(output)))
