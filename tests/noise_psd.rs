//! The synthesised LTP output noise has the exact two-channel CSD S_o(f) of the noise model:
//! a Welch estimate of a long stretch matches S11, S22, Re S12 and Im S12.

use occam::config::Study;
use occam::experiment::stream;
use occam::signal::{SynthMode, WelchConfig, Window, synth_two_channel, welch_csd2};
use std::path::Path;

/// Statistical error of a Welch estimate with `m` effective averages of a Gaussian process
/// (Bendat & Piersol; Percival & Walden §7): Var Ŝ11 = S11²/m, Var Ŝ22 = S22²/m and, for the
/// cross term, Var Re Ŝ12 = (S11 S22 + Re S12²)/(2m), Var Im Ŝ12 = (S11 S22 − Re S12²)/(2m)
/// (S12² the complex square). BH92 bins four apart are uncorrelated (main lobe ±2 bins), so
/// the normalised deviations over K such bins have mean 0 ± 1/√K and mean square 1 ± √(2/K).
/// We allow 4 standard errors on each.
#[test]
fn welch_estimate_of_synthesised_noise_matches_the_model_csd() {
    let study = Study::from_toml(
        "seed = 1\noutput = \"x\"\n[[experiment]]\nname = \"a\"\ndesign = \"tn3045_x1\"\n",
        "t.toml",
        Path::new("."),
    )
    .unwrap();
    let sys = study.system();
    let fs = 10.0;
    let n = 1 << 21;
    let mut rng = stream(77, 0);
    let [y1, y2] =
        synth_two_channel(n, fs, |f| sys.noise_csd(f), &mut rng, SynthMode::Circular).unwrap();
    let seg = 1 << 14;
    let cfg = WelchConfig::new(fs, Window::Bh92, seg);
    let est = welch_csd2(&y1, &y2, &cfg).unwrap();
    let m = est.n_eff;
    let mut devs: [Vec<f64>; 4] = Default::default();
    for k in (8..seg / 2 - 1).step_by(4) {
        let f = est.freqs[k];
        let s = sys.noise_csd(f);
        let (s11, s22, s12) = (s[0][0].re, s[1][1].re, s[0][1]);
        let sq = (s12 * s12).re;
        let sd = [
            s11 / m.sqrt(),
            s22 / m.sqrt(),
            ((s11 * s22 + sq) / (2.0 * m)).sqrt(),
            ((s11 * s22 - sq) / (2.0 * m)).sqrt(),
        ];
        let d = [
            est.s11[k] - s11,
            est.s22[k] - s22,
            est.s12[k].re - s12.re,
            est.s12[k].im - s12.im,
        ];
        for i in 0..4 {
            devs[i].push(d[i] / sd[i]);
        }
    }
    let names = ["S11", "S22", "Re S12", "Im S12"];
    for (name, d) in names.iter().zip(&devs) {
        let k = d.len() as f64;
        let mean = d.iter().sum::<f64>() / k;
        let ms = d.iter().map(|x| x * x).sum::<f64>() / k;
        assert!(
            mean.abs() < 4.0 / k.sqrt(),
            "{name}: mean deviation {mean} over {k} bins"
        );
        assert!(
            (ms - 1.0).abs() < 4.0 * (2.0 / k).sqrt(),
            "{name}: mean square deviation {ms} over {k} bins"
        );
        eprintln!(
            "{name}: K = {k}, mean {mean:+.3} (se {:.3}), mean square {ms:.3} (se {:.3})",
            1.0 / k.sqrt(),
            (2.0 / k).sqrt()
        );
    }
}
