"""The ArviZ groups beyond the chains: ``log_likelihood`` (pointwise ln L at thinned posterior
draws, one observation per group of frequency bins or per bin), ``prior`` (draws from the prior)
and ``observed_data`` (the data's |DFT| per bin). The numbers come from ``occam.Likelihood``;
this module only arranges them."""

import math

import numpy as np

# the one variable of the default layout: the observations are the data's DFT bins
SPECTRUM = "spectrum"

# A bin whose ln L moves by less than this over the posterior (sd over the draws, in nats)
# carries no information about θ, and ArviZ's Pareto fit of its importance weights is a fit to
# rounding: on examples/guidance-delays.toml one such bin (sd 3e-12) made `elpd_loo` NaN and
# 190 others (sd < 1e-6) gave k̂ up to 1.26, while every bin above it gave k̂ ≤ 0.58. Such
# bins are folded into the next bin that carries information (see `observation_groups`).
INFORMATIVE_SD = 1e-6

# draws per model the grouping is decided on (evenly thinned over all chains): enough to
# tell 1e-6 nat from rounding, cheap beside the log_likelihood group itself
GROUPING_DRAWS = 128

OBSERVATIONS = ("groups", "bins")


def kept_draws(n_chains, n_draws, n_bins, max_draws, max_values):
    """Indices of the draws kept per chain: evenly thinned so that at most ``max_draws`` draws
    over all chains and ``max_values`` pointwise values (draws × bins) are stored."""
    if max_draws < 1 or max_values < 1:
        raise ValueError(f"max_draws and max_values must be ≥ 1; got {max_draws}, {max_values}")
    cap = max(1, min(max_draws, max_values // max(n_bins, 1)))
    per_chain = max(1, cap // max(n_chains, 1))
    step = max(1, math.ceil(n_draws / per_chain))
    return np.arange(0, n_draws, step)


def check_observations(observations):
    if observations not in OBSERVATIONS:
        raise ValueError(
            f"observations must be one of {OBSERVATIONS}; got {observations!r}"
        )


def bin_spreads(lik, points):
    """Per experiment name, the sd over ``points`` (rows of free parameters) of each bin's
    ln L; ``points`` evenly thinned to ``GROUPING_DRAWS`` rows first."""
    points = np.asarray(points, dtype=float)
    if len(points) > GROUPING_DRAWS:
        points = points[np.linspace(0, len(points) - 1, GROUPING_DRAWS).round().astype(int)]
    return {n: v.std(axis=0) for n, v in lik.ln_likelihood_per_bin(points).items()}


def observation_groups(exps, spreads):
    """The observations of the ``groups`` layout: per experiment, the group of each bin.

    ``spreads``: one dict per model (experiment name → each bin's ln L sd over that model's
    posterior, ``bin_spreads``). A bin *carries information* when its sd is at least
    ``INFORMATIVE_SD`` in every model whose ln L moves at all (a model with every parameter
    fixed, or chains that never moved, has no say). Each informative bin closes a group with the
    bins before it that carry none; the bins after an experiment's last informative bin join its
    group; an experiment with none is one group. The same groups for every model of a select
    (``az.compare`` needs the same observations) and never across experiments.

    Returns experiment name → ``(group, informative)``: the group index of each bin (0, 1, …)
    and the index of each group's informative bin (its first bin when it has none)."""
    moving = [
        s for s in spreads if any(np.max(v, initial=0.0) >= INFORMATIVE_SD for v in s.values())
    ]
    out = {}
    for e in exps:
        name, n = e["name"], len(e["freqs"])
        if moving:
            info = np.all([s[name] >= INFORMATIVE_SD for s in moving], axis=0)
        else:
            info = np.zeros(n, dtype=bool)
        where = np.flatnonzero(info)
        if where.size == 0:
            out[name] = (np.zeros(n, dtype=np.int64), np.array([0], dtype=np.int64))
            continue
        # a bin's group: how many informative bins come strictly before it
        group = np.concatenate([[0], np.cumsum(info)[:-1]]).astype(np.int64)
        group = np.minimum(group, where.size - 1)
        out[name] = (group, where)
    return out


def _grouped(values, group, n_groups):
    """``values`` ``(…, bins)`` summed over each group's bins: ``(…, n_groups)``."""
    out = np.zeros(values.shape[:-1] + (n_groups,))
    np.add.at(out, (..., group), values)
    return out


def log_likelihood_group(per, exps, n_chains, keep, *, per_experiment, groups):
    """The ``log_likelihood`` dataset of pointwise values ``per`` (experiment name →
    ``(n_chains × len(keep), bins)``), one observation per bin (``groups=None``) or per
    group of ``observation_groups``."""
    import xarray as xr

    shape = lambda v: v.reshape(n_chains, len(keep), -1)  # noqa: E731
    if groups is None:
        dim = "bin"
        values = {e["name"]: per[e["name"]] for e in exps}
        coords = {
            e["name"]: {"frequency": np.asarray(e["freqs"], dtype=float)} for e in exps
        }
    else:
        dim = "observation"
        values, coords = {}, {}
        for e in exps:
            g, info = groups[e["name"]]
            f = np.asarray(e["freqs"], dtype=float)
            values[e["name"]] = _grouped(per[e["name"]], g, len(info))
            coords[e["name"]] = {
                "frequency": f[info],
                "f_lo": np.array([f[g == k].min() for k in range(len(info))]),
                "f_hi": np.array([f[g == k].max() for k in range(len(info))]),
                "n_bins": np.bincount(g, minlength=len(info)),
            }
    base = {"chain": np.arange(n_chains), "draw": keep}
    if per_experiment:
        data, c = {}, dict(base)
        for e in exps:
            n = e["name"]
            d = f"{n}_{dim}"
            data[n] = (("chain", "draw", d), shape(values[n]))
            if groups is None:
                c[d] = coords[n]["frequency"]
            else:
                c[d] = np.arange(len(coords[n]["frequency"]))
                for k, v in coords[n].items():
                    c[f"{n}_{k}"] = (d, v)
        ds = xr.Dataset(data, coords=c)
    else:
        names = [e["name"] for e in exps]
        total = sum(values[n].shape[-1] for n in names)
        c = dict(base)
        c[dim] = np.arange(total)
        c["experiment"] = (
            dim,
            np.concatenate([[n] * values[n].shape[-1] for n in names]),
        )
        for k in coords[names[0]]:
            c[k] = (dim, np.concatenate([coords[n][k] for n in names]))
        ds = xr.Dataset(
            {SPECTRUM: (("chain", "draw", dim), shape(np.concatenate([values[n] for n in names], axis=-1)))},
            coords=c,
        )
    if groups is not None:
        ds.attrs["observations"] = (
            "groups of adjacent frequency bins: each bin whose ln L has an sd of at least "
            f"{INFORMATIVE_SD:g} nat over the posterior (in every model whose ln L moves) ends "
            "a group with the bins before it that carry less; to_arviz(observations='bins') "
            "gives one observation per bin"
        )
    return ds


def inference_data(idata, chains, lik, *, log_likelihood, prior, observed_data, per_experiment,
                   max_draws, max_values, prior_draws, groups=None):
    """``idata`` (posterior and sample_stats of ``chains``) with the groups asked for, from
    the likelihood ``lik`` of the chains' model; ``groups`` (``observation_groups``) or
    ``None`` for one observation per bin."""
    import xarray as xr

    if lik.param_names != chains.param_names:
        raise ValueError(
            f"the likelihood's parameters {lik.param_names} are not the chains' "
            f"{chains.param_names}: pass the study the run was made from (study=...)"
        )
    exps = lik.experiments
    out = {}
    if log_likelihood:
        n_chains, n_draws, p = chains.samples.shape
        keep = kept_draws(n_chains, n_draws, lik.n_bins, max_draws, max_values)
        pts = chains.samples[:, keep].reshape(-1, p)
        out["log_likelihood"] = log_likelihood_group(
            lik.ln_likelihood_per_bin(pts), exps, n_chains, keep,
            per_experiment=per_experiment, groups=groups,
        )
    if prior:
        # seeded: the same draws every call, as every number of occam
        u = np.random.default_rng(0x0CCA).uniform(size=(prior_draws, lik.ndim))
        x = lik.prior_transform(u)
        out["prior"] = xr.Dataset(
            {n: (("chain", "draw"), x[None, :, k]) for k, n in enumerate(lik.param_names)},
            coords={"chain": [0], "draw": np.arange(prior_draws)},
        )
    if observed_data:
        out["observed_data"] = observed_data_group(exps, per_experiment)
    idata.add_groups(out)
    return idata


def observed_data_group(exps, per_experiment):
    """The data's ``|DFT|`` per bin and data channel."""
    import xarray as xr

    channels = exps[0]["channels"]
    if per_experiment:
        data = {e["name"]: ((f"{e['name']}_bin", "channel"), e["data_abs"]) for e in exps}
        coords = {f"{e['name']}_bin": e["freqs"] for e in exps}
    else:
        data = {SPECTRUM: (("bin", "channel"), np.concatenate([e["data_abs"] for e in exps]))}
        coords = {
            "bin": np.arange(sum(len(e["freqs"]) for e in exps)),
            "experiment": ("bin", np.concatenate([[e["name"]] * len(e["freqs"]) for e in exps])),
            "frequency": ("bin", np.concatenate([e["freqs"] for e in exps])),
        }
    return xr.Dataset(data, coords={"channel": channels, **coords})


def rj_log_likelihood(rj, liks, *, max_draws, max_values, per_experiment, groups):
    """The ``log_likelihood`` dataset of the reversible-jump chain ``rj``: each kept draw's
    pointwise ln L under the model it is in (``liks``: model name → its ``Likelihood``), so that
    ``az.loo`` gives the model-averaged posterior's leave-one-out predictive."""
    first = liks[rj.model_names[0]]
    exps = first.experiments
    for name, lik in liks.items():
        same = [e["name"] for e in lik.experiments] == [e["name"] for e in exps] and all(
            np.array_equal(a["freqs"], b["freqs"]) for a, b in zip(lik.experiments, exps)
        )
        if not same:
            raise ValueError(
                f"model `{name}` sees other frequency bins than `{rj.model_names[0]}`: no "
                "model-averaged log_likelihood (pass a model name to to_arviz)"
            )
    n_chains, n_draws = rj.model_index.shape
    keep = kept_draws(n_chains, n_draws, first.n_bins, max_draws, max_values)
    index = rj.model_index[:, keep].reshape(-1)
    samples = rj.samples[:, keep].reshape(len(index), -1)
    per = {e["name"]: np.full((len(index), len(e["freqs"])), np.nan) for e in exps}
    for k, name in enumerate(rj.model_names):
        rows = index == k
        if not rows.any():
            continue
        lik = liks[name]
        cols = [rj.param_names.index(p) for p in lik.param_names]
        for e, v in lik.ln_likelihood_per_bin(samples[rows][:, cols]).items():
            per[e][rows] = v
    return log_likelihood_group(
        per, exps, n_chains, keep, per_experiment=per_experiment, groups=groups
    )
