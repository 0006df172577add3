//! The commanded injections of an experiment read from a file, filled in through its gaps.
//!
//! Telemetry gaps drop every channel, the injections' read-back included; the loop's response
//! to what an injection did inside a gap rings into the next valid run, and the gaps' edge
//! correction can only remove it where the injection is known there (docs: "Real data: gaps").
//! When the study gives the experiment's design beside its data file, the design *is* what was
//! commanded: after checking that it agrees with the file wherever the file has the channel,
//! its values replace the missing ones.

use super::design::ExperimentDesign;
use crate::data::dataset::ExperimentData;
use crate::data::gaps;

/// Largest difference between the design and the file's injection, relative to the
/// injection's largest |value|, that still counts as agreement: a design one sample off
/// (10 Hz) differs by ≥ 6e−4 at the lowest ladder frequency (1 mHz), single-precision
/// telemetry by ≤ 1e−7.
pub const AGREEMENT: f64 = 1e-4;

/// Fills `e`'s missing injection samples from `design` and returns the channels it filled.
///
/// Every injection channel of the design that the experiment has (`i1`, `i12`, and the force
/// and `inject` channels it drives) must agree with the file outside the gaps to
/// [`AGREEMENT`] of its amplitude, and span the file's fit stretch; a guidance channel the
/// design leaves quiet must be zero in the file. A channel the file already gives through its
/// gaps is only checked. Errors name the channel and what to change.
///
/// ```
/// use occam::data::dataset::ExperimentData;
/// use occam::experiment::{ExperimentDesign, fill_commanded};
///
/// let d = ExperimentDesign::builtin("tn3045_x1").unwrap();
/// let [i1, i12] = d.injections();
/// let n = i1.len();
/// let mut e = ExperimentData::new("inv1", d.fs, [vec![0.0; n], vec![0.0; n]], [i1.clone(), i12],
///     [Vec::new(), Vec::new()]);
/// e.add_gaps(&[[3000, 4000]]);                  // a telemetry gap: i1 blanked there too
/// assert_eq!(e.i[0][3500], 0.0);
/// assert_eq!(fill_commanded(&mut e, &d).unwrap(), vec!["i1".to_string()]);
/// assert_eq!(e.i[0][3500], i1[3500]);
/// assert!(e.known_in_gaps.contains(&"i1".to_string()));
/// ```
pub fn fill_commanded(
    e: &mut ExperimentData,
    design: &ExperimentDesign,
) -> Result<Vec<String>, String> {
    if (design.fs - e.fs).abs() > 1e-9 * e.fs {
        return Err(format!(
            "the design runs at fs = {} Hz but the file at {} Hz: give the data's rate as the experiment's `fs`",
            design.fs, e.fs
        ));
    }
    let n = e.n_samples();
    // checked before anything is rendered: a design's length is the study's to choose
    // (`pre_pad = 1e12`), the file's is not
    if design.n_samples_f64() != n as f64 {
        return Err(format!(
            "the design spans {} samples (pre_pad {} s, the injections, post_pad {} s at {} Hz) but the file's fit stretch has {n}: set `pre_pad` / `post_pad` so that the design lines up with the file from its first sample",
            design.n_samples_f64(),
            design.pre_pad,
            design.post_pad,
            design.fs
        ));
    }
    // the driven channels, then the guidance channels the design leaves quiet (zero)
    let mut series: Vec<(String, Vec<f64>, bool)> = design
        .channel_injections()
        .into_iter()
        .map(|(c, v)| (c, v, true))
        .collect();
    for c in ["i1", "i12"] {
        if !series.iter().any(|(s, ..)| s == c) {
            series.push((c.into(), vec![0.0; n], false));
        }
    }
    let mut filled = Vec::new();
    for (c, want, driven) in series {
        let Some(have) = e.channel(&c) else {
            continue;
        };
        let known = e.known_in_gaps.contains(&c) || e.gaps.is_empty();
        // compared outside the gaps only, where the file has the channel
        let mut outside = want.clone();
        if !known {
            gaps::blank(&mut outside, &e.gaps);
        }
        let scale = want.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        let (worst, at) = have
            .iter()
            .zip(&outside)
            .map(|(h, w)| (h - w).abs())
            .enumerate()
            .fold((0.0_f64, 0), |a, (k, d)| if d > a.0 { (d, k) } else { a });
        if worst > AGREEMENT * scale.max(f64::MIN_POSITIVE) {
            return Err(format!(
                "the file's `{c}` differs from the design's commanded injection by {worst:.3e} at t = {:.1} s (its amplitude is {scale:.3e}): the design is not what was commanded, or it is shifted — check `design`, `x1`/`x12`/…, `pre_pad` and the file's first sample, or remove the design",
                at as f64 / e.fs
            ));
        }
        if known || !driven {
            continue;
        }
        let mut v = have.to_vec();
        for g in &e.gaps {
            v[g[0]..g[1]].copy_from_slice(&want[g[0]..g[1]]);
        }
        e.set_channel(&c, v);
        e.known_in_gaps.push(c.clone());
        filled.push(c);
    }
    Ok(filled)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn experiment(d: &ExperimentDesign) -> (ExperimentData, Vec<f64>) {
        let [i1, i12] = d.injections();
        let n = i1.len();
        let e = ExperimentData::new(
            "inv1",
            d.fs,
            [vec![1.0; n], vec![1.0; n]],
            [i1.clone(), i12],
            [Vec::new(), Vec::new()],
        );
        (e, i1)
    }

    #[test]
    fn blanked_injection_is_filled_and_a_quiet_channel_left_alone() {
        let d = ExperimentDesign::builtin("tn3045_x1").unwrap();
        let (mut e, i1) = experiment(&d);
        e.add_gaps(&[[20_000, 20_500], [40_000, 41_000]]);
        assert!(e.i[0][20_100] == 0.0 && i1[20_100] != 0.0);
        let filled = fill_commanded(&mut e, &d).unwrap();
        assert_eq!(filled, ["i1"]);
        assert_eq!(e.i[0], i1, "every sample the design's");
        assert_eq!(e.o[0][20_100], 0.0, "read-outs stay blanked");
        // i12: not driven by this design, zero in the file, so nothing to fill
        assert!(!e.known_in_gaps.contains(&"i12".to_string()));
        // a second call finds nothing left to fill
        assert!(fill_commanded(&mut e, &d).unwrap().is_empty());
    }

    #[test]
    fn a_design_that_is_not_the_files_is_refused() {
        let d = ExperimentDesign::builtin("tn3045_x1").unwrap();
        // shifted by one sample
        let (mut e, i1) = experiment(&d);
        let mut shifted = vec![0.0];
        shifted.extend_from_slice(&i1[..i1.len() - 1]);
        e.set_channel("i1", shifted);
        e.add_gaps(&[[20_000, 20_500]]);
        let err = fill_commanded(&mut e, &d).unwrap_err();
        assert!(
            err.contains("`i1` differs") && err.contains("pre_pad"),
            "{err}"
        );
        // the other guidance channel driven in the file but quiet in the design
        let (mut e, i1) = experiment(&d);
        e.set_channel("i12", i1);
        let err = fill_commanded(&mut e, &d).unwrap_err();
        assert!(err.contains("`i12` differs"), "{err}");
        // too short a file
        let (mut e, _) = experiment(&d);
        let n = e.n_samples() - 10;
        for c in ["o1", "o12", "i1", "i12"] {
            let v = e.channel(c).unwrap()[..n].to_vec();
            e.set_channel(c, v);
        }
        let err = fill_commanded(&mut e, &d).unwrap_err();
        assert!(err.contains("spans") && err.contains("post_pad"), "{err}");
        // a design far longer than any file is refused before it is rendered
        let (mut e, _) = experiment(&d);
        let huge = ExperimentDesign {
            pre_pad: 1e12,
            ..d.clone()
        };
        let err = fill_commanded(&mut e, &huge).unwrap_err();
        assert!(
            err.contains("spans 1000000") && err.contains("pre_pad 1000000000000 s"),
            "{err}"
        );
        // another rate
        let (mut e, _) = experiment(&d);
        e.fs = 2.0 * d.fs;
        assert!(fill_commanded(&mut e, &d).unwrap_err().contains("fs"));
    }

    #[test]
    fn single_precision_telemetry_agrees() {
        let d = ExperimentDesign::builtin("tn3045_x1").unwrap();
        let (mut e, i1) = experiment(&d);
        e.set_channel("i1", i1.iter().map(|v| f64::from(*v as f32)).collect());
        e.add_gaps(&[[20_000, 20_500]]);
        assert_eq!(fill_commanded(&mut e, &d).unwrap(), ["i1"]);
    }
}
