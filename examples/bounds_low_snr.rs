//! The MAP search and relative binning of the guidance-delay study at low SNR, where the
//! posterior fills its prior box (issue 12): per model, the bounded MAP (which parameters sit
//! on a bound), the unbounded search (its maximum or why it does not exist) and the measured
//! relative-binning error over the box.
//!
//!   cargo run --release --example bounds_low_snr -- 5 60

use occam::config::Study;
use occam::jobs::prepare::{default_start, likelihood_of, load_data, relbin_of};
use occam::likelihood::{fisher_scoring, fisher_scoring_unbounded};
use std::path::Path;

fn main() {
    let text =
        std::fs::read_to_string("examples/guidance-delays.toml").expect("run from the crate root");
    let snrs: Vec<f64> = std::env::args()
        .skip(1)
        .map(|a| a.parse().expect("a number"))
        .collect();
    for snr in if snrs.is_empty() {
        vec![5.0, 60.0]
    } else {
        snrs
    } {
        let t = text.replace("target_snr = 450.0", &format!("target_snr = {snr}"));
        let study = Study::from_toml(&t, "guidance-delays.toml", Path::new("examples")).unwrap();
        let (data, _) = load_data(&study).unwrap();
        println!("== target_snr = {snr}");
        for m in &study.select_models {
            let spec = &m.spec;
            let exact = likelihood_of(&study, spec.model, &data).unwrap();
            let names = exact.model().param_names().to_vec();
            let t0 = std::time::Instant::now();
            let map = fisher_scoring(&exact, &default_start(&study, spec), &spec.free, 1e-3, 200)
                .unwrap();
            println!(
                "{}: bounded MAP converged {} in {} iterations ({:.2} s), ln post {:.4}, on bounds {:?}",
                m.name,
                map.converged,
                map.iterations,
                t0.elapsed().as_secs_f64(),
                map.ln_posterior,
                map.bound_names(&names, &spec.free)
            );
            match fisher_scoring_unbounded(&exact, &map.theta, &spec.free, 1e-3, 200) {
                Ok(u) => println!(
                    "{}: unbounded maximum {:?}",
                    m.name,
                    spec.free
                        .iter()
                        .map(|&i| (names[i].as_str(), u.theta[i]))
                        .collect::<Vec<_>>()
                ),
                Err(e) => println!("{}: unbounded: {e}", m.name),
            }
            let t0 = std::time::Instant::now();
            match relbin_of(&study, &exact, &map.theta) {
                Ok(rb) => println!(
                    "{}: relbin {} coarse bins ({:.2} s), validation {}",
                    m.name,
                    rb.n_coarse(),
                    t0.elapsed().as_secs_f64(),
                    serde_json::to_string(rb.validation()).unwrap()
                ),
                Err(e) => println!("{}: relbin: {e}", m.name),
            }
        }
    }
}
