"""occam from Python: a study's likelihood for your own samplers, and occam's jobs with their
results as numpy arrays and ArviZ data.

>>> import occam
>>> lik = occam.Likelihood.from_study("examples/tn3045.toml")
>>> lik.ln_posterior(lik.reference)              # one point: a float
>>> fit = occam.fit("examples/tn3045.toml")      # the same run as `occam fit`
>>> import arviz as az; az.summary(fit.to_arviz())

Errors of occam raise ``occam.OccamError`` (a ``RuntimeError``) with the message the command
line prints; wrong arguments (shapes, NaN) raise ``ValueError``.
"""

import os

from . import _occam
from ._likelihood import Likelihood
from ._results import Chains, FitResult, RjChain, SelectResult, SimulateResult

OccamError = _occam.OccamError
__version__ = _occam.__version__

__all__ = [
    "Chains",
    "FitResult",
    "Likelihood",
    "OccamError",
    "RjChain",
    "SelectResult",
    "SimulateResult",
    "fit",
    "select",
    "simulate",
]


def _path(p):
    return None if p is None else os.fspath(p)


def _with_log(result, log):
    result.log = list(log)
    return result


def simulate(path, output=None):
    """``occam simulate``: simulates the study's experiments into ``output`` (default: the
    study's ``output``) and returns a ``SimulateResult``.

    Every job runs exactly as the command line does (``occam::commands``: the same numbers and
    files, the run directory's lock, staging and ``manifest.json``), on all cores with the GIL
    released; it prints nothing: the lines the command line prints while running (data
    origin, what is resumed) are in the result's ``log``, its warnings in
    ``summary["warnings"]``. Relative paths in the study resolve as on the command line
    (against the current directory, or the study file's for data files)."""
    out, log = _occam.simulate(os.fspath(path), _path(output))
    return _with_log(SimulateResult.read(out), log)


def fit(path, output=None, resume=False):
    """``occam fit``: MAP, Fisher matrix and Metropolis–Hastings of the ``[fit]`` model, into
    ``output`` (default ``<output>/fit``), exactly as the command line runs it (same numbers,
    same files, same run-directory lock); ``resume=True`` continues from the checkpoint.
    Returns a ``FitResult``."""
    out, log = _occam.fit(os.fspath(path), _path(output), bool(resume))
    return _with_log(FitResult.read(out), log)


def select(path, output=None, resume=False):
    """``occam select``: every Bayes-factor estimator between the ``[[select.model]]`` models,
    into ``output`` (default ``<output>/select``), exactly as the command line runs it.
    Returns a ``SelectResult``."""
    out, log = _occam.select(os.fspath(path), _path(output), bool(resume))
    return _with_log(SelectResult.read(out), log)
