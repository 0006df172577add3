//! "Did you mean …?" for an unknown key: the closest of the keys a table accepts.

/// The accepted key closest to `unknown` (Damerau–Levenshtein), when it is close enough to be a
/// likely typo: at most 2 edits, and at most a third of the key's length for short keys.
pub fn closest<'a>(unknown: &str, accepted: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    let limit = (unknown.chars().count() / 3).clamp(1, 2);
    accepted
        .into_iter()
        .map(|k| (strsim::damerau_levenshtein(unknown, k), k))
        .filter(|&(d, _)| d <= limit)
        .min_by_key(|&(d, _)| d)
        .map(|(_, k)| k)
}

/// Adds "; did you mean `key`?" to a TOML error that names an unknown field and the accepted
/// ones (`unknown field `x`, expected one of `a`, `b`` or `expected `a` or `b``), when one of
/// them is a likely typo of it; any other message is returned unchanged.
pub fn did_you_mean(msg: &str) -> String {
    let Some(rest) = msg.split("unknown field `").nth(1) else {
        return msg.to_string();
    };
    let Some((unknown, expected)) = rest.split_once('`') else {
        return msg.to_string();
    };
    let accepted: Vec<&str> = expected
        .split('`')
        .skip(1)
        .step_by(2)
        .take_while(|s| !s.contains('\n'))
        .collect();
    match closest(unknown, accepted) {
        Some(k) => format!("{}; did you mean `{k}`?", msg.trim_end()),
        None => msg.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn suggests_a_near_key_and_nothing_for_a_far_one() {
        let m = "TOML parse error at line 3, column 2\n  |\n3 | [analysys]\n  |  ^^^^^^^^\nunknown field `analysys`, expected one of `seed`, `output`, `analysis`, `prior`";
        assert!(did_you_mean(m).ends_with("did you mean `analysis`?"));
        let m = "unknown field `itrations`, expected one of `iterations`, `burn_in`";
        assert!(did_you_mean(m).ends_with("did you mean `iterations`?"));
        let m = "unknown field `fs`, expected `band` or `window`";
        assert_eq!(did_you_mean(m), m);
        let m = "unknown field `completely_else`, expected one of `seed`, `output`";
        assert_eq!(did_you_mean(m), m);
        assert_eq!(did_you_mean("invalid type: string"), "invalid type: string");
        assert_eq!(closest("chians", ["chains", "burn_in"]), Some("chains"));
        assert_eq!(closest("x", ["y"]), Some("y"));
        assert_eq!(closest("ab", ["xy"]), None);
    }
}
