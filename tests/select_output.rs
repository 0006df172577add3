//! What `occam select` shows a reader: the answer before the table, every note in full, each
//! model's parameter estimates, and repeated warnings merged (issue 24, items 1–3).

mod common;
use common::{occam, small};

#[test]
fn select_leads_with_the_answer_and_cuts_no_note() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("s.toml"), small()).unwrap();
    let (ok, out, err) = occam(&["select", "s.toml", "-q"], d);
    assert!(ok, "{err}");
    let lines: Vec<&str> = out.lines().collect();
    let pos = |needle: &str| {
        lines
            .iter()
            .position(|l| l.starts_with(needle))
            .unwrap_or_else(|| panic!("no line starting with {needle:?}:\n{out}"))
    };
    // the header: the models and what differs, then the answer, then the table
    let models = pos("models compared: 2; all have a_df and a_sus free");
    assert!(
        lines[models + 1]
            .trim_start()
            .starts_with("X  3 free parameters of model `ltp`; also d21 free"),
        "{out}"
    );
    assert!(
        lines[models + 2].contains(
            "fixes w1sq = -1.300e-6 s⁻², w2sq = -1.900e-6 s⁻², dt1 = 0.2000 s, dt2 = 0.2000 s and d21 = 0"
        ),
        "{out}"
    );
    let answer = pos("answer: ");
    let probs = pos("posterior model probabilities (prior equal): ");
    let table = pos("pair  estimator");
    assert!(models < answer && answer < probs && probs < table, "{out}");
    // only the data lines of the run's log come before the header
    assert!(
        lines[..models]
            .iter()
            .all(|l| l.starts_with("data:") || l.starts_with("noise reference")),
        "{out}"
    );
    // the answer names the preferred model and the reference's ln B with its error
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("out/select/summary.json")).unwrap())
            .unwrap();
    let preferred = s["pairs"][0]["preferred"].as_str().unwrap();
    assert!(
        lines[answer].starts_with(&format!("answer: {preferred} preferred")),
        "{out}"
    );
    assert!(
        lines[answer + 1].contains("ln B(X/Y) = ") && lines[answer + 1].contains(" ± "),
        "{out}"
    );
    // no note is cut, anywhere: every row's note is in full under its marker
    for text in [
        out.clone(),
        std::fs::read_to_string(d.join("out/select/table.txt")).unwrap(),
        std::fs::read_to_string(d.join("out/select/table.md")).unwrap(),
    ] {
        assert!(!text.contains('…'), "a cut note:\n{text}");
        for e in s["pairs"][0]["estimates"].as_array().unwrap() {
            for k in ["note", "assumes"] {
                if let Some(n) = e[k].as_str() {
                    assert!(text.contains(n), "note {n:?} missing from:\n{text}");
                }
            }
        }
    }
    // each model's estimates: in the terminal, the files and summary.json
    for m in s["models"].as_array().unwrap() {
        let est = m["estimates"].as_array().unwrap();
        assert_eq!(est.len(), m["free"].as_array().unwrap().len());
        for e in est {
            assert!(
                e["map"].is_f64()
                    && e["mean"].is_f64()
                    && e["sd"].is_f64()
                    && e["fisher_sigma"].is_f64(),
                "{e}"
            );
        }
    }
    assert_eq!(s["models"][0]["estimates"][0]["name"], "a_df");
    let est = pos("parameter estimates of each model:");
    assert!(lines[est + 1].starts_with("model  parameter  "), "{out}");
    assert!(table < est, "{out}");
    let md = std::fs::read_to_string(d.join("out/select/table.md")).unwrap();
    assert!(md.starts_with("- models compared: 2"), "{md}");
    assert!(md.contains("| model | parameter |"), "{md}");
    // the jumps line says what burn-in does to its counts
    assert!(out.contains("burn-in included — after burn-in"), "{out}");
}
