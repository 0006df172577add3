//! Exports the exact likelihood of a study's `[[select.model]]` comparison for the nested-sampling
//! peers (bench/peer/nested_peers.py), so that dynesty and nautilus sample exactly the `ln L`
//! that `occam select` samples, on the same simulated data, with the same uniform prior boxes.
//!
//!     cargo run --release --example peer_inputs -- STUDY.toml OUT_PREFIX
//!
//! writes `OUT_PREFIX.npz` (the in-band spectra of every experiment in the layout that
//! bench/peer/numpy_lnl.py reads, the masses, and the Rust `ln L` at check points spread over
//! the prior box) and `OUT_PREFIX.json` (the models: names, free parameters, fixed values; the
//! prior boxes; the study). It refuses studies the numpy peer cannot reproduce: a user-defined
//! or non-default built-in model, non-uniform priors, or models built on different `[[model]]`s.

#[path = "../bench/peer/peer_npz.rs"]
mod peer_npz;

use ndarray::Array1;
use ndarray_npy::NpzWriter;
use occam::config::{ModelDef, Study};
use occam::jobs::prepare::{likelihood_of, load_data};
use occam::ltp::{N_PARAMS, PARAM_NAMES};
use occam::model::{LoopResponse, ThrusterResponse};
use occam::prior::PriorKind;
use rand::{RngExt, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use std::path::{Path, PathBuf};

/// Check points drawn uniformly from each model's prior box (besides the truth).
const N_RANDOM_CHECKS: usize = 6;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() != 2 {
        eprintln!("usage: peer_inputs STUDY.toml OUT_PREFIX  (writes OUT_PREFIX.npz and .json)");
        std::process::exit(2);
    }
    if let Err(e) = run(Path::new(&args[0]), Path::new(&args[1])) {
        eprintln!("peer_inputs: {e}");
        std::process::exit(1);
    }
}

fn run(study_path: &Path, prefix: &Path) -> Result<(), Box<dyn std::error::Error>> {
    let study = Study::load(study_path)?;
    if study.select_models.len() < 2 {
        return Err(format!(
            "{}: needs at least two [[select.model]] tables to compare",
            study_path.display()
        )
        .into());
    }
    let mi = study.select_models[0].spec.model;
    if study.select_models.iter().any(|m| m.spec.model != mi) {
        return Err(
            "the [[select.model]] models must all be sub-models of one [[model]] \
                    (the numpy peer implements one likelihood)"
                .into(),
        );
    }
    let masses = match &study.models.defs[mi] {
        ModelDef::Ltp { options, .. }
            if options.thruster == ThrusterResponse::None
                && options.response == LoopResponse::Continuous =>
        {
            options.masses
        }
        _ => {
            return Err(
                "the numpy peer implements the built-in continuous closed loop \
                        without thruster response only (kind = \"ltp\", thruster = \"none\", \
                        response = \"continuous\")"
                    .into(),
            );
        }
    };
    let prior = &study.models.priors[mi];
    let mut lo = [0.0; N_PARAMS];
    let mut hi = [0.0; N_PARAMS];
    for (i, k) in prior.kinds().iter().enumerate() {
        match *k {
            PriorKind::Uniform { lo: a, hi: b } => {
                lo[i] = a;
                hi[i] = b;
            }
            _ => {
                return Err(format!(
                    "prior of `{}` is not a uniform box; the peers' prior transform \
                     supports uniform boxes only",
                    PARAM_NAMES[i]
                )
                .into());
            }
        }
    }
    let (dataset, origin) = load_data(&study)?;
    let lik = likelihood_of(&study, mi, &dataset)?;
    let spectra = lik.spectra();
    if spectra.iter().any(|e| e.consts.len() != 5 * e.len()) {
        return Err("unexpected layout of the LTP model's per-bin constants".into());
    }

    // check points: each model's base with the truth in its free parameters, then uniform
    // draws from each model's box (fixed parameters at their values)
    let truth = study.truth.to_array();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(study.seed ^ 0x9e37_79b9);
    let mut checks: Vec<[f64; N_PARAMS]> = Vec::new();
    for m in &study.select_models {
        let mut th = [0.0; N_PARAMS];
        th.copy_from_slice(&m.spec.base);
        for &i in &m.spec.free {
            th[i] = truth[i];
        }
        checks.push(th);
        for _ in 0..N_RANDOM_CHECKS / study.select_models.len() {
            let mut t = th;
            for &i in &m.spec.free {
                t[i] = lo[i] + (hi[i] - lo[i]) * rng.random::<f64>();
            }
            checks.push(t);
        }
    }

    let npz_path = prefix.with_extension("npz");
    let mut z = NpzWriter::new(std::fs::File::create(&npz_path)?);
    peer_npz::write_peer_inputs(&mut z, &lik, &masses, &truth, &checks)?;
    z.add_array("prior_lo", &Array1::from_vec(lo.to_vec()))?;
    z.add_array("prior_hi", &Array1::from_vec(hi.to_vec()))?;
    z.finish()?;

    let models: Vec<_> = study
        .select_models
        .iter()
        .map(|m| {
            serde_json::json!({
                "name": m.name,
                "free": m.spec.free,
                "base": m.spec.base,
            })
        })
        .collect();
    let snr = lik.snr(&truth);
    let meta = serde_json::json!({
        "study": study_path.display().to_string(),
        "origin": origin,
        "param_names": PARAM_NAMES,
        "prior_lo": lo,
        "prior_hi": hi,
        "models": models,
        "n_bins": lik.n_bins(),
        "rho_opt_at_truth": snr,
    });
    let json_path: PathBuf = prefix.with_extension("json");
    std::fs::write(&json_path, serde_json::to_string_pretty(&meta)?)?;
    println!(
        "wrote {} and {} ({} bins, rho_opt {:.1} at the truth, {} check points)",
        npz_path.display(),
        json_path.display(),
        lik.n_bins(),
        snr,
        checks.len()
    );
    Ok(())
}
