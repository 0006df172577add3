//! An error and its causes as one line a person reads: each cause once.

/// `e` with each cause of its chain appended (`a: b: c`, as anyhow's `{:#}`), leaving out a
/// cause whose text the line already holds: several error types put their cause in their
/// own message and also return it as `source`, and `{:#}` then said it twice (`d.csv: a
/// directory, …: a directory, …`).
///
/// ```
/// let e = anyhow::anyhow!("d.csv: a directory").context("preparing the data");
/// assert_eq!(occam::jobs::error_text(&e), "preparing the data: d.csv: a directory");
/// ```
pub fn error_text(e: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if text.is_empty() || line.contains(&text) {
            continue;
        }
        if !line.is_empty() {
            line.push_str(": ");
        }
        line.push_str(&text);
    }
    line
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, thiserror::Error)]
    #[error("cannot read d.csv: {source}")]
    struct Said {
        #[source]
        source: std::io::Error,
    }

    #[test]
    fn a_cause_already_in_the_message_is_not_repeated() {
        let io = std::io::Error::other("a directory, not a regular file");
        let e = anyhow::Error::new(Said { source: io }).context("preparing the data of s.toml");
        assert_eq!(
            error_text(&e),
            "preparing the data of s.toml: cannot read d.csv: a directory, not a regular file"
        );
        // anyhow's own form says it twice
        assert_eq!(format!("{e:#}").matches("a directory").count(), 2);
        let plain = anyhow::anyhow!("one").context("two");
        assert_eq!(error_text(&plain), format!("{plain:#}"));
    }
}
