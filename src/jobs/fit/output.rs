//! The fit's outputs: Table I, the summary, chains on disk and plots.

use super::summary::{FitError, FitOutcome, FitSummary};
use crate::jobs::chains_npz::chains_arrays;
use crate::report::{Table, fmt_fixed, fmt_pm, fmt_short, fmt_sig};
use crate::sampler::Chains;
use std::path::Path;

/// R-hat for the table: 4 decimals, `∞ (stuck)` when it is infinite (zero within-chain
/// variance: the chains did not move; `sd` 0: not even between chains), `NaN` when it could
/// not be computed.
pub fn fmt_rhat(rhat: f64, sd: f64) -> String {
    if rhat == f64::INFINITY {
        if sd == 0.0 {
            "∞ (stuck, sd 0)".into()
        } else {
            "∞ (stuck)".into()
        }
    } else {
        fmt_fixed(rhat, 4)
    }
}

/// The Table I layout as a text table.
///
/// When the rows carry sandwich errors (the Fisher errors are not the estimate's, e.g. with a
/// Welch noise estimate; [`crate::likelihood::score_covariance_differs`]) a `sandwich σ` column
/// follows `σ/CR`.
pub fn table(s: &FitSummary) -> Table {
    let sandwich = s.rows.iter().any(|r| r.sandwich.is_some());
    let mut header = vec![
        "parameter",
        "unit",
        "truth",
        "MAP",
        "estimate ± σ",
        "Cramér-Rao σ",
        "σ/CR",
    ];
    if sandwich {
        header.push("sandwich σ");
    }
    header.extend(["R-hat", "ESS"]);
    let mut t = Table::new(header);
    for r in &s.rows {
        let mut row = vec![
            r.name.clone(),
            if r.unit.is_empty() {
                "–".into()
            } else {
                r.unit.clone()
            },
            r.truth.map_or("–".into(), |v| fmt_sig(v, 4)),
            fmt_sig(r.map, 6),
            fmt_pm(r.mean, r.sd),
            fmt_short(r.cramer_rao),
            fmt_fixed(r.sd / r.cramer_rao, 3),
        ];
        if sandwich {
            row.push(r.sandwich.map_or("–".into(), fmt_short));
        }
        row.extend([fmt_rhat(r.rhat, r.sd), fmt_fixed(r.ess, 0)]);
        t.push_row(row).expect("row width matches the header");
    }
    t
}

/// What a fit directory held before `manifest.json` existed: the files a new run removes when
/// it does not write them itself ([`crate::data::rundir::RunDir::publish`]).
pub const LEGACY_OUTPUTS: &[&str] = &[
    "summary.json",
    "table.txt",
    "table.md",
    "chains.npz",
    "trace.png",
    "trace.svg",
    "corner.png",
    "corner.svg",
    // `occam report` records its page in the manifest; in an older directory only this finds it
    "report.html",
];

/// Most parameters the trace and corner plots show (the first ones of the chains).
pub const MAX_PLOTTED: usize = 16;

/// Writes `summary.json`, `table.txt`, `table.md`, `chains.npz`, the trace and corner plots
/// (of the first `MAX_PLOTTED` parameters) and where the information comes from
/// (`information.md`, `.json`, `.png`, `.svg`) into `out`; every file atomically.
pub fn write_outputs(o: &FitOutcome, out: &Path) -> Result<(), FitError> {
    let io = |p: &Path, e: std::io::Error| FitError::Other(format!("{}: {e}", p.display()));
    std::fs::create_dir_all(out).map_err(|e| io(out, e))?;
    let json = serde_json::to_string_pretty(&o.summary).expect("summary serialises") + "\n";
    let p = out.join("summary.json");
    crate::atomic::write_bytes(&p, json.as_bytes()).map_err(|e| io(&p, e))?;
    let t = table(&o.summary);
    let p = out.join("table.txt");
    crate::atomic::write_bytes(&p, t.to_text().as_bytes()).map_err(|e| io(&p, e))?;
    let p = out.join("table.md");
    crate::atomic::write_bytes(&p, t.to_markdown().as_bytes()).map_err(|e| io(&p, e))?;
    write_chains_npz(&o.chains, &out.join("chains.npz"))?;
    // the plots show the first MAX_PLOTTED parameters: the model's own come first, modelled
    // glitches (three parameters each) after them, and a 70-parameter corner plot would be
    // thousands of panels
    let all = o.chains.names().len();
    let shown = all.min(MAX_PLOTTED);
    let names = o.chains.names()[..shown].to_vec();
    let per_chain: Vec<Vec<Vec<f64>>> = o
        .chains
        .chains()
        .iter()
        .map(|c| c.samples.chunks(all).map(|s| s[..shown].to_vec()).collect())
        .collect();
    // NaN marks a parameter whose true value is unknown; the plots leave it unmarked.
    let truth: Option<Vec<f64>> = o.summary.rows.iter().any(|r| r.truth.is_some()).then(|| {
        o.summary
            .rows
            .iter()
            .take(shown)
            .map(|r| r.truth.unwrap_or(f64::NAN))
            .collect()
    });
    // Units by name: the chains hold the free parameters, the rows say what each one is.
    let units: Vec<String> = names
        .iter()
        .map(|n| {
            o.summary
                .rows
                .iter()
                .find(|r| &r.name == n)
                .map(|r| r.unit.clone())
                .unwrap_or_default()
        })
        .collect();
    let ln_posterior: Vec<Vec<f64>> = o
        .chains
        .chains()
        .iter()
        .map(|c| c.ln_posterior.clone())
        .collect();
    crate::report::draw_trace(
        out,
        "trace",
        &crate::report::TracePlot {
            names: &names,
            units: &units,
            chains: &per_chain,
            ln_posterior: &ln_posterior,
            truth: truth.as_deref(),
            iterations: Some((o.summary.burn_in, o.summary.thin)),
        },
    )?;
    let map: Option<Vec<f64>> = names
        .iter()
        .map(|n| o.summary.rows.iter().find(|r| &r.name == n).map(|r| r.map))
        .collect();
    let pooled: Vec<Vec<f64>> = per_chain.iter().flatten().cloned().collect();
    let step = (pooled.len() / 20_000).max(1);
    let thinned: Vec<Vec<f64>> = pooled.into_iter().step_by(step).collect();
    crate::report::draw_corner(
        out,
        "corner",
        &crate::report::CornerPlot {
            names: &names,
            units: &units,
            samples: &thinned,
            truth: truth.as_deref(),
            map: map.as_deref(),
        },
    )?;
    if let Some(info) = &o.information {
        write_information(info, out)?;
    }
    crate::report::bode::write(out, &o.bode)?;
    crate::report::raw::write(out, &o.raw)?;
    Ok(())
}

/// Writes `information.md`, `information.json` and the plot `information.png`/`.svg`: the
/// share of each parameter's Fisher information below each frequency.
fn write_information(
    info: &crate::likelihood::information::Information,
    out: &Path,
) -> Result<(), FitError> {
    let io = |p: &Path, e: std::io::Error| FitError::Other(format!("{}: {e}", p.display()));
    let md = format!(
        "# Where the information comes from\n\nThe Fisher matrix of the free parameters at the MAP, split by experiment, by injection segment (the half-octave around each injected frequency) and by decade. A share is the part's fraction of the parameter's diagonal information; σ without is the Cramér–Rao σ with the part left out, over the σ with everything (∞: the rest cannot constrain the parameter).\n\n{}",
        info.markdown()
    );
    let p = out.join("information.md");
    crate::atomic::write_bytes(&p, md.as_bytes()).map_err(|e| io(&p, e))?;
    let json = serde_json::to_string_pretty(info).expect("information serialises") + "\n";
    let p = out.join("information.json");
    crate::atomic::write_bytes(&p, json.as_bytes()).map_err(|e| io(&p, e))?;
    let series: Vec<(String, Vec<(f64, f64)>)> = info
        .params
        .iter()
        .enumerate()
        .map(|(a, n)| {
            let pts = info.cumulative.iter().map(|(f, s)| (*f, s[a])).collect();
            (n.clone(), pts)
        })
        .collect();
    crate::report::line_plot(
        out,
        "information",
        &crate::report::LinePlot {
            title: "Share of each parameter's Fisher information below f",
            x_label: "f (Hz)",
            y_label: "cumulative share",
            series: &series,
            log_x: true,
            ..Default::default()
        },
    )?;
    Ok(())
}

/// Writes a run's chains as `chains.npz` (see [`chains_arrays`]), atomically.
pub fn write_chains_npz(chains: &Chains, path: &Path) -> Result<(), FitError> {
    crate::data::npz_write::write_npz_file(path, &chains_arrays(chains))
        .map_err(|e| FitError::Other(format!("{}: {e}", path.display())))
}
