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


def simulate(path, output=None):
    """``occam simulate``: simulates the study's experiments into ``output`` (default: the
    study's ``output``) and returns a ``SimulateResult``."""
    out = _occam.simulate(os.fspath(path), _path(output))
    return SimulateResult.read(out)


def fit(path, output=None, resume=False):
    """``occam fit``: MAP, Fisher matrix and Metropolis–Hastings of the ``[fit]`` model, into
    ``output`` (default ``<output>/fit``), exactly as the command line runs it (same numbers,
    same files, same run-directory lock); ``resume=True`` continues from the checkpoint.
    Returns a ``FitResult``."""
    out = _occam.fit(os.fspath(path), _path(output), bool(resume))
    return FitResult.read(out)


def select(path, output=None, resume=False):
    """``occam select``: every Bayes-factor estimator between the ``[[select.model]]`` models,
    into ``output`` (default ``<output>/select``), exactly as the command line runs it.
    Returns a ``SelectResult``."""
    out = _occam.select(os.fspath(path), _path(output), bool(resume))
    return SelectResult.read(out)
