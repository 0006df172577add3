//! Where the information on each parameter comes from: the Fisher matrix split by experiment,
//! by injection segment and by frequency decade ([`Information`]).
//!
//! Two numbers per part and parameter, because the parameters are correlated and neither
//! alone says what a part is worth:
//! - the **share** of the parameter's diagonal information `F_aa` that the part's bins carry
//!   (the shares of a split add up to 1): what the part measures with the others held fixed;
//! - **σ without**: the Cramér–Rao σ when the part is left out, over the σ with everything
//!   (`∞` when the rest cannot constrain every parameter): what the part adds once the
//!   correlations are paid for.
//!
//! A segment is the half-octave around one injected frequency (`f_line/√2 ≤ f < f_line·√2`,
//! the nearest line when two overlap): in the frequency domain a finite sine's information
//! sits at its frequency and a few `1/T` around it, and the ladder doubles its frequency from
//! one segment to the next. Bins near no line are the part "elsewhere".

use super::exact::Likelihood;
use super::fisher::{cramer_rao, fisher_parts};
use nalgebra::DMatrix;
use serde::Serialize;

/// One part of a split of the Fisher matrix.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct InfoPart {
    /// What the part holds, e.g. `inv1 x1 3.33e-3 Hz` or `1e-3–1e-2 Hz`.
    pub name: String,
    /// Per parameter: the part's share of the diagonal information `F_aa`.
    pub share: Vec<f64>,
    /// Per parameter: the Cramér–Rao σ without the part over the σ with it (`∞` when the
    /// rest leaves a parameter unconstrained).
    pub sigma_without: Vec<f64>,
}

/// A split: its name (`experiment`, `segment`, `decade`) and parts.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Split {
    pub by: String,
    pub parts: Vec<InfoPart>,
}

/// The Fisher information of a set of parameters at a point, split three ways (module docs).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Information {
    /// The free parameters.
    pub params: Vec<String>,
    /// Their Cramér–Rao σ with everything.
    pub sigma: Vec<f64>,
    /// By experiment, by segment and by decade.
    pub splits: Vec<Split>,
    /// Per frequency `f` (Hz, rising): per parameter, the share of its diagonal information
    /// from bins below `f`.
    pub cumulative: Vec<(f64, Vec<f64>)>,
}

/// An injected line of an experiment: its label and frequency (Hz).
pub type Line = (String, f64);

/// Upper edges of the cumulative curve, per decade.
const CUMULATIVE_PER_DECADE: usize = 20;

impl Information {
    /// The information on `free` (names `names`, of the full vector) at `th`; `lines[e]`
    /// holds experiment `e`'s injected lines. `None` when the whole Fisher matrix is
    /// singular.
    pub fn of(
        lik: &Likelihood,
        th: &[f64],
        free: &[usize],
        names: &[String],
        lines: &[Vec<Line>],
    ) -> Option<Self> {
        let sp = lik.spectra();
        let d = free.len();
        let sum = |ps: &[DMatrix<f64>]| ps.iter().fold(DMatrix::zeros(d, d), |acc, p| acc + p);
        // three passes over the bins: by experiment (whose sum is the whole), by segment and
        // on a fine log grid (whose blocks of CUMULATIVE_PER_DECADE are the decades)
        let by_exp = fisher_parts(lik, th, free, sp.len(), |e, _| Some(e));
        let total = sum(&by_exp);
        let sigma = cramer_rao(&total)?;
        let split = |by: &str, labels: Vec<String>, parts: &[DMatrix<f64>]| Split {
            by: by.into(),
            parts: labels
                .into_iter()
                .enumerate()
                .map(|(i, name)| part(name, i, parts, &total, &sigma))
                .collect(),
        };
        let by_experiment = split(
            "experiment",
            sp.iter().map(|e| e.name.clone()).collect(),
            &by_exp,
        );
        // segments: every experiment's lines, then "elsewhere"
        let mut seg_labels: Vec<String> = Vec::new();
        let mut first: Vec<usize> = Vec::new();
        for (e, l) in lines.iter().enumerate().take(sp.len()) {
            first.push(seg_labels.len());
            seg_labels.extend(
                l.iter()
                    .map(|(n, f)| format!("{} {n} {f:.3e} Hz", sp[e].name)),
            );
        }
        let elsewhere = seg_labels.len();
        seg_labels.push("elsewhere".into());
        let seg_parts = fisher_parts(lik, th, free, seg_labels.len(), |e, f| {
            let near = lines
                .get(e)
                .into_iter()
                .flatten()
                .enumerate()
                .map(|(j, (_, fl))| (j, (f / fl).ln().abs()))
                .filter(|(_, d)| *d < std::f64::consts::LN_2 / 2.0)
                .min_by(|a, b| a.1.total_cmp(&b.1));
            Some(near.map_or(elsewhere, |(j, _)| first[e] + j))
        });
        let by_segment = split("segment", seg_labels, &seg_parts);
        let (lo, hi) = band_of(lik);
        let d0 = lo.log10().floor() as i32;
        let d1 = (hi.log10().ceil() as i32).max(d0 + 1);
        let per = CUMULATIVE_PER_DECADE;
        let n = (d1 - d0) as usize * per;
        // the top edge (f = 1 Hz on a band to 1 Hz) belongs to the last bin
        let fine = fisher_parts(lik, th, free, n, |_, f| {
            let i = ((f.log10() - d0 as f64) * per as f64).floor().max(0.0);
            Some((i as usize).min(n - 1))
        });
        let decades: Vec<String> = (d0..d1).map(|d| format!("1e{d}–1e{} Hz", d + 1)).collect();
        let dec_parts: Vec<DMatrix<f64>> = fine.chunks(per).map(sum).collect();
        let by_decade = split("decade", decades, &dec_parts);
        let edge = |i: usize| 10f64.powf(d0 as f64 + (i + 1) as f64 / per as f64);
        let mut acc = vec![0.0; d];
        let cumulative = fine
            .iter()
            .enumerate()
            .map(|(i, p)| {
                for (a, v) in acc.iter_mut().enumerate() {
                    *v += p[(a, a)];
                }
                let s = (0..d).map(|a| acc[a] / total[(a, a)]).collect();
                (edge(i), s)
            })
            .collect();
        Some(Information {
            params: free.iter().map(|&i| names[i].clone()).collect(),
            sigma,
            splits: vec![by_experiment, by_segment, by_decade],
            cumulative,
        })
    }

    /// The splits as Markdown tables: per part, each parameter's share in % and, in
    /// brackets, σ without the part over σ.
    pub fn markdown(&self) -> String {
        let mut s = String::new();
        s.push_str("| parameter | σ (Cramér–Rao) |\n| --- | --- |\n");
        for (p, v) in self.params.iter().zip(&self.sigma) {
            s.push_str(&format!(
                "| {p} | {} |\n",
                crate::numfmt::fmt_short_sig(*v, 3)
            ));
        }
        for sp in &self.splits {
            s.push_str(&format!(
                "\nBy {}: share of each parameter's diagonal information, % (σ without the part ÷ σ)\n\n| {} | {} |\n|{}\n",
                sp.by,
                sp.by,
                self.params.join(" | "),
                " --- |".repeat(self.params.len() + 1)
            ));
            for p in &sp.parts {
                let cells: Vec<String> = p
                    .share
                    .iter()
                    .zip(&p.sigma_without)
                    .map(|(sh, w)| {
                        let w = if w.is_finite() {
                            format!("{w:.2}")
                        } else {
                            "∞".into()
                        };
                        format!("{:.1} ({w})", 100.0 * sh)
                    })
                    .collect();
                s.push_str(&format!("| {} | {} |\n", p.name, cells.join(" | ")));
            }
        }
        s
    }
}

/// Part `i` of `parts` (which together hold every bin of `total`).
fn part(
    name: String,
    i: usize,
    parts: &[DMatrix<f64>],
    total: &DMatrix<f64>,
    sigma: &[f64],
) -> InfoPart {
    let d = sigma.len();
    let p = &parts[i];
    // the others summed, not the total less this part: no cancellation
    let others = parts
        .iter()
        .enumerate()
        .filter(|(j, _)| *j != i)
        .fold(DMatrix::zeros(d, d), |acc, (_, q)| acc + q);
    let rest = cramer_rao(&others);
    InfoPart {
        name,
        share: (0..d).map(|a| p[(a, a)] / total[(a, a)]).collect(),
        sigma_without: (0..d)
            .map(|a| match &rest {
                Some(r) if r[a].is_finite() => r[a] / sigma[a],
                _ => f64::INFINITY,
            })
            .collect(),
    }
}

/// The lowest and highest in-band frequency of any experiment.
fn band_of(lik: &Likelihood) -> (f64, f64) {
    lik.spectra()
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), e| {
            (
                lo.min(e.freqs[0]),
                hi.max(*e.freqs.last().expect("an experiment has in-band bins")),
            )
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::likelihood::fisher_exact;
    use crate::likelihood::tests::{likelihood_of, small_study};
    use crate::likelihood::{NoiseSource, SpectraOptions};

    fn info() -> (Information, Likelihood) {
        let study = small_study(5, 1e-6, "none");
        let opts = SpectraOptions {
            noise: NoiseSource::Model,
            band: [1e-3, 0.3],
            ..Default::default()
        };
        let lik = likelihood_of(&study, &opts);
        let names = crate::density::LogDensity::param_names(&lik).to_vec();
        let lines = vec![
            vec![
                ("x1".to_string(), 0.002),
                ("x1".to_string(), 0.02),
                ("x1".to_string(), 0.1),
            ],
            vec![("x12".to_string(), 0.002), ("x12".to_string(), 0.02)],
        ];
        let free: Vec<usize> = (0..7).collect();
        let i = Information::of(&lik, &study.truth.to_array(), &free, &names, &lines).unwrap();
        (i, lik)
    }

    #[test]
    fn shares_add_up_and_follow_the_injections() {
        let (i, lik) = info();
        let th = small_study(5, 1e-6, "none").truth.to_array();
        let total = fisher_exact(&lik, &th, &(0..7).collect::<Vec<_>>());
        // σ with everything is the Cramér–Rao bound (the whole summed by experiment)
        let cr = crate::likelihood::cramer_rao(&total).unwrap();
        for (s, c) in i.sigma.iter().zip(&cr) {
            assert!((s / c - 1.0).abs() < 1e-12, "{s} vs {c}");
        }
        for sp in &i.splits {
            for a in 0..7 {
                let sum: f64 = sp.parts.iter().map(|p| p.share[a]).sum();
                assert!((sum - 1.0).abs() < 1e-12, "{}: {sum}", sp.by);
                // leaving a part out never shrinks a bound
                assert!(sp.parts.iter().all(|p| p.sigma_without[a] >= 1.0 - 1e-9));
            }
        }
        let names: Vec<&str> = i.splits[1].parts.iter().map(|p| p.name.as_str()).collect();
        assert_eq!(names.len(), 6, "{names:?}");
        assert_eq!(names[3], "b x12 2.000e-3 Hz");
        assert_eq!(names[5], "elsewhere");
        // a_sus (index 5) is measured by the x12 injection: experiment b holds nearly all of
        // it, and without b the bound grows many-fold
        let (a, b) = (&i.splits[0].parts[0], &i.splits[0].parts[1]);
        assert!(a.share[5] < 1e-3 && b.share[5] > 0.999, "{a:?} {b:?}");
        assert!(b.sigma_without[5] > 10.0, "{b:?}");
        // the 0.1 Hz segment is x1's only line above 0.05 Hz and carries part of dt1 (index 2)
        let top = &i.splits[1].parts[2];
        assert!(top.share[2] > 0.05, "{:?}", top.share);
        assert!(top.share[5] < 1e-3, "{:?}", top.share);
    }

    #[test]
    fn without_known_lines_every_bin_is_elsewhere() {
        // loaded data: no injected lines are known, the segment split is one part
        let (_, lik) = info();
        let th = small_study(5, 1e-6, "none").truth.to_array();
        let names = crate::density::LogDensity::param_names(&lik).to_vec();
        let free: Vec<usize> = (0..7).collect();
        let i = Information::of(&lik, &th, &free, &names, &[]).unwrap();
        let seg = &i.splits[1].parts;
        assert_eq!(seg.len(), 1);
        assert_eq!(seg[0].name, "elsewhere");
        assert!(seg[0].share.iter().all(|s| (s - 1.0).abs() < 1e-12));
        assert!(seg[0].sigma_without.iter().all(|w| w.is_infinite()));
    }

    #[test]
    fn the_cumulative_share_rises_to_one() {
        let (i, _) = info();
        let c = &i.cumulative;
        assert!(c.windows(2).all(|w| w[0].0 < w[1].0));
        for a in 0..7 {
            assert!(c.windows(2).all(|w| w[1].1[a] >= w[0].1[a] - 1e-15));
            assert!((c.last().unwrap().1[a] - 1.0).abs() < 1e-12);
        }
        // nothing below the band's lower edge (1 mHz)
        assert!(
            c.iter()
                .filter(|(f, _)| *f <= 1e-3)
                .all(|(_, s)| s[0] == 0.0)
        );
    }
}
