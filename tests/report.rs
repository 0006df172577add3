//! `occam report` end to end: a fit, a select and a sweep run each become one page holding
//! every table row, every figure, every warning and the study; the page is well-formed,
//! escapes what users wrote, lands in the run's manifest, and a directory that is not a run
//! is refused.

mod common;
use common::occam;
use std::path::Path;

/// Fit and select settings of the runs (a few seconds each): the shared small study.
fn study() -> String {
    common::small()
}

/// A 1-D sweep of two points and two realisations (about a second).
const SWEEP: &str = r#"
seed = 5
output = "out"
[simulation]
target_snr = 30.0
thruster = { response = "pole", value = 0.3 }
[[model]]
kind = "ltp"
name = "pole"
thruster = "pole"
[prior]
f_df = { kind = "uniform", lo = 0.05, hi = 3.0 }
[select]
rj_iterations = 4000
rj_burn_in = 500
iterations = 1500
burn_in = 500
pt_temperatures = 0
[[select.model]]
name = "X"
free = ["a_df"]
fixed = { w1sq = -1.3e-6, w2sq = -1.9e-6, dt1 = 0.2, dt2 = 0.2, a_sus = 1.08, d21 = 4e-4 }
[[select.model]]
name = "Y"
model = "pole"
free = ["a_df", "f_df"]
fixed = { w1sq = -1.3e-6, w2sq = -1.9e-6, dt1 = 0.2, dt2 = 0.2, a_sus = 1.08, d21 = 4e-4 }
[sweep]
realisations = 2
truth = "Y"
[[sweep.axis]]
key = "simulation.target_snr"
values = [20.0, 3000.0]
[[experiment]]
name = "inv1"
pre_pad = 1000.0
post_pad = 3000.0
noise_duration = 5000.0
x1 = { kind = "sine", freq = 0.01, amplitude = 1e-6, duration = 2000.0 }
"#;

fn esc(s: &str) -> String {
    occam::html::esc(s)
}

fn read(p: &Path) -> String {
    std::fs::read_to_string(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// Checks that every tag the page opens is closed in order (void elements written `<x/>`),
/// that no `<` in text starts anything but a tag, comment or declaration, and that every `&`
/// starts an entity: the page parses the same as XHTML and HTML.
fn well_formed(html: &str) -> Result<(), String> {
    let b = html.as_bytes();
    let mut stack: Vec<String> = Vec::new();
    let mut i = 0;
    while i < b.len() {
        match b[i] {
            b'<' => {
                let rest = &html[i..];
                if rest.starts_with("<!--") {
                    i += rest.find("-->").ok_or("unterminated comment")? + 3;
                    continue;
                }
                if rest.starts_with("<!") || rest.starts_with("<?") {
                    i += rest.find('>').ok_or("unterminated declaration")? + 1;
                    continue;
                }
                let mut j = i + 1;
                let mut quote: Option<u8> = None;
                while j < b.len() {
                    match (quote, b[j]) {
                        (None, q @ (b'"' | b'\'')) => quote = Some(q),
                        (Some(q), c) if c == q => quote = None,
                        (None, b'>') => break,
                        _ => {}
                    }
                    j += 1;
                }
                if j == b.len() {
                    return Err(format!("unterminated tag at byte {i}"));
                }
                let inner = &html[i + 1..j];
                if let Some(name) = inner.strip_prefix('/') {
                    let name = name.trim();
                    match stack.pop() {
                        Some(open) if open == name => {}
                        other => {
                            return Err(format!(
                                "</{name}> at byte {i} closes {other:?}; open: {stack:?}"
                            ));
                        }
                    }
                } else {
                    let name: String = inner
                        .chars()
                        .take_while(|c| !c.is_whitespace() && *c != '/')
                        .collect();
                    if !name.starts_with(|c: char| c.is_ascii_alphabetic()) {
                        return Err(format!("a stray `<` at byte {i}: {:?}", inner));
                    }
                    if !inner.ends_with('/') {
                        stack.push(name);
                    }
                }
                i = j + 1;
            }
            b'&' => {
                let end = html[i..]
                    .find(';')
                    .filter(|&e| e > 1 && e < 12)
                    .ok_or(format!("a bare `&` at byte {i}"))?;
                let name = &html[i + 1..i + end];
                let ok = name.chars().all(|c| c.is_ascii_alphanumeric())
                    || (name.starts_with('#') && name[1..].chars().all(|c| c.is_ascii_digit()));
                if !ok {
                    return Err(format!("a bad entity &{name}; at byte {i}"));
                }
                i += end + 1;
            }
            _ => i += 1,
        }
    }
    if stack.is_empty() {
        Ok(())
    } else {
        Err(format!("unclosed: {stack:?}"))
    }
}

/// The page of `run`: written by `occam report`, listed in the run's manifest, well-formed,
/// free of scripts, with every figure the manifest lists inlined verbatim.
fn report(cwd: &Path, run: &str) -> String {
    let (ok, out, err) = occam(&["report", run], cwd);
    assert!(ok, "{err}");
    let page = cwd.join(run).join("report.html");
    assert!(out.contains("report.html"), "{out}");
    let html = read(&page);
    well_formed(&html).unwrap_or_else(|e| panic!("{run}: {e}"));
    assert!(!html.to_ascii_lowercase().contains("<script"), "{run}");
    let manifest: serde_json::Value =
        serde_json::from_str(&read(&cwd.join(run).join("manifest.json"))).unwrap();
    let files: Vec<&str> = manifest["files"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["name"].as_str().unwrap())
        .collect();
    assert!(files.contains(&"report.html"), "{files:?}");
    let svgs: Vec<&&str> = files.iter().filter(|f| f.ends_with(".svg")).collect();
    assert!(!svgs.is_empty(), "{run}: no figures to check");
    for f in &svgs {
        let svg = read(&cwd.join(run).join(f));
        let svg = occam::html::inline_svg(&svg).unwrap();
        assert!(html.contains(&svg), "{run}: {f} is not inlined");
        assert!(
            html.contains(&format!("<figcaption>{f}</figcaption>")),
            "{f}"
        );
    }
    assert_eq!(html.matches("<svg").count(), svgs.len(), "{run}");
    html
}

/// The rows of the page's tables: each `<td>`'s content, as HTML.
fn html_rows(html: &str) -> Vec<Vec<String>> {
    html.split("<tr>")
        .skip(1)
        .map(|tr| {
            let tr = &tr[..tr.find("</tr>").unwrap_or(tr.len())];
            tr.split("<td")
                .skip(1)
                .map(|td| {
                    let a = td.find('>').unwrap() + 1;
                    td[a..td.find("</td>").unwrap()].to_string()
                })
                .collect()
        })
        .collect()
}

/// Every body row of every table of a Markdown file is a row of the page (a select's
/// `table.md` has lines before its tables and more than one table).
fn has_markdown_rows(html: &str, md: &str) {
    let rows = html_rows(html);
    let mut n = 0;
    let lines: Vec<&str> = md.lines().collect();
    let rule = |l: &str| l.starts_with('|') && l.chars().all(|c| "|-: ".contains(c));
    for (i, line) in lines.iter().enumerate() {
        let header = lines.get(i + 1).is_some_and(|next| rule(next));
        if !line.starts_with('|') || rule(line) || header {
            continue;
        }
        let cells: Vec<String> = line
            .trim()
            .trim_matches('|')
            .split(" | ")
            .map(|c| esc(&c.trim().replace("\\|", "|")))
            .collect();
        assert!(rows.contains(&cells), "row missing: {line}");
        n += 1;
    }
    assert!(n > 0, "no rows in {md}");
}

/// Every warning in the summary's `warnings` is on the page, escaped.
fn has_warnings(html: &str, summary: &serde_json::Value) -> usize {
    let ws = summary["warnings"].as_array().cloned().unwrap_or_default();
    for w in &ws {
        let w = w.as_str().unwrap();
        assert!(html.contains(&esc(w)), "warning missing: {w}");
    }
    ws.len()
}

#[test]
fn fit_and_select_reports_hold_every_row_figure_warning_and_the_study() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("s.toml"), study()).unwrap();
    for cmd in ["fit", "select"] {
        let (ok, _, err) = occam(&[cmd, "s.toml", "-q"], d);
        assert!(ok, "{cmd}: {err}");
    }
    for cmd in ["fit", "select"] {
        let run = format!("out/{cmd}");
        let html = report(d, &run);
        has_markdown_rows(&html, &read(&d.join(&run).join("table.md")));
        let summary: serde_json::Value =
            serde_json::from_str(&read(&d.join(&run).join("summary.json"))).unwrap();
        let n = has_warnings(&html, &summary);
        assert!(html.contains(&format!("Warnings ({n})")) || n == 0, "{cmd}");
        // the run wrote its resolved study, and the page shows it verbatim (escaped)
        let resolved = read(&d.join(&run).join("study.resolved.toml"));
        assert!(html.contains(&esc(&resolved)), "{cmd}");
        assert!(!html.contains("predates study.resolved.toml"), "{cmd}");
        assert!(html.contains(&format!("<title>occam {cmd} — {run}</title>")));
        // diagnostics of each kind
        if cmd == "fit" {
            for p in summary["rows"].as_array().unwrap() {
                assert!(html.contains(&format!("<td>{}</td>", p["name"].as_str().unwrap())));
            }
            assert!(html.contains("<th>non-finite ln posterior</th>"));
        } else {
            for h in [
                "X against Y",
                "Parallel tempering",
                "Reversible jump",
                "effective jumps",
            ] {
                assert!(html.contains(h), "{h}");
            }
            // the full notes, which table.md cuts short
            let note = summary["pairs"][0]["estimates"][0]["note"]
                .as_str()
                .unwrap();
            assert!(html.contains(&esc(note)), "{note}");
        }
    }

    // the file is the study with its defaults; a run without it (older) says so
    let study = occam::config::Study::load(&d.join("s.toml")).unwrap();
    let text = occam::config::resolved_toml(&study).unwrap();
    // (its header names the study as the command was given it: compare the TOML itself)
    let body = |t: &str| -> Vec<String> {
        t.lines()
            .filter(|l| !l.starts_with('#'))
            .map(String::from)
            .collect()
    };
    assert_eq!(
        body(&read(&d.join("out/fit/study.resolved.toml"))),
        body(&text)
    );
    std::fs::remove_file(d.join("out/fit/study.resolved.toml")).unwrap();
    let html = report(d, "out/fit");
    assert!(html.contains("predates study.resolved.toml"));

    // the next fit removes the stale report with its other old outputs
    let (ok, _, err) = occam(&["fit", "s.toml", "-q"], d);
    assert!(ok, "{err}");
    assert!(!d.join("out/fit/report.html").exists());
}

#[test]
fn a_sweep_report_holds_its_text_table_and_every_task_warning() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("w.toml"), SWEEP).unwrap();
    let (ok, _, err) = occam(&["sweep", "w.toml", "-q"], d);
    assert!(ok, "{err}");
    let html = report(d, "out/sweep");
    let table = read(&d.join("out/sweep/table.txt"));
    // each row's cells (the text table's columns are cut at its rule of dashes)
    let lines: Vec<&str> = table.lines().collect();
    let rule = lines.iter().position(|l| l.starts_with("---")).unwrap();
    let mut rows = 0;
    for l in &lines[rule + 1..] {
        if l.trim().is_empty() || !l.starts_with(' ') {
            break;
        }
        let first = l.split_whitespace().next().unwrap();
        assert!(html.contains(&format!(">{first}</td>")), "row missing: {l}");
        for token in l.split_whitespace() {
            assert!(html.contains(&esc(token)), "{token} of {l}");
        }
        rows += 1;
    }
    assert_eq!(rows, 2, "{table}");
    // the text lines around the table
    assert!(html.contains(&format!("<p class=\"tabletext\">{}</p>", esc(lines[0]))));
    // every realisation's warning
    let sweep: serde_json::Value =
        serde_json::from_str(&read(&d.join("out/sweep/sweep.json"))).unwrap();
    let mut n = 0;
    for p in sweep["points"].as_array().unwrap() {
        for r in p["realisations"].as_array().unwrap() {
            for w in r["outcome"]["warnings"].as_array().into_iter().flatten() {
                assert!(html.contains(&esc(w.as_str().unwrap())), "{w}");
                n += 1;
            }
        }
    }
    assert!(n > 0, "the sweep was meant to warn (MAP on a prior bound)");
    // and the terminal shows them (issue 52: it showed none), each kind once with its count
    assert!(err.contains("warning: the tasks raised"), "{err}");
    let kinds: Vec<&str> = err
        .lines()
        .filter(|l| l.starts_with("warning: (in "))
        .collect();
    assert!(!kinds.is_empty() && kinds.len() <= n, "{err}");
    let all: Vec<&str> = sweep["points"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|p| p["realisations"].as_array().unwrap())
        .flat_map(|r| r["outcome"]["warnings"].as_array().into_iter().flatten())
        .filter_map(|w| w.as_str())
        .collect();
    for k in &kinds {
        let text = k.split_once(") ").unwrap().1;
        assert!(all.contains(&text), "{text} not among {all:?}");
    }
    assert!(html.contains("simulation.target_snr"));
}

#[test]
fn user_text_is_escaped_and_figures_lose_scripts() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("s.toml"), study()).unwrap();
    let (ok, _, err) = occam(&["fit", "s.toml", "-q", "-o", "a<b>&c"], d);
    assert!(ok, "{err}");
    let run = d.join("a<b>&c");
    // a summary, a figure and a study edited by hand (or written by a hostile tool)
    let p = run.join("summary.json");
    let mut s: serde_json::Value = serde_json::from_str(&read(&p)).unwrap();
    s["model"] = "<script>alert(1)</script>".into();
    s["warnings"] = serde_json::json!(["<img src=x onerror=alert(2)> & more"]);
    std::fs::write(&p, s.to_string()).unwrap();
    let f = run.join("corner.svg");
    let svg = read(&f).replacen("</svg>", "<script>alert(3)</script></svg>", 1);
    std::fs::write(&f, svg).unwrap();
    std::fs::write(
        run.join("study.resolved.toml"),
        "# </pre><script>alert(4)</script>\nseed = 1\n",
    )
    .unwrap();
    // as edited, the report refuses the summary (its size is not the manifest's) ...
    let (ok, _, err) = occam(&["report", "a<b>&c"], d);
    assert!(
        !ok && err.contains("changed since the run wrote it"),
        "{err}"
    );
    // ... so the hostile tool rewrites the manifest's sizes too: what it wrote is escaped
    let m = run.join("manifest.json");
    let mut man: serde_json::Value = serde_json::from_str(&read(&m)).unwrap();
    for f in man["files"].as_array_mut().unwrap() {
        let len = std::fs::metadata(run.join(f["name"].as_str().unwrap()))
            .unwrap()
            .len();
        f["bytes"] = len.into();
    }
    std::fs::write(&m, man.to_string()).unwrap();
    let (ok, _, err) = occam(&["report", "a<b>&c"], d);
    assert!(ok, "{err}");
    let html = read(&run.join("report.html"));
    well_formed(&html).unwrap();
    assert!(!html.to_ascii_lowercase().contains("<script"), "{html}");
    assert!(!html.contains("<img"));
    for s in [
        "&lt;script&gt;alert(1)&lt;/script&gt;",
        "&lt;img src=x onerror=alert(2)&gt; &amp; more",
        "&lt;/pre&gt;&lt;script&gt;alert(4)&lt;/script&gt;",
        "occam fit — a&lt;b&gt;&amp;c",
    ] {
        assert!(html.contains(s), "{s}");
    }
}

#[test]
fn non_runs_old_runs_busy_runs_and_other_destinations() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // not a run: an empty directory, a missing one, a file
    std::fs::create_dir(d.join("empty")).unwrap();
    std::fs::write(d.join("file.txt"), "x").unwrap();
    for target in ["empty", "missing", "file.txt"] {
        let (ok, _, err) = occam(&["report", target], d);
        assert!(!ok);
        assert!(
            err.contains(&format!(
                "{target} is not an occam run directory (no manifest.json); give the directory a fit/select/sweep wrote"
            )),
            "{err}"
        );
    }
    assert!(!d.join("empty/.occam.lock").exists() && !d.join("empty/report.html").exists());

    std::fs::write(d.join("s.toml"), study()).unwrap();
    let (ok, _, err) = occam(&["fit", "s.toml", "-q"], d);
    assert!(ok, "{err}");
    let run = d.join("out/fit");
    let manifest = read(&run.join("manifest.json"));

    // elsewhere: written there, the run's manifest untouched; over a run's own file: refused
    let (ok, out, err) = occam(&["report", "out/fit", "-o", "elsewhere.html"], d);
    assert!(ok && out.contains("elsewhere.html"), "{err}");
    well_formed(&read(&d.join("elsewhere.html"))).unwrap();
    assert_eq!(read(&run.join("manifest.json")), manifest);
    let (ok, _, err) = occam(&["report", "out/fit", "-o", "out/fit/summary.json"], d);
    assert!(!ok && err.contains("one of the run's own files"), "{err}");
    assert!(read(&run.join("summary.json")).starts_with('{'));

    // a run that is being written: refused, nothing written
    let held = occam::data::rundir::RunDir::lock(&run).unwrap();
    let e = occam::html::write_report(&run, None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("another occam run"), "{e}");
    assert!(!run.join("report.html").exists());
    drop(held);

    // a run from before manifests: recognised by its summary, nothing added to a manifest
    std::fs::remove_file(run.join("manifest.json")).unwrap();
    let (ok, _, err) = occam(&["report", "out/fit"], d);
    assert!(ok, "{err}");
    let html = read(&run.join("report.html"));
    assert!(html.contains("has no manifest.json"));
    assert!(html.contains("<title>occam fit"));
    assert!(!run.join("manifest.json").exists());
    // every figure of the directory: trace, corner, information, and the data and Bode plots
    let svgs: Vec<String> = std::fs::read_dir(&run)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".svg"))
        .collect();
    assert!(
        svgs.iter().any(|n| n.starts_with("timeseries_")),
        "{svgs:?}"
    );
    assert_eq!(html.matches("<svg").count(), svgs.len(), "{svgs:?}");
}

#[test]
fn the_well_formedness_check_can_fail() {
    assert!(well_formed("<p><b>x</b></p>").is_ok());
    assert!(well_formed("<p><br/>&amp;&#39;</p>").is_ok());
    assert!(well_formed("<p><b>x</p></b>").is_err());
    assert!(well_formed("<p>").is_err());
    assert!(well_formed("<p>a < b</p>").is_err());
    assert!(well_formed("<p>a & b</p>").is_err());
    assert!(well_formed("<p title=\"a>b\">x</p>").is_ok());
    assert!(well_formed("<p").is_err());
}
