//! The page: one self-contained XHTML-compatible document (inline CSS, inline SVG, no
//! script, no external resource), sections in a fixed order.

use super::escape::esc;
use super::fmt::{facts, table};
use super::parts::Parts;
use super::run::{RESOLVED_STUDY, Run, RunKind};
use super::table::{parse_markdown, parse_text, to_html};

const STYLE: &str = "
body { font-family: system-ui, -apple-system, 'Segoe UI', Roboto, sans-serif; margin: 0 auto;
  max-width: 1200px; padding: 1em 2em 3em; color: #1a1a1a; background: #fff; line-height: 1.45; }
h1 { font-size: 1.6em; margin-bottom: 0.2em; }
h2 { border-bottom: 2px solid #0072b2; padding-bottom: 0.2em; margin-top: 2em; }
h3 { margin-top: 1.4em; }
nav { margin: 0.8em 0; }
nav a { margin-right: 1.2em; color: #0072b2; }
dl.facts { display: grid; grid-template-columns: max-content auto; gap: 0.15em 1.2em; }
dl.facts dt { font-weight: 600; }
dl.facts dd { margin: 0; }
.scroll { overflow-x: auto; margin: 0.6em 0; }
table { border-collapse: collapse; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: left; vertical-align: top; }
th { background: #eef3f8; }
table.file td { white-space: nowrap; }
table.file td.wrap { white-space: normal; min-width: 24em; }
td.num, th.num { text-align: right; font-variant-numeric: tabular-nums; }
tbody tr:nth-child(even) { background: #f7f7f7; }
.warnings { border: 3px solid #d55e00; background: #fff4ec; padding: 0.4em 1.2em 0.8em; }
.warnings h2 { border: none; color: #a33f00; margin-top: 0.4em; }
.warnings li { margin: 0.4em 0; }
.warnings .where { color: #555; font-size: 0.85em; }
h3 .where { color: #555; font-size: 0.8em; font-weight: normal; }
.nowarnings { border: 2px solid #009e73; background: #effaf5; padding: 0.6em 1.2em; }
.bad { color: #b03a00; font-weight: 700; }
.note, .tabletext { color: #444; }
pre { background: #f5f5f5; border: 1px solid #ddd; padding: 0.8em; overflow-x: auto;
  font-size: 0.85em; }
figure { margin: 1.2em 0; }
figure svg { max-width: 100%; height: auto; display: block; }
figcaption { font-size: 0.9em; color: #444; margin-top: 0.3em; }
footer { margin-top: 3em; font-size: 0.85em; color: #666; }
";

/// How many places to name under one warning before summarising the rest.
const MAX_PLACES: usize = 8;

fn warnings_section(p: &Parts) -> String {
    if p.warnings.is_empty() {
        return "<section id=\"warnings\" class=\"nowarnings\"><h2>Warnings</h2><p>None: the run recorded no warning.</p></section>\n".into();
    }
    let mut h = format!(
        "<section id=\"warnings\" class=\"warnings\"><h2>Warnings ({})</h2>\n<ul>\n",
        p.warnings.len()
    );
    for w in &p.warnings.0 {
        let mut places: Vec<String> = w.places.iter().take(MAX_PLACES).map(|s| esc(s)).collect();
        if w.places.len() > MAX_PLACES {
            places.push(format!("and {} more", w.places.len() - MAX_PLACES));
        }
        h.push_str(&format!(
            "<li>{}<br/><span class=\"where\">in {}</span></li>\n",
            esc(&w.text),
            places.join("; ")
        ));
    }
    h.push_str("</ul></section>\n");
    h
}

/// The run's notes (`notes` in its summary: facts about the data that are not problems, such as
/// its gaps), after the warnings; nothing without them.
fn notes_section(s: &serde_json::Value) -> String {
    let notes: Vec<&str> = s
        .get("notes")
        .and_then(|v| v.as_array())
        .map(|a| a.iter().filter_map(|n| n.as_str()).collect())
        .unwrap_or_default();
    if notes.is_empty() {
        return String::new();
    }
    let mut h = String::from("<section id=\"notes\"><h2>Notes</h2>\n<ul>\n");
    for n in notes {
        h.push_str(&format!("<li>{}</li>\n", esc(n)));
    }
    h.push_str("</ul></section>\n");
    h
}

/// The headline of a run that failed its own checks (`"valid": false` in its summary, with
/// `invalid_reasons`): before every table; nothing for a valid run or an older summary.
fn invalid_section(s: &serde_json::Value) -> String {
    if s.get("valid").and_then(|v| v.as_bool()) != Some(false) {
        return String::new();
    }
    let mut h = String::from(
        "<section id=\"invalid\" class=\"warnings\"><h2>Results not valid: do not use the numbers below</h2>\n<p>This run failed its own checks:</p>\n<ul>\n",
    );
    for r in s
        .get("invalid_reasons")
        .and_then(|v| v.as_array())
        .into_iter()
        .flatten()
        .filter_map(|v| v.as_str())
    {
        h.push_str(&format!("<li>{}</li>\n", esc(r)));
    }
    h.push_str("</ul></section>\n");
    h
}

/// A reader's heading for a table file of a run (its name shown beside it).
fn table_title(name: &str) -> String {
    match name {
        "table.md" | "table.txt" => "Estimates".into(),
        "information.md" => "Where the information comes from".into(),
        "design.md" | "design.txt" => "Design".into(),
        other => other.to_string(),
    }
}

fn tables_section(run: &Run) -> String {
    let mut h = String::from("<section id=\"tables\"><h2>Results</h2>\n");
    if run.tables.is_empty() {
        h.push_str("<p class=\"note\">This run wrote no table.</p>\n");
    }
    for (name, text) in &run.tables {
        let blocks = if name.ends_with(".md") {
            parse_markdown(text)
        } else {
            parse_text(text)
        };
        h.push_str(&format!(
            "<h3>{} <span class=\"where\">({})</span></h3>\n{}",
            esc(&table_title(name)),
            esc(name),
            to_html(&blocks)
        ));
    }
    h.push_str("</section>\n");
    h
}

fn figures_section(run: &Run) -> String {
    let mut h = String::from("<section id=\"figures\"><h2>Figures</h2>\n");
    if run.figures.is_empty() {
        h.push_str("<p class=\"note\">This run wrote no SVG figure.</p>\n");
    }
    for (name, svg) in &run.figures {
        h.push_str(&format!(
            "<figure>\n{svg}\n<figcaption>{}</figcaption></figure>\n",
            esc(name)
        ));
    }
    h.push_str("</section>\n");
    h
}

fn study_section(run: &Run) -> String {
    let mut h = String::from("<section id=\"study\"><h2>Study</h2>\n");
    match &run.study {
        Some(text) => h.push_str(&format!(
            "<p class=\"note\">{RESOLVED_STUDY}: the study this run used, every default filled in.</p>\n<pre>{}</pre>\n",
            esc(text)
        )),
        None => h.push_str(&format!(
            "<p class=\"note\">This run predates {RESOLVED_STUDY} (or its command does not write one): the study it used is not recorded in the directory.</p>\n"
        )),
    }
    h.push_str("</section>\n");
    h
}

fn files_section(run: &Run) -> String {
    let mut h = String::from("<section id=\"files\"><h2>Files</h2>\n");
    h.push_str(&match &run.manifest {
        Some(m) => format!(
            "<p class=\"note\">As listed in manifest.json (written by occam {} <code>{}</code>).</p>\n",
            esc(&m.version),
            esc(&m.command)
        ),
        None => "<p class=\"note\">This directory has no manifest.json (a run that predates manifests, or one interrupted while publishing): the files below are what the directory holds.</p>\n".into(),
    });
    let rows: Vec<Vec<String>> = run
        .files
        .iter()
        .map(|(n, b)| vec![esc(n), b.to_string()])
        .collect();
    h.push_str(&table(&["file", "bytes"], &rows));
    if !run.skipped.is_empty() {
        let rows: Vec<Vec<String>> = run
            .skipped
            .iter()
            .map(|s| vec![esc(&s.name), esc(&s.why)])
            .collect();
        h.push_str("<h3>Not shown</h3>\n");
        h.push_str(&table(&["file", "why"], &rows));
    }
    h.push_str("</section>\n");
    h
}

fn other_outputs(run: &Run) -> String {
    let mut h = String::new();
    for (name, text) in &run.json_files {
        h.push_str(&format!(
            "<h3>{}</h3>\n<pre>{}</pre>\n",
            esc(name),
            esc(text)
        ));
    }
    if h.is_empty() {
        h.push_str("<p class=\"note\">No diagnostics for this kind of run.</p>\n");
    }
    h
}

/// The whole page for `run`.
pub fn render(run: &Run) -> String {
    let parts = match (&run.kind, &run.summary) {
        (RunKind::Fit, Some((_, s))) => super::fit::parts(s),
        (RunKind::Select, Some((_, s))) => super::select::parts(
            s,
            run.tables
                .iter()
                .any(|(n, _)| n == "table.md" || n == "table.txt"),
        ),
        (RunKind::Sweep, Some((_, s))) => super::sweep::parts(s),
        _ => Parts {
            diagnostics: other_outputs(run),
            ..Parts::default()
        },
    };
    let dir = run.dir.display().to_string();
    let title = format!("occam {} — {}", run.kind.name(), dir);
    let mut h = String::new();
    h.push_str("<!DOCTYPE html>\n<html xmlns=\"http://www.w3.org/1999/xhtml\" lang=\"en\">\n<head>\n<meta charset=\"utf-8\"/>\n");
    h.push_str("<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\"/>\n");
    h.push_str(&format!("<title>{}</title>\n", esc(&title)));
    h.push_str(&format!("<style>{STYLE}</style>\n</head>\n<body>\n"));
    h.push_str(&format!("<header><h1>{}</h1>\n", esc(&title)));
    let mut f: Vec<(&str, String)> = vec![("command", esc(run.kind.name()))];
    if let Some(m) = &run.manifest {
        f.push(("written by", format!("occam {}", esc(&m.version))));
    }
    f.extend(parts.facts.iter().map(|(k, v)| (*k, v.clone())));
    h.push_str(&facts(&f));
    h.push_str("</header>\n");
    h.push_str("<nav><a href=\"#warnings\">Warnings</a><a href=\"#tables\">Results</a><a href=\"#diagnostics\">Diagnostics</a><a href=\"#figures\">Figures</a><a href=\"#study\">Study</a><a href=\"#files\">Files</a></nav>\n");
    if let Some((_, s)) = &run.summary {
        h.push_str(&invalid_section(s));
    }
    h.push_str(&warnings_section(&parts));
    if let Some((_, s)) = &run.summary {
        h.push_str(&notes_section(s));
    }
    h.push_str(&tables_section(run));
    h.push_str(&format!(
        "<section id=\"diagnostics\"><h2>Diagnostics</h2>\n{}</section>\n",
        parts.diagnostics
    ));
    h.push_str(&figures_section(run));
    h.push_str(&study_section(run));
    h.push_str(&files_section(run));
    h.push_str(&format!(
        "<footer>Written by <code>occam report</code> (occam {}) from {}. Self-contained: no scripts, no external resources.</footer>\n</body>\n</html>\n",
        env!("CARGO_PKG_VERSION"),
        esc(&dir)
    ));
    h
}

#[cfg(test)]
mod tests {
    use super::{invalid_section, notes_section};
    use serde_json::json;

    #[test]
    fn a_failed_run_leads_with_its_reasons_and_a_valid_or_old_one_with_nothing() {
        let bad = json!({"valid": false, "invalid_reasons": ["chains: R-hat above 1.1 for `a` 1.64 <x>"]});
        let h = invalid_section(&bad);
        assert!(h.contains("Results not valid"), "{h}");
        assert!(h.contains("R-hat above 1.1 for `a` 1.64 &lt;x&gt;"), "{h}");
        assert!(invalid_section(&json!({"valid": true, "invalid_reasons": []})).is_empty());
        assert!(invalid_section(&json!({"origin": "an older run"})).is_empty());
    }

    #[test]
    fn notes_are_listed_each_and_absent_without_any() {
        let s = json!({"notes": ["experiment `a`: 3 gap(s) <x>", "experiment `b`: 1 gap(s)"], "warnings": []});
        let h = notes_section(&s);
        assert!(h.contains("<h2>Notes</h2>"), "{h}");
        assert!(
            h.contains("<li>experiment `a`: 3 gap(s) &lt;x&gt;</li>"),
            "{h}"
        );
        assert!(h.contains("<li>experiment `b`: 1 gap(s)</li>"), "{h}");
        assert!(notes_section(&json!({"warnings": ["w"]})).is_empty());
        assert!(notes_section(&json!({"notes": []})).is_empty());
    }
}
