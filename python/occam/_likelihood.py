"""`occam.Likelihood`: a study's likelihood for samplers written in Python."""

import os
from statistics import NormalDist

import numpy as np

from . import _occam


def _points(theta):
    """`theta` as a float64 array (no copy when it already is one)."""
    return np.asarray(theta, dtype=np.float64)


class Likelihood:
    """The exact likelihood of one model of a study over its free parameters.

    Built by the same library calls as ``occam fit`` and ``occam select`` (the data loaded or
    simulated as the command line does, the same spectra, noise estimate and statistic), so
    ``ln_likelihood`` returns, bit for bit, the ``ln L`` the command line's samplers see with
    ``[analysis] likelihood = "exact"``. ``theta`` is the vector of the model's free parameters
    in the order of ``param_names`` (the last axis of ``chains.npz``'s ``samples``).

    Every density method takes one point (a 1-D array of ``len(param_names)`` values: returns a
    float) or many (a 2-D array, one row per point: returns a 1-D array, rows evaluated in
    parallel on all cores with the GIL released; the numbers do not depend on the thread
    count). Wrong shapes and non-finite values raise ``ValueError``.
    """

    __slots__ = ("_native", "_args")

    def __init__(self, native, args=None):
        """Use `Likelihood.from_study`."""
        if not isinstance(native, _occam._Likelihood):
            raise TypeError("use occam.Likelihood.from_study(path, model=None)")
        self._native = native
        self._args = args

    @classmethod
    def from_study(cls, path, model=None):
        """The likelihood of a study's model.

        ``model=None`` is the study's ``[fit]`` model (with its ``free``/``fixed``); a string
        names one of the study's ``[[select.model]]`` tables. Raises ``occam.OccamError`` with
        the command line's message for a study that cannot be read or data that cannot be
        prepared.
        """
        native = _occam._Likelihood.from_study(os.fspath(path), model)
        return cls(native, (os.path.abspath(os.fspath(path)), model))

    def __reduce__(self):
        # a pickled likelihood is rebuilt from its study in the receiving process (the data
        # are simulated again from the same seed, or read again): what a multiprocessing pool
        # of emcee or dynesty needs
        return (type(self).from_study, self._args)

    def ln_likelihood(self, theta):
        """``ln L(θ)`` (natural log, the study's ``[analysis] statistic``)."""
        return self._native.ln_likelihood(_points(theta))

    def ln_prior(self, theta):
        """``ln π(θ)``: the normalised prior of the free parameters; ``-inf`` outside it."""
        return self._native.ln_prior(_points(theta))

    def ln_posterior(self, theta):
        """``ln L(θ) + ln π(θ)``; ``-inf`` outside the prior (``ln L`` is then not evaluated)."""
        return self._native.ln_posterior(_points(theta))

    def fisher(self, theta):
        """The Fisher matrix ``[P, P]`` of the Gaussian (Whittle) ``ln L`` at one point.

        Exact (dual numbers through the model), over the free parameters; for the
        ``student_t`` and ``log_periodogram`` statistics it is still the Whittle one, as the
        command line's MAP search uses.
        """
        return self._native.fisher(_points(theta))

    def prior_transform(self, u):
        """Maps the unit cube to the prior (nested samplers: dynesty, nautilus, UltraNest).

        ``u`` in ``[0, 1]``, one point (1-D) or one row per point (2-D): each coordinate
        through its prior's inverse CDF (uniform ``lo + u (hi − lo)``, log-uniform
        ``lo (hi/lo)^u``, Gaussian ``mu + sigma Φ⁻¹(u)``).
        """
        u = np.array(u, dtype=np.float64)
        if u.ndim not in (1, 2) or u.shape[-1] != self.ndim:
            raise ValueError(
                f"u must have shape ({self.ndim},) or (n, {self.ndim}); got {u.shape}"
            )
        if not np.all((u >= 0) & (u <= 1)):
            raise ValueError("u must lie in [0, 1] (and not be NaN)")
        out = np.empty_like(u)
        for k, p in enumerate(self.priors):
            x = u[..., k]
            if p["kind"] == "uniform":
                out[..., k] = p["lo"] + x * (p["hi"] - p["lo"])
            elif p["kind"] == "log_uniform":
                out[..., k] = p["lo"] * (p["hi"] / p["lo"]) ** x
            else:
                inv = NormalDist(p["mu"], p["sigma"]).inv_cdf
                # Φ⁻¹(0) and Φ⁻¹(1) are ∓∞
                out[..., k] = np.vectorize(
                    lambda v: -np.inf if v == 0 else np.inf if v == 1 else inv(v),
                    otypes=[np.float64],
                )(x)
        return out

    @property
    def param_names(self):
        """Names of the free parameters, in the order of θ."""
        return self._native.param_names

    @property
    def ndim(self):
        """Number of free parameters."""
        return len(self._native.param_names)

    @property
    def prior_bounds(self):
        """``[P, 2]`` array: each free parameter's prior support ``(lo, hi)``.

        Uniform and log-uniform priors give their box; a Gaussian prior gives
        ``(-inf, inf)`` (its support; ``priors`` has its ``mu`` and ``sigma``).
        """
        return self._native.prior_bounds

    @property
    def priors(self):
        """Each free parameter's prior as a dict: ``name``, ``kind`` (``uniform``,
        ``log_uniform``: ``lo``, ``hi``; ``gaussian``: ``mu``, ``sigma``)."""
        return self._native.priors

    @property
    def reference(self):
        """A reference point of the free parameters (1-D array).

        The injected truth when the data are simulated (or a dataset written by
        ``occam simulate``) and every free parameter has a true value; otherwise the start
        of the command line's MAP search (``[fit] start``, else the prior centre).
        ``reference_source`` says which (``"truth"`` or ``"start"``).
        """
        return self._native.reference

    @property
    def reference_source(self):
        """``"truth"`` or ``"start"``: where ``reference`` comes from."""
        return self._native.reference_source

    @property
    def n_bins(self):
        """In-band frequency bins, summed over the experiments."""
        return self._native.n_bins

    @property
    def model(self):
        """The ``[[select.model]]`` name, or the name of the ``[fit]`` model."""
        return self._native.model

    @property
    def parent_model(self):
        """The model this one is a sub-model of (a ``[[model]]`` name, or ``ltp``)."""
        return self._native.parent_model

    @property
    def fixed(self):
        """The parameters held fixed, as a dict name → value."""
        return dict(self._native.fixed)

    @property
    def statistic(self):
        """``[analysis] statistic``: ``whittle``, ``student_t`` or ``log_periodogram``."""
        return self._native.statistic

    @property
    def study(self):
        """The study file."""
        return self._native.study

    @property
    def warnings(self):
        """The warnings ``occam fit``/``select`` print about this model on these data."""
        return self._native.warnings

    def __repr__(self):
        return (
            f"occam.Likelihood(study={self.study!r}, model={self.model!r}, "
            f"params={self.param_names!r}, n_bins={self.n_bins}, "
            f"statistic={self.statistic!r})"
        )
