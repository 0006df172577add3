//! The book's study-file reference (`docs/src/reference/study-file.md`) against the loader:
//! every table the reference lists has exactly the keys the loader accepts, and every table the
//! loader has is listed.
//!
//! The loader's key sets are not written down a second time here: each table's type is asked
//! for them (a probe key makes serde list the fields it expected), so a key added to a struct
//! without a line in the reference fails this test, and so does a listed key the loader refuses.

use std::collections::{BTreeMap, BTreeSet};

/// The names serde lists after "expected" in an unknown-field or unknown-variant error.
fn expected_names(err: &str) -> BTreeSet<String> {
    let Some(i) = err.find("expected") else {
        return BTreeSet::new();
    };
    err[i..]
        .split('`')
        .skip(1)
        .step_by(2)
        .map(str::to_string)
        .collect()
}

/// The keys of the table type `T`, asked with an unknown key (and `prefix` lines such as the
/// `kind` of a tagged enum).
fn keys<T: serde::de::DeserializeOwned>(prefix: &str) -> BTreeSet<String> {
    let text = format!("{prefix}\nzz_probe = 1\n");
    match toml::from_str::<T>(&text) {
        // serde lets a unit variant of a tagged enum (`kind = "none"`) ignore other keys: the
        // table has no key besides its `kind`
        Ok(_) => BTreeSet::new(),
        Err(e) => {
            let msg = e.to_string();
            assert!(
                msg.contains("zz_probe"),
                "{}: {msg}",
                std::any::type_name::<T>()
            );
            expected_names(&msg)
        }
    }
}

/// The variants of the tagged enum `T` (its `kind` values).
fn kinds<T: serde::de::DeserializeOwned>() -> BTreeSet<String> {
    let e = toml::from_str::<T>("kind = \"zz_probe\"\n")
        .err()
        .expect("an unknown kind is refused")
        .to_string();
    expected_names(&e)
}

/// Every table of a study file, by the heading the reference gives it, with its keys.
fn schema() -> BTreeMap<String, BTreeSet<String>> {
    use crate::config::*;
    let mut s = BTreeMap::new();
    let mut put = |h: &str, k: BTreeSet<String>| {
        s.insert(h.to_string(), k);
    };
    put("top level", keys::<StudyFile>(""));
    put("[truth]", keys::<crate::ltp::LtpParams>(""));
    put("[noise]", keys::<crate::ltp::NoiseModel>(""));
    put("[masses]", keys::<crate::ltp::Masses>(""));
    put("[simulation]", keys::<SimulationOptions>(""));
    put("[simulation.thruster]", keys::<TruthThruster>(""));
    put(
        "[simulation.gaps]",
        keys::<crate::experiment::RandomGaps>(""),
    );
    put(
        "[simulation.glitches]",
        keys::<crate::experiment::RandomGlitches>(""),
    );
    put("[simulation.actuators]", keys::<ActuatorOptions>(""));
    put("[simulation.actuators.tm1]", keys::<ActuatorEntry>(""));
    put("[analysis]", keys::<AnalysisOptions>(""));
    put(
        "[analysis.log_periodogram]",
        keys::<crate::likelihood::LogPeriodogramOptions>(""),
    );
    put("[prior.NAME] kind", kinds::<crate::prior::PriorKind>());
    for k in kinds::<crate::prior::PriorKind>() {
        put(
            &format!("[prior.NAME] kind = \"{k}\""),
            keys::<crate::prior::PriorKind>(&format!("kind = \"{k}\"")),
        );
    }
    put(
        "[[model]] kind = \"ltp\"",
        keys::<models::LtpModelEntry>(""),
    );
    put(
        "[[model]] kind = \"accel\"",
        keys::<models::AccelModelEntry>(""),
    );
    put(
        "[[model]] kind = \"tied\"",
        keys::<models::TiedModelEntry>(""),
    );
    put(
        "[[model]] kind = \"drift\"",
        keys::<models::DriftModelEntry>(""),
    );
    put(
        "[[model]] kind = \"user\"",
        keys::<crate::model::user::UserModelDef>(""),
    );
    put(
        "[[model]] kind = \"state_space\"",
        keys::<crate::model::state_space::StateSpaceDef>(""),
    );
    put(
        "[[model]] kind = \"transfer_matrix\"",
        keys::<crate::model::state_space::TransferMatrixDef>(""),
    );
    put(
        "[model.blocks.NAME] kind",
        kinds::<crate::model::user::BlockDef>(),
    );
    for k in kinds::<crate::model::user::BlockDef>() {
        put(
            &format!("[model.blocks.NAME] kind = \"{k}\""),
            keys::<crate::model::user::BlockDef>(&format!("kind = \"{k}\"")),
        );
    }
    put("[fit]", keys::<FitOptions>(""));
    put("[select]", keys::<SelectOptions>(""));
    put("[[select.model]]", keys::<SelectModelEntry>(""));
    put("[sweep]", keys::<sweep::SweepOptions>(""));
    put("[[sweep.axis]]", keys::<sweep::SweepAxis>(""));
    put("[design]", keys::<crate::config::design::DesignOptions>(""));
    put("[[experiment]]", keys::<ExperimentEntry>(""));
    put("[[stretch]]", keys::<stretches::StretchEntry>(""));
    put("[[experiment]] injection kind", kinds::<InjectionEntry>());
    for k in kinds::<InjectionEntry>() {
        put(
            &format!("[[experiment]] injection kind = \"{k}\""),
            keys::<InjectionEntry>(&format!("kind = \"{k}\"")),
        );
    }
    put(
        "sine_train segments",
        keys::<crate::experiment::SineSegment>(""),
    );
    s
}

/// The reference chapter: after its `# Study file reference` title, `## heading` lines, each
/// followed by a table whose first column holds the keys in backticks.
fn book_reference(chapter: &str) -> BTreeMap<String, BTreeSet<String>> {
    assert!(
        chapter.starts_with("# Study file reference\n"),
        "the reference chapter starts with `# Study file reference`"
    );
    let mut out: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    let mut current: Option<String> = None;
    for line in chapter.lines() {
        if let Some(h) = line.strip_prefix("## ") {
            let h = h.trim().trim_matches('`').to_string();
            assert!(!out.contains_key(&h), "the reference lists {h} twice");
            out.insert(h.clone(), BTreeSet::new());
            current = Some(h);
        } else if let (Some(h), Some(row)) = (&current, line.strip_prefix("| `")) {
            let key = row.split('`').next().unwrap_or_default().to_string();
            out.get_mut(h).expect("inserted").insert(key);
        }
    }
    out
}

#[test]
fn the_book_lists_every_study_key_and_no_other() {
    let doc = book_reference(include_str!("../../docs/src/reference/study-file.md"));
    let schema = schema();
    let mut problems = Vec::new();
    for (table, keys) in &schema {
        match doc.get(table) {
            None => problems.push(format!(
                "docs/src/reference/study-file.md has no `## {table}` table (keys: {keys:?})"
            )),
            Some(d) => {
                let missing: Vec<_> = keys.difference(d).collect();
                let extra: Vec<_> = d.difference(keys).collect();
                if !missing.is_empty() {
                    problems.push(format!("{table}: the reference lacks {missing:?}"));
                }
                if !extra.is_empty() {
                    problems.push(format!("{table}: the loader has no {extra:?}"));
                }
            }
        }
    }
    for table in doc.keys().filter(|t| !schema.contains_key(*t)) {
        problems.push(format!(
            "reference table `{table}` is not a table of the loader"
        ));
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

#[test]
fn the_probe_reads_serde_lists() {
    let e = "unknown field `zz`, expected one of `a`, `b_c`, `d`";
    assert_eq!(
        expected_names(e),
        ["a", "b_c", "d"].map(String::from).into()
    );
    assert_eq!(
        expected_names("unknown field `zz`, expected `only`"),
        ["only".to_string()].into()
    );
    assert!(expected_names("unknown field `zz`, there are no fields").is_empty());
    // a probe of a real table finds keys the reference names
    assert!(keys::<crate::config::FitOptions>("").contains("burn_in"));
}

#[test]
fn the_reference_parser_reads_headings_and_first_cells() {
    let text = "# Study file reference\n| `not_a_key` | before any heading |\n## `[fit]`\n| key | default |\n|---|---|\n| `chains` | 4 |\n| `burn_in` | 5000 |\n## top level\n| `seed` | required |\n";
    let r = book_reference(text);
    assert_eq!(r.len(), 2, "{r:?}");
    assert_eq!(r["[fit]"], ["burn_in", "chains"].map(String::from).into());
    assert_eq!(r["top level"], ["seed".to_string()].into());
}
