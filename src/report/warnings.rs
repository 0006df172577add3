//! Repeated warnings merged for a reader: a run over seven models can raise the same warning
//! for 14 of its 21 pairs, differing only in the pair's names and a count; printed one by
//! one they bury the answer.

/// Splits `X/Y: text` or ``model `X`: text`` into the place and the text; `None` when the
/// warning names no place.
fn place_of(w: &str) -> (Option<&str>, &str) {
    if let Some((head, rest)) = w.split_once(": ") {
        let is_place = (!head.contains(' ') && !head.is_empty())
            || (head.starts_with("model `")
                && head.ends_with('`')
                && head.matches('`').count() == 2);
        if is_place {
            return (Some(head), rest);
        }
    }
    (None, w)
}

/// The text with every backticked name and every number replaced, so that warnings that
/// differ only in which models and what counts they name compare equal.
fn shape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut quoted = false;
    let mut in_number = false;
    for c in text.chars() {
        if c == '`' {
            if !quoted {
                out.push_str("`…`");
            }
            quoted = !quoted;
            in_number = false;
            continue;
        }
        if quoted {
            continue;
        }
        let numeric = c.is_ascii_digit() || (in_number && matches!(c, '.' | 'e' | '-' | '+'));
        if numeric {
            if !in_number {
                out.push('#');
            }
            in_number = true;
        } else {
            in_number = false;
            out.push(c);
        }
    }
    out
}

/// The kind of a warning, for counting many runs' warnings: its place's shape and its text up
/// to the first `": "` that opens a list of details (a backticked name or a number: which
/// parameters sit on which bound, how far), shaped; the whole text, shaped, when none does.
/// `model `X`: the MAP is on a bound of the prior box: `w1sq` = …` and
/// `model `Y`: the MAP is on a bound of the prior box: `a_df` = …` are one kind;
/// `in-model chains: R-hat of …` and `in-model chains: effective sample size of …` are two.
fn kind(w: &str) -> String {
    let (place, text) = place_of(w);
    let details = text.match_indices(": ").map(|(i, _)| i).find(|&i| {
        text[i + 2..]
            .chars()
            .next()
            .is_some_and(|c| c == '`' || c.is_ascii_digit())
    });
    let head = details.map_or(text, |i| &text[..i]);
    format!("{}|{}", place.map(shape).unwrap_or_default(), shape(head))
}

/// The warnings, each group of the same shape (same text but for the places, names and
/// numbers) once: a single one as it is; a repeated one as its first text, prefixed with
/// how many times and where it occurred — `(14×, at A/B, A/C, …; the first shown) A/B: …`.
/// Order: by first occurrence.
///
/// ```
/// use occam::report::group_warnings;
/// let w = [
///     "X/Y: only 0 accepted jumps between `X` and `Y`".to_string(),
///     "the noise estimate is short".to_string(),
///     "X/Z: only 3 accepted jumps between `X` and `Z`".to_string(),
/// ];
/// let g = group_warnings(&w);
/// assert_eq!(g.len(), 2);
/// assert_eq!(g[0], "(2×, at X/Y and X/Z; the first shown) X/Y: only 0 accepted jumps between `X` and `Y`");
/// assert_eq!(g[1], "the noise estimate is short");
/// ```
pub fn group_warnings(warnings: &[String]) -> Vec<String> {
    let mut groups: Vec<(String, Vec<&str>)> = Vec::new();
    for w in warnings {
        let text = place_of(w).1;
        let key = shape(text);
        match groups.iter_mut().find(|(k, _)| *k == key) {
            Some((_, members)) => members.push(w),
            None => groups.push((key, vec![w])),
        }
    }
    groups
        .into_iter()
        .map(|(_, members)| {
            if members.len() == 1 {
                return members[0].to_string();
            }
            let places: Vec<&str> = members.iter().filter_map(|m| place_of(m).0).collect();
            let at = match places.as_slice() {
                [] => String::new(),
                [one] => format!(", at {one}"),
                [rest @ .., last] => format!(", at {} and {last}", rest.join(", ")),
            };
            format!("({}×{at}; the first shown) {}", members.len(), members[0])
        })
        .collect()
}

/// The warnings of many runs of one kind (a sweep's tasks: `runs[t]` the labels and warnings
/// of task `t`), each kind once (the same text up to its details, whatever the model, the
/// parameters and the numbers) with the number of runs that raised it and the first run's
/// label and text — `(in 12 of 40 tasks, first snr=5 r=0) model `X`: …` — most frequent
/// first: what a terminal can show of hundreds.
///
/// ```
/// use occam::report::group_run_warnings;
/// let runs = [
///     ("a".to_string(), vec!["model `X`: 3 evaluations refused".to_string()]),
///     ("b".to_string(), vec![]),
///     ("c".to_string(), vec!["model `X`: 7 evaluations refused".to_string(), "odd".to_string()]),
/// ];
/// let g = group_run_warnings(&runs, "tasks");
/// assert_eq!(g, [
///     "(in 2 of 3 tasks, first a) model `X`: 3 evaluations refused",
///     "(in 1 of 3 tasks, first c) odd",
/// ]);
/// ```
pub fn group_run_warnings(runs: &[(String, Vec<String>)], what: &str) -> Vec<String> {
    // (shape, runs raising it, first label, first text)
    let mut groups: Vec<(String, usize, &str, &str)> = Vec::new();
    for (label, warnings) in runs {
        let mut seen: Vec<String> = Vec::new();
        for w in warnings {
            let key = kind(w);
            if seen.contains(&key) {
                continue;
            }
            match groups.iter_mut().find(|g| g.0 == key) {
                Some(g) => g.1 += 1,
                None => groups.push((key.clone(), 1, label, w)),
            }
            seen.push(key);
        }
    }
    // stable: equal counts keep their first occurrence's order
    groups.sort_by_key(|g| std::cmp::Reverse(g.1));
    groups
        .into_iter()
        .map(|(_, n, label, text)| {
            format!("(in {n} of {} {what}, first {label}) {text}", runs.len())
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(v: &[&str]) -> Vec<String> {
        v.iter().map(|x| x.to_string()).collect()
    }

    #[test]
    fn same_shape_merges_and_different_texts_stay_apart() {
        let w = s(&[
            "a/b: no Fig. 2 (bayes_factor): no reversible-jump estimator has a value",
            "a/b: only 0 accepted jumps between `a` and `b` after burn-in (< 30): run longer",
            "model `a`: R-hat of `w1sq` is 1.2",
            "a/c: only 21 accepted jumps between `a` and `c` after burn-in (< 30): run longer",
            "b/c: only 1.5e3 accepted jumps between `b` and `c` after burn-in (< 30): run longer",
            "model `b`: R-hat of `dt1` is 1.05",
            "a/c: no Fig. 2 (bayes_factor): no reversible-jump estimator has a value",
        ]);
        let g = group_warnings(&w);
        assert_eq!(g.len(), 3, "{g:#?}");
        assert!(g[0].starts_with("(2×, at a/b and a/c; the first shown) a/b: no Fig. 2"));
        assert!(g[1].starts_with("(3×, at a/b, a/c and b/c; the first shown) a/b: only 0"));
        assert!(
            g[2].starts_with("(2×, at model `a` and model `b`; the first shown) model `a`: R-hat")
        );
        // a different text is never merged, even with the same place
        let w = s(&["a/b: first thing", "a/b: second thing"]);
        assert_eq!(group_warnings(&w), w);
        // texts without a place merge by shape alone
        let w = s(&["the noise has 3 averages", "the noise has 4 averages"]);
        assert_eq!(
            group_warnings(&w),
            s(&["(2×; the first shown) the noise has 3 averages"])
        );
        assert!(group_warnings(&[]).is_empty());
    }

    #[test]
    fn a_sentence_before_a_colon_is_not_a_place() {
        assert_eq!(
            place_of("the chains did not move: lower the scale"),
            (None, "the chains did not move: lower the scale")
        );
        assert_eq!(place_of("X/Y: text"), (Some("X/Y"), "text"));
        assert_eq!(place_of("model `a b`: text"), (Some("model `a b`"), "text"));
    }

    /// A sweep counts its tasks' warnings by kind: a MAP on a bound of any model, whichever
    /// parameters and bounds its details name, is one line (issue 52's walk: the sweep
    /// starter printed 21 lines, 17 of them this one kind).
    #[test]
    fn a_sweep_counts_warnings_by_kind_not_by_detail() {
        let bound = |m: &str, p: &str, side: &str| {
            format!(
                "model `{m}`: the MAP is on a bound of the prior box: `{p}` = 5 is on the {side} bound (hi = 5: raise hi)"
            )
        };
        let runs = [
            (
                "t0".to_string(),
                vec![bound("X", "w1sq", "upper"), bound("Y", "a_df", "lower")],
            ),
            (
                "t1".to_string(),
                vec![bound("Y", "w2sq", "lower; `a_sus` = 1 is on the upper")],
            ),
            (
                "t2".to_string(),
                s(&["model `X`: 2 likelihood evaluations fell where the loop is unstable"]),
            ),
            ("t3".to_string(), vec![]),
        ];
        let g = group_run_warnings(&runs, "tasks");
        assert_eq!(g.len(), 2, "{g:#?}");
        assert_eq!(
            g[0],
            format!(
                "(in 2 of 4 tasks, first t0) {}",
                bound("X", "w1sq", "upper")
            )
        );
        assert!(g[1].starts_with("(in 1 of 4 tasks, first t2) model `X`: 2 likelihood"));
        // a different kind of the same place stays apart
        let runs = [(
            "t0".to_string(),
            s(&["a/b: first thing: x", "a/b: second thing: x"]),
        )];
        assert_eq!(group_run_warnings(&runs, "tasks").len(), 2);
        // texts that share only an opening label stay apart: the details start at a name or a
        // number, not at any colon
        let chains = |t: &str, m: &str| {
            (
                t.to_string(),
                vec![
                    format!(
                        "model `{m}`: in-model chains: R-hat of `w1sq` is 1.02 > 1.01: run longer"
                    ),
                    format!(
                        "model `{m}`: in-model chains: effective sample size of `dt1` is 80 < 100: run longer"
                    ),
                ],
            )
        };
        let g = group_run_warnings(&[chains("t0", "X"), chains("t1", "Y")], "tasks");
        assert_eq!(g.len(), 2, "{g:#?}");
        assert!(g[0].starts_with("(in 2 of 2 tasks, first t0) model `X`: in-model chains: R-hat"));
        assert!(g[1].contains("effective sample size"), "{g:#?}");
    }
}
