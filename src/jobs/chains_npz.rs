//! A run's Metropolis–Hastings chains as the arrays of a `chains.npz` (written by `fit` and,
//! per model, by `select`).

use crate::sampler::Chains;

/// The arrays of a `chains.npz`: `samples` (chains × kept × parameters), `ln_posterior` and
/// `ln_likelihood` (chains × kept), `param_names` (parameters; the order of the last axis of
/// `samples`) and `accepted` (chains × kept: a proposal was accepted since the previous kept
/// draw — with `thin` = 1 exactly this draw's proposal, with thinning "the state moved").
pub fn chains_arrays(chains: &Chains) -> Vec<crate::data::npz_write::NpyArray> {
    use crate::data::npz_write::{NpyArray, NpyData};
    let (m, n, d) = (chains.chains().len(), chains.n_kept(), chains.dim());
    let cat = |f: &dyn Fn(&crate::sampler::Chain) -> &[f64]| -> Vec<f64> {
        chains
            .chains()
            .iter()
            .flat_map(|c| f(c).iter().copied())
            .collect()
    };
    vec![
        NpyArray::new("samples", &[m, n, d], NpyData::F64(cat(&|c| &c.samples))),
        NpyArray::new(
            "ln_posterior",
            &[m, n],
            NpyData::F64(cat(&|c| &c.ln_posterior)),
        ),
        NpyArray::new(
            "ln_likelihood",
            &[m, n],
            NpyData::F64(cat(&|c| &c.ln_likelihood)),
        ),
        NpyArray::new("param_names", &[d], NpyData::Str(chains.names().to_vec())),
        NpyArray::new(
            "accepted",
            &[m, n],
            NpyData::Bool(
                chains
                    .chains()
                    .iter()
                    .flat_map(|c| c.accepted.iter().copied())
                    .collect(),
            ),
        ),
    ]
}
