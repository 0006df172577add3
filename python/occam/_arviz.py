"""The ArviZ groups beyond the chains: ``log_likelihood`` (pointwise ln L per frequency bin at
thinned posterior draws), ``prior`` (draws from the prior) and ``observed_data`` (the data's
|DFT| per bin). The numbers come from ``occam.Likelihood``; this module only arranges them."""

import math

import numpy as np

# the one variable of the default layout: the observations are the data's DFT bins
SPECTRUM = "spectrum"


def kept_draws(n_chains, n_draws, n_bins, max_draws, max_values):
    """Indices of the draws kept per chain: evenly thinned so that at most ``max_draws`` draws
    over all chains and ``max_values`` pointwise values (draws × bins) are stored."""
    if max_draws < 1 or max_values < 1:
        raise ValueError(f"max_draws and max_values must be ≥ 1; got {max_draws}, {max_values}")
    cap = max(1, min(max_draws, max_values // max(n_bins, 1)))
    per_chain = max(1, cap // max(n_chains, 1))
    step = max(1, math.ceil(n_draws / per_chain))
    return np.arange(0, n_draws, step)


def inference_data(idata, chains, lik, *, log_likelihood, prior, observed_data, per_experiment,
                   max_draws, max_values, prior_draws):
    """``idata`` (posterior and sample_stats of ``chains``) with the groups asked for, from
    the likelihood ``lik`` of the chains' model."""
    import xarray as xr

    if lik.param_names != chains.param_names:
        raise ValueError(
            f"the likelihood's parameters {lik.param_names} are not the chains' "
            f"{chains.param_names}: pass the study the run was made from (study=...)"
        )
    exps = lik.experiments
    groups = {}
    if per_experiment:
        coords = {f"{e['name']}_bin": e["freqs"] for e in exps}
    else:
        coords = {
            "bin": np.arange(sum(len(e["freqs"]) for e in exps)),
            "experiment": ("bin", np.concatenate([[e["name"]] * len(e["freqs"]) for e in exps])),
            "frequency": ("bin", np.concatenate([e["freqs"] for e in exps])),
        }
    if log_likelihood:
        n_chains, n_draws, p = chains.samples.shape
        keep = kept_draws(n_chains, n_draws, lik.n_bins, max_draws, max_values)
        pts = chains.samples[:, keep].reshape(-1, p)
        per = lik.ln_likelihood_per_bin(pts)
        shape = lambda v: v.reshape(n_chains, len(keep), -1)  # noqa: E731
        if per_experiment:
            data = {n: (("chain", "draw", f"{n}_bin"), shape(v)) for n, v in per.items()}
        else:
            data = {
                SPECTRUM: (
                    ("chain", "draw", "bin"),
                    shape(np.concatenate([per[e["name"]] for e in exps], axis=1)),
                )
            }
        groups["log_likelihood"] = xr.Dataset(
            data, coords={"chain": np.arange(n_chains), "draw": keep, **coords}
        )
    if prior:
        # seeded: the same draws every call, as every number of occam
        u = np.random.default_rng(0x0CCA).uniform(size=(prior_draws, lik.ndim))
        x = lik.prior_transform(u)
        groups["prior"] = xr.Dataset(
            {n: (("chain", "draw"), x[None, :, k]) for k, n in enumerate(lik.param_names)},
            coords={"chain": [0], "draw": np.arange(prior_draws)},
        )
    if observed_data:
        channels = exps[0]["channels"]
        if per_experiment:
            data = {
                e["name"]: ((f"{e['name']}_bin", "channel"), e["data_abs"]) for e in exps
            }
        else:
            data = {
                SPECTRUM: (("bin", "channel"), np.concatenate([e["data_abs"] for e in exps]))
            }
        groups["observed_data"] = xr.Dataset(data, coords={"channel": channels, **coords})
    idata.add_groups(groups)
    return idata
