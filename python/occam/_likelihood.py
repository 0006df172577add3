"""`occam.Likelihood`: a study's likelihood for samplers written in Python."""

import os
from statistics import NormalDist

import numpy as np

from . import _occam


def _points(theta):
    """`theta` as a float64 array (no copy when it already is one)."""
    return np.asarray(theta, dtype=np.float64)


class MapResult:
    """The MAP search's answer (``Likelihood.map``): ``theta`` (free parameters, in the order
    of ``param_names``), ``ln_posterior`` (``ln L + ln π`` there, Whittle), ``sigma``
    (Cramér–Rao σ from the Fisher matrix there; ``None`` when it is singular), ``fisher``
    ``[P, P]``, ``converged``, ``iterations``, ``at_bound`` (per parameter: on a bound of the
    prior box) and ``n_maxima`` (distinct maxima the multi-start search found)."""

    __slots__ = ("theta", "ln_posterior", "sigma", "fisher", "converged", "iterations",
                 "at_bound", "n_maxima", "param_names")

    def __init__(self, d, param_names):
        for k in self.__slots__[:-1]:
            setattr(self, k, d[k])
        self.param_names = list(param_names)

    def as_dict(self):
        """The MAP as a dict name → value."""
        return dict(zip(self.param_names, self.theta.tolist()))

    def __repr__(self):
        return (
            f"occam.MapResult(theta={self.as_dict()!r}, ln_posterior={self.ln_posterior!r}, "
            f"converged={self.converged})"
        )


class Likelihood:
    """The likelihood of one model of a study over its free parameters: the exact one, or
    (``binned=True``) the relative-binned one the command line's samplers run on.

    Built by the same library calls as ``occam fit`` and ``occam select`` (the data loaded or
    simulated as the command line does, the same spectra, noise estimate and statistic), so
    ``ln_likelihood`` returns, bit for bit, the ``ln L`` the command line's samplers see with
    ``[analysis] likelihood = "exact"`` (and, with ``binned=True``, the one they see with
    ``likelihood = "relbin"``). ``theta`` is the vector of the model's free parameters
    in the order of ``param_names`` (the last axis of ``chains.npz``'s ``samples``).

    A model whose residual noise moves with its parameters (``noise = "model"`` through the
    model's own dynamics, e.g. a state-space model's noise inputs) is the exception:
    ``ln_likelihood``, ``ln_posterior`` and ``ln_likelihood_per_bin`` then evaluate the noise
    at θ itself (the exact Whittle likelihood, ``ln det C(θ)`` included: an external sampler's
    evidence needs no correction), while ``map()``, ``fisher()`` and ``binned=True`` hold it at
    the model's own MAP, as the command line's samplers do (``warnings`` says so).

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
    def from_study(cls, path, model=None, binned=False):
        """The likelihood of a study's model.

        ``model=None`` is the study's ``[fit]`` model (with its ``free``/``fixed``); a string
        names one of the study's ``[[select.model]]`` tables. ``binned=True`` evaluates
        ``ln_likelihood`` and ``ln_posterior`` by relative binning, built exactly as the
        command line's samplers build it (the MAP search, then the coarse bins validated
        around it: ``occam fit``'s region for the ``[fit]`` model, ``occam select``'s for a
        select model), so the values equal the ``ln L`` stored in their chains; ``binning``
        holds its validation. It is an approximation valid near the posterior (the validated
        region: ``[analysis] relbin_sigma`` Fisher σ); ``fisher``, ``map`` and
        ``ln_likelihood_per_bin`` stay exact. Raises ``occam.OccamError`` with the command
        line's message for a study that cannot be read or data that cannot be prepared.
        """
        native = _occam._Likelihood.from_study(os.fspath(path), model, bool(binned))
        return cls(native, (os.path.abspath(os.fspath(path)), model, bool(binned)))

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

    def ln_likelihood_per_bin(self, theta):
        """The exact ``ln L`` frequency bin by frequency bin at each row of ``theta``.

        ``theta`` one point (1-D) or one row per point (2-D ``(n, P)``); returns a dict
        experiment name → array ``(bins,)`` (1-D input) or ``(n, bins)``, the experiment's
        in-band bins at ``experiments[i]["freqs"]``. Each bin's term carries its share of the
        normalisation, so that summed over bins and experiments they give the exact
        ``ln_likelihood`` (the bins are the independent observations of the Whittle,
        Student-t and Wishart likelihoods: what ``az.loo`` needs). The log-periodogram
        statistic has no per-bin terms: ``OccamError``.
        """
        t = _points(theta)
        one = t.ndim == 1
        parts = self._native.ln_likelihood_per_bin(t[None, :] if one else t)
        names = [e["name"] for e in self._native.experiments]
        return {n: (p[0] if one else p) for n, p in zip(names, parts)}

    def map(self, start=None):
        """The MAP: the multi-start search of ``occam fit`` (Fisher scoring on the exact
        Whittle ``ln L + ln π``, bounded by the prior box, from ``start`` and ``[fit]
        map_starts`` quasi-random points of the prior). ``start``: the free parameters' values
        to start from (``None``: the command line's start, ``[fit] start`` or the prior
        centre). Returns a ``MapResult`` (``theta``, ``ln_posterior``, ``sigma``, …); the
        GIL is released while it runs."""
        s = None if start is None else _points(start)
        return MapResult(self._native.map(s), self.param_names)

    @property
    def binning(self):
        """``None`` for the exact likelihood; with ``binned=True`` the relative binning's
        validation, as the command line reports it: ``n_coarse`` coarse bins for ``n_bins``
        bins, ``worst_abs_delta_ln_l`` (the largest ``|ln L̃ − ln L|`` over ``n_points``
        validation points, checked against ``limit``), ``worst_point`` (free parameters),
        ``tolerance``, ``refinements``, ``coverage`` (per parameter, the fraction of its prior
        width the validation points span), ``box_params`` and ``fiducial`` (the MAP it is
        built around)."""
        return self._native.binning

    @property
    def binned(self):
        """Whether ``ln_likelihood`` is the relative-binned approximation."""
        return self._native.binning is not None

    @property
    def experiments(self):
        """Per experiment a dict: ``name``, ``freqs`` (its in-band bins, Hz), ``channels``
        (data channels) and ``data_abs`` (``|DFT|`` of the data there, ``(bins, channels)``)."""
        return self._native.experiments

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
            f"statistic={self.statistic!r}, binned={self.binned})"
        )
