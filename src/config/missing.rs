//! Every required key a study lacks, at once: serde stops at the first missing field, so a
//! study missing three keys would otherwise take three runs to learn them. The text is parsed
//! again with a stand-in value for each key found (at the head of the table that lacks it),
//! until no further one is missing. The stand-ins only find the keys; nothing parsed with them
//! is used.

use super::study::StudyFile;

/// At most this many re-parses (each finds one key).
const MAX_KEYS: usize = 32;

/// Stand-in values tried for a missing key, until one has the key's type.
const STAND_INS: [&str; 5] = ["0", "\"x\"", "[]", "{}", "0.5"];

/// The 1-based line of byte `at`.
fn line_of(text: &str, at: usize) -> usize {
    text[..at.min(text.len())].matches('\n').count() + 1
}

/// `missing field `k`` of a TOML error: the key and where its table starts (`None`: the
/// top-level table, whose span is the whole text).
fn missing_key(e: &toml::de::Error, text: &str) -> Option<(String, Option<usize>)> {
    let k = e
        .message()
        .strip_prefix("missing field `")?
        .split('`')
        .next()?;
    let at = match e.span() {
        Some(s) if !(s.start == 0 && s.end >= text.trim_end().len()) => Some(s.start),
        _ => None,
    };
    Some((k.to_string(), at))
}

/// Where a stand-in for a key of the table starting at byte `at` goes: after its header
/// line, or at the very top for the top-level table (`None`).
fn insertion_point(text: &str, at: Option<usize>) -> Option<usize> {
    let Some(at) = at else { return Some(0) };
    let start = text[..at.min(text.len())].rfind('\n').map_or(0, |i| i + 1);
    let line = text[start..].lines().next().unwrap_or("");
    if line.trim_start().starts_with('[') {
        Some(start + line.len() + 1).filter(|&i| i <= text.len())
    } else {
        // a key of an inline table: no line to insert
        None
    }
}

/// Every missing required key as `(key, line of its table)` (line 0: the top level), in
/// the order of their tables, when the first parse failed with `first`; empty when the
/// failure is not a missing key.
pub fn missing_keys(text: &str, first: &toml::de::Error) -> Vec<(String, usize)> {
    let mut found = Vec::new();
    let mut text = text.to_string();
    let mut err = Some(first.clone());
    // lines inserted above each original line, to report the user's own line numbers
    let mut inserted: Vec<usize> = Vec::new();
    while let Some(e) = err.take() {
        if found.len() >= MAX_KEYS {
            break;
        }
        let Some((key, at)) = missing_key(&e, &text) else {
            break;
        };
        // the top-level table is reported at line 0; a span at the very start may be the
        // top level's or the first table's (when the file opens with a header): try both
        let table_line = at.map_or(0, |a| original_line(line_of(&text, a), &inserted));
        let mut places: Vec<(usize, usize)> = insertion_point(&text, at)
            .map(|p| (p, table_line))
            .into_iter()
            .collect();
        if at == Some(0) {
            places.push((0, 0));
        }
        let mut next = None;
        let mut reported = places.first().map_or(table_line, |p| p.1);
        'places: for &(pos, line) in &places {
            for v in STAND_INS {
                let mut t = text.clone();
                t.insert_str(pos, &format!("{key} = {v}\n"));
                let ins = with_insertion(&inserted, line_of(&t, pos));
                match toml::from_str::<StudyFile>(&t) {
                    Ok(_) => {
                        next = Some((t, None, ins));
                        reported = line;
                        break 'places;
                    }
                    Err(e2) => match missing_key(&e2, &t) {
                        Some((k2, at2)) => {
                            let l2 = at2.map_or(0, |a| original_line(line_of(&t, a), &ins));
                            // the same key of the same table: a wrong type or the wrong
                            // table, try the next stand-in
                            if k2 == key && l2 == table_line {
                                continue;
                            }
                            // taken: the next missing key
                            next = Some((t, Some(e2), ins));
                            reported = line;
                            break 'places;
                        }
                        // another error (a wrong type for the stand-in, or one elsewhere)
                        None => continue,
                    },
                }
            }
        }
        found.push((key, reported));
        let Some((t, e2, ins)) = next else { break };
        inserted = ins;
        text = t;
        err = e2;
    }
    found.sort_by_key(|(_, l)| *l);
    found
}

/// The lines of the stand-ins after one more is inserted at line `l` (those at or below it
/// move down one).
fn with_insertion(inserted: &[usize], l: usize) -> Vec<usize> {
    let mut v: Vec<usize> = inserted
        .iter()
        .map(|&x| if x >= l { x + 1 } else { x })
        .collect();
    v.push(l);
    v
}

/// The line in the user's text of line `l` of the text with stand-ins at lines `inserted`.
fn original_line(l: usize, inserted: &[usize]) -> usize {
    l - inserted.iter().filter(|&&i| i < l).count()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn keys(text: &str) -> Vec<(String, usize)> {
        let e = toml::from_str::<StudyFile>(text).unwrap_err();
        missing_keys(text, &e)
    }

    #[test]
    fn every_missing_key_is_found_with_the_line_of_its_table() {
        // the top level's `seed`, `output` and `experiment`, and `name` of two
        // [[select.model]] tables
        let t = "[[select.model]]\nfree = [\"w1sq\"]\n\n[[select.model]]\nfree = [\"w2sq\"]\n";
        let k = keys(t);
        assert_eq!(
            k,
            vec![
                ("seed".to_string(), 0),
                ("output".to_string(), 0),
                ("experiment".to_string(), 0),
                ("name".to_string(), 1),
                ("name".to_string(), 4)
            ],
            "{k:?}"
        );
        // a table below the top level: its own line
        let t = "seed = 1\noutput = \"o\"\n[[experiment]]\ndesign = \"tn3045_x1\"\n";
        assert_eq!(keys(t), vec![("name".to_string(), 3)]);
        // an error that is not a missing key: nothing
        let t = "seed = \"one\"\n";
        assert!(keys(t).is_empty());
    }
}
