"""Result objects of `occam.simulate`, `occam.fit`, `occam.select`, `occam.sweep` and
`occam.design`: the run directory read back into numpy arrays and dicts (readable again later
with ``FitResult.read(dir)`` etc.)."""

import json
import os
from pathlib import Path

import numpy as np

from ._arviz import (
    bin_spreads,
    check_observations,
    inference_data,
    observation_groups,
    observed_data_group,
    rj_log_likelihood,
)


def _load_npz(path):
    """Every array of an ``.npz`` (no pickles: occam writes none)."""
    with np.load(path, allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


def _read_json(path):
    with open(path, encoding="utf-8") as f:
        return json.load(f)


def _files(output):
    """The files the run published (``manifest.json``), or ``[]`` for an older directory."""
    m = Path(output) / "manifest.json"
    if not m.exists():
        return []
    files = _read_json(m).get("files", [])
    return [f["name"] if isinstance(f, dict) else f for f in files]


def _az_from_dict(**groups):
    """``arviz.from_dict`` across its two signatures (keyword groups before arviz 1.0, one
    dict of groups after)."""
    import inspect

    import arviz as az

    attrs = groups.pop("attrs", None)
    if "posterior" in inspect.signature(az.from_dict).parameters:
        return az.from_dict(**groups, attrs=attrs)
    return az.from_dict(groups, attrs=attrs)


def _study_of(result):
    """The study a run was made from: the one given to ``occam.fit``/``select``, else the run
    directory's ``study.resolved.toml`` (every default filled in)."""
    if getattr(result, "study", None):
        return result.study
    p = result.output / "study.resolved.toml"
    if not p.exists():
        raise ValueError(
            f"{result.output}: no study.resolved.toml to rebuild the likelihood from: pass "
            "study=<the study file> to to_arviz, or log_likelihood=prior=observed_data=False"
        )
    return p


class Chains:
    """Metropolis–Hastings chains as ``chains.npz`` stores them (kept draws only).

    ``samples`` ``[chains, draws, params]``, ``ln_posterior`` and ``ln_likelihood``
    ``[chains, draws]``, ``param_names`` (list), ``accepted`` ``[chains, draws]`` bool (whether
    the state moved at that draw; ``None`` for files written before occam stored it).
    """

    def __init__(self, samples, ln_posterior, ln_likelihood, param_names, accepted=None):
        self.samples = samples
        self.ln_posterior = ln_posterior
        self.ln_likelihood = ln_likelihood
        self.param_names = list(param_names)
        self.accepted = accepted

    @classmethod
    def read(cls, path, param_names=None):
        """Reads a ``chains.npz``; ``param_names`` is needed only for files without names."""
        z = _load_npz(path)
        for k in ("samples", "ln_posterior", "ln_likelihood"):
            if k not in z:
                raise ValueError(f"{path}: no array `{k}`: not a chains file of occam")
        names = [str(n) for n in z["param_names"]] if "param_names" in z else param_names
        if names is None:
            raise ValueError(
                f"{path}: the file has no `param_names` (written before occam stored them); "
                "pass param_names"
            )
        if len(names) != z["samples"].shape[-1]:
            raise ValueError(
                f"{path}: {len(names)} parameter names for {z['samples'].shape[-1]} columns"
            )
        return cls(z["samples"], z["ln_posterior"], z["ln_likelihood"], names, z.get("accepted"))

    @property
    def n_chains(self):
        return self.samples.shape[0]

    @property
    def n_draws(self):
        return self.samples.shape[1]

    def to_arviz(self, attrs=None):
        """``arviz.InferenceData``: posterior with one variable per parameter, dims
        ``(chain, draw)``; sample_stats ``lp`` (ln posterior), ``ln_likelihood`` (ln L) and
        ``accepted`` (when stored)."""
        posterior = {n: self.samples[:, :, i] for i, n in enumerate(self.param_names)}
        stats = {"lp": self.ln_posterior, "ln_likelihood": self.ln_likelihood}
        if self.accepted is not None:
            stats["accepted"] = self.accepted.astype(bool)
        return _az_from_dict(posterior=posterior, sample_stats=stats, attrs=attrs or {})

    def __repr__(self):
        return (
            f"occam.Chains({self.n_chains} chains × {self.n_draws} draws, "
            f"params={self.param_names!r})"
        )


class RjChain:
    """The reversible-jump chain of ``select`` (``rj_chain.npz``), post burn-in.

    ``model_index`` ``[chains, draws]`` (into ``model_names``), ``samples``
    ``[chains, draws, params]`` over ``param_names`` (the union of the models' parameters; NaN
    where the current model has no such parameter), ``ln_likelihood`` ``[chains, draws]``,
    ``thin`` (every ``thin``-th iteration is stored).
    """

    def __init__(self, model_index, model_names, param_names, samples, ln_likelihood, thin):
        self.model_index = model_index
        self.model_names = list(model_names)
        self.param_names = list(param_names)
        self.samples = samples
        self.ln_likelihood = ln_likelihood
        self.thin = thin

    @classmethod
    def read(cls, path):
        z = _load_npz(path)
        for k in ("model_index", "model_names", "param_names", "samples", "ln_likelihood"):
            if k not in z:
                raise ValueError(f"{path}: no array `{k}`: not an RJ chain file of occam")
        thin = int(np.asarray(z["thin"]).reshape(-1)[0]) if "thin" in z else 1
        return cls(
            z["model_index"],
            [str(n) for n in z["model_names"]],
            [str(n) for n in z["param_names"]],
            z["samples"],
            z["ln_likelihood"],
            thin,
        )

    def visits(self):
        """Stored draws per model (× ``thin`` ≈ the iterations ``summary.json`` counts)."""
        return np.bincount(self.model_index.reshape(-1), minlength=len(self.model_names))

    def to_arviz(self, attrs=None):
        """``arviz.InferenceData`` of the model-index chain: posterior ``model_index`` and, per
        model, ``is_<model>`` (1.0 in that model, else 0.0: its mean is the model's
        posterior probability from the visits, with ArviZ's ESS and MCSE); sample_stats
        ``ln_likelihood``. The parameters (NaN outside their models) stay in ``samples``."""
        posterior = {"model_index": self.model_index}
        for k, n in enumerate(self.model_names):
            posterior[f"is_{n}"] = (self.model_index == k).astype(np.float64)
        a = dict(attrs or {})
        a["model_names"] = list(self.model_names)
        a["thin"] = self.thin
        return _az_from_dict(
            posterior=posterior, sample_stats={"ln_likelihood": self.ln_likelihood}, attrs=a
        )

    def __repr__(self):
        return (
            f"occam.RjChain({self.model_index.shape[0]} chains × {self.model_index.shape[1]} "
            f"draws, models={self.model_names!r}, thin={self.thin})"
        )


class SimulateResult:
    """What ``occam.simulate`` wrote: ``output`` (the directory), ``dataset`` (the arrays of
    ``dataset.npz`` by name: ``<experiment>.o1``, …, ``truth``), ``metadata``
    (``dataset.json``), ``files`` (the published files)."""

    def __init__(self, output, dataset, metadata, files):
        self.output = Path(output)
        self.dataset = dataset
        self.metadata = metadata
        self.files = files
        self.log = []

    @classmethod
    def read(cls, output):
        out = Path(os.fspath(output))
        return cls(
            out,
            _load_npz(out / "dataset.npz"),
            _read_json(out / "dataset.json"),
            _files(out),
        )

    def __repr__(self):
        return f"occam.SimulateResult(output={str(self.output)!r})"


class FitResult:
    """What ``occam.fit`` wrote: ``summary`` (``summary.json`` as a dict), ``output``, the
    chains (``samples``, ``ln_posterior``, ``ln_likelihood``, ``param_names``, ``accepted``;
    also as ``chains``), ``files``."""

    def __init__(self, output, summary, chains, files):
        self.output = Path(output)
        self.summary = summary
        self.chains = chains
        self.files = files
        self.log = []

    @classmethod
    def read(cls, output):
        """Reads a fit run directory."""
        out = Path(os.fspath(output))
        summary = _read_json(out / "summary.json")
        names = [r["name"] for r in summary.get("rows", [])]
        return cls(out, summary, Chains.read(out / "chains.npz", names), _files(out))

    samples = property(lambda self: self.chains.samples)
    ln_posterior = property(lambda self: self.chains.ln_posterior)
    ln_likelihood = property(lambda self: self.chains.ln_likelihood)
    param_names = property(lambda self: self.chains.param_names)
    accepted = property(lambda self: self.chains.accepted)

    def to_arviz(self, log_likelihood=True, prior=True, observed_data=True,
                 per_experiment=False, max_draws=2000, max_values=20_000_000,
                 prior_draws=1000, study=None, observations="groups"):
        """``arviz.InferenceData`` of the chains (see ``Chains.to_arviz``; ``attrs`` hold the
        model, the statistic and the likelihood the chains ran on) with the groups
        ``az.loo``, ``az.compare`` and ``az.plot_*`` read:

        * ``log_likelihood``: the exact ``ln L`` at thinned posterior draws, observation by
          observation, so that summed over observations it is the draw's exact ``ln L`` (the
          chains' stored ``ln L`` when they ran on the exact likelihood). The observations
          (``observations="groups"``, the default) are groups of adjacent frequency bins: a
          bin whose ``ln L`` varies by less than 1e-6 nat over the posterior carries no
          information and is folded into the next bin that does (alone, ArviZ's Pareto fit of
          such a bin is a fit to rounding: ``elpd_loo`` NaN, spurious ``k̂ > 0.7``);
          coordinates ``experiment``, ``frequency`` (the informative bin's), ``f_lo``,
          ``f_hi`` and ``n_bins``. ``observations="bins"``: one observation per bin, as
          before (coordinates ``experiment`` and ``frequency``). One variable ``spectrum``,
          dims ``(chain, draw, observation)`` (or ``bin``), every experiment's observations
          (``az.loo(idata)`` needs a single variable); ``per_experiment=True``: one variable
          per experiment, dims ``(chain, draw, <experiment>_observation)`` (then
          ``az.loo(idata, var_name="a")``). Memory: at most ``max_draws`` draws over all
          chains and ``max_values`` numbers (8 bytes each) in all, evenly thinned; the
          ``draw`` coordinate holds the kept draws' indices.
        * ``prior``: ``prior_draws`` draws from the prior (seeded: the same each call).
        * ``observed_data``: ``spectrum`` (or one variable per experiment), the data's
          ``|DFT|`` per bin and data channel, dims ``(bin, channel)``.

        These groups rebuild the likelihood from the study: ``study`` (default: the study the
        run was made from, else the run directory's ``study.resolved.toml``)."""
        check_observations(observations)
        s = self.summary
        attrs = {k: s[k] for k in ("model", "statistic", "likelihood") if k in s}
        attrs["occam_output"] = str(self.output)
        idata = self.chains.to_arviz(attrs)
        if not (log_likelihood or prior or observed_data):
            return idata
        from ._likelihood import Likelihood

        lik = Likelihood.from_study(study or _study_of(self), None)
        groups = None
        if log_likelihood and observations == "groups":
            p = self.chains.samples.shape[-1]
            groups = observation_groups(
                lik.experiments, [bin_spreads(lik, self.chains.samples.reshape(-1, p))]
            )
        return inference_data(
            idata, self.chains, lik, log_likelihood=log_likelihood, prior=prior,
            observed_data=observed_data, per_experiment=per_experiment,
            max_draws=max_draws, max_values=max_values, prior_draws=prior_draws,
            groups=groups,
        )

    def __repr__(self):
        return (
            f"occam.FitResult(output={str(self.output)!r}, model={self.summary.get('model')!r}, "
            f"{self.chains!r})"
        )


class SelectResult:
    """What ``occam.select`` wrote: ``summary`` (``summary.json``), ``output``, ``models``
    (dict model name → ``Chains``: each model's in-model chains, ``chains_<model>.npz``), ``rj``
    (``RjChain``, ``None`` when the reversible-jump run did not run), ``files``."""

    def __init__(self, output, summary, models, rj, files):
        self.output = Path(output)
        self.summary = summary
        self.models = models
        self.rj = rj
        self.files = files
        self.log = []

    @classmethod
    def read(cls, output):
        """Reads a select run directory."""
        out = Path(os.fspath(output))
        summary = _read_json(out / "summary.json")
        models = {}
        for m in summary.get("models", []):
            p = out / f"chains_{m['name']}.npz"
            if p.exists():
                models[m["name"]] = Chains.read(p, m.get("free"))
        rj = RjChain.read(out / "rj_chain.npz") if (out / "rj_chain.npz").exists() else None
        return cls(out, summary, models, rj, _files(out))

    @property
    def model_names(self):
        return [m["name"] for m in self.summary.get("models", [])]

    @property
    def model_probabilities(self):
        """Posterior model probabilities (from the reversible jump) as a dict model name →
        probability, in ``[[select.model]]`` order; ``{}`` when the reversible jump gave
        none."""
        p = self.posterior_model_probabilities
        return dict(zip(self.model_names, p)) if p else {}

    @property
    def posterior_model_probabilities(self):
        """The same as a list in ``model_names`` order (``summary.json``'s
        ``posterior_model_probabilities``), or ``None``."""
        return self.summary.get("posterior_model_probabilities")

    def _likelihood(self, study, model):
        """``occam.Likelihood`` of ``model`` on ``study``, built once per result."""
        from ._likelihood import Likelihood

        cache = self.__dict__.setdefault("_likelihoods", {})
        key = (str(study), model)
        if key not in cache:
            cache[key] = Likelihood.from_study(study, model)
        return cache[key]

    def _observation_groups(self, study):
        """``observation_groups`` over every model with chains: the same observations for
        each, as ``az.compare`` needs."""
        cache = self.__dict__.setdefault("_groups", {})
        if str(study) not in cache:
            spreads = []
            for name, chains in self.models.items():
                lik = self._likelihood(study, name)
                p = chains.samples.shape[-1]
                spreads.append(bin_spreads(lik, chains.samples.reshape(-1, p)))
            any_lik = self._likelihood(study, next(iter(self.models)))
            cache[str(study)] = observation_groups(any_lik.experiments, spreads)
        return cache[str(study)]

    def to_arviz(self, model=None, log_likelihood=True, prior=True, observed_data=True,
                 per_experiment=False, max_draws=2000, max_values=20_000_000,
                 prior_draws=1000, study=None, observations="groups"):
        """``arviz.InferenceData``.

        ``model=None`` gives the reversible-jump chain (``RjChain.to_arviz``: ``model_index``
        and ``is_<model>``) with, when ``log_likelihood``, the model-averaged pointwise ln L
        (each kept draw's ``ln L`` under the model it is in), so that ``az.loo`` gives the
        leave-one-out predictive of the posterior over models and parameters; and
        ``observed_data``. It has no ``prior`` group (the prior is one per model).

        A model name gives that model's in-model chains (``Chains.to_arviz``) with the
        ``log_likelihood``, ``prior`` and ``observed_data`` groups of ``FitResult.to_arviz``
        (same arguments), so that
        ``az.compare({m: sel.to_arviz(m) for m in sel.model_names})`` compares the models by
        leave-one-out cross-validation. With ``observations="groups"`` the groups of bins are
        decided over every model of the run, so that each model has the same observations."""
        check_observations(observations)
        if model is not None and model not in self.models:
            raise ValueError(
                f"{self.output}: no chains of model `{model}`; the models with chains are "
                f"{list(self.models)}"
            )
        if model is None and self.rj is None:
            raise ValueError(
                f"{self.output}: no reversible-jump chain (rj_chain.npz): "
                f"{self.summary.get('rj_note') or 'not written by this occam version'}"
            )
        attrs = {"occam_output": str(self.output)}
        if model is None:
            idata = self.rj.to_arviz(attrs)
            prior = False
        else:
            idata = self.models[model].to_arviz({"model": model, **attrs})
        if not (log_likelihood or prior or observed_data):
            return idata
        study = study or _study_of(self)
        groups = None
        if log_likelihood and observations == "groups":
            if not self.models:
                raise ValueError(
                    f"{self.output}: no model's chains (chains_<model>.npz) to decide the "
                    "groups of bins on: pass observations='bins'"
                )
            groups = self._observation_groups(study)
        if model is not None:
            return inference_data(
                idata, self.models[model], self._likelihood(study, model),
                log_likelihood=log_likelihood, prior=prior, observed_data=observed_data,
                per_experiment=per_experiment, max_draws=max_draws, max_values=max_values,
                prior_draws=prior_draws, groups=groups,
            )
        liks = {m: self._likelihood(study, m) for m in self.rj.model_names}
        out = {}
        if log_likelihood:
            out["log_likelihood"] = rj_log_likelihood(
                self.rj, liks, max_draws=max_draws, max_values=max_values,
                per_experiment=per_experiment, groups=groups,
            )
        if observed_data:
            first = liks[self.rj.model_names[0]]
            out["observed_data"] = observed_data_group(first.experiments, per_experiment)
        idata.add_groups(out)
        return idata

    def __repr__(self):
        return (
            f"occam.SelectResult(output={str(self.output)!r}, models={self.model_names!r}, "
            f"rj={'yes' if self.rj is not None else 'no'})"
        )


class SweepResult:
    """What ``occam.sweep`` wrote: ``summary`` (``sweep.json``: the grid, every point's
    estimates, bands and how often each model was picked), ``arrays`` (``sweep.npz`` by name),
    ``output``, ``files``, ``log`` (every line ``occam sweep`` prints, its table included)."""

    def __init__(self, output, summary, arrays, files):
        self.output = Path(output)
        self.summary = summary
        self.arrays = arrays
        self.files = files
        self.log = []

    @classmethod
    def read(cls, output):
        """Reads a sweep run directory."""
        out = Path(os.fspath(output))
        npz = out / "sweep.npz"
        return cls(
            out,
            _read_json(out / "sweep.json"),
            _load_npz(npz) if npz.exists() else {},
            _files(out),
        )

    def __repr__(self):
        return f"occam.SweepResult(output={str(self.output)!r})"


class DesignResult:
    """What ``occam.design`` wrote: ``report`` (``design.json``: the baseline, start and chosen
    designs with their proxy scores, the search and any validation), ``design_study`` (the
    runnable study of the chosen design, ``design.toml``), ``baseline_study``
    (``baseline.toml``), ``output``, ``files``, ``log`` (the table ``occam design`` prints)."""

    def __init__(self, output, report, files):
        self.output = Path(output)
        self.report = report
        self.design_study = self.output / "design.toml"
        self.baseline_study = self.output / "baseline.toml"
        self.files = files
        self.log = []

    @classmethod
    def read(cls, output):
        """Reads a design run directory."""
        out = Path(os.fspath(output))
        return cls(out, _read_json(out / "design.json"), _files(out))

    def __repr__(self):
        return f"occam.DesignResult(output={str(self.output)!r})"
