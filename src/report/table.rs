//! A small table of strings that renders as aligned plain text or as Markdown.

use super::error::ReportError;
use std::fmt;

/// A table: one header row and any number of body rows, all cells strings.
///
/// Columns whose body cells all look like numbers (including `fmt_pm` output such as
/// `(-1.29998 ± 0.00021)e-6`, and empty cells) are right-aligned so digits line up; other
/// columns are left-aligned.
///
/// ```
/// use occam::report::Table;
///
/// let mut t = Table::new(["Method", "B_XY"]);
/// t.push_row(["RJMCMC", "0.309"]).unwrap();
/// t.push_row(["SBIC", "0.768"]).unwrap();
/// assert_eq!(t.to_text(), "Method   B_XY\n------  -----\nRJMCMC  0.309\nSBIC    0.768\n");
/// assert!(t.push_row(["LF"]).is_err());
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Table {
    header: Vec<String>,
    rows: Vec<Vec<String>>,
}

impl Table {
    /// A table with the given column headers and no rows.
    pub fn new<S: Into<String>>(header: impl IntoIterator<Item = S>) -> Self {
        Table {
            header: header.into_iter().map(Into::into).collect(),
            rows: Vec::new(),
        }
    }

    /// Appends a row; it must have exactly one cell per header column.
    pub fn push_row<S: Into<String>>(
        &mut self,
        row: impl IntoIterator<Item = S>,
    ) -> Result<(), ReportError> {
        let row: Vec<String> = row.into_iter().map(Into::into).collect();
        if row.len() != self.header.len() {
            return Err(ReportError::RowWidth {
                row: self.rows.len(),
                expected: self.header.len(),
                found: row.len(),
            });
        }
        self.rows.push(row);
        Ok(())
    }

    /// The column headers.
    pub fn header(&self) -> &[String] {
        &self.header
    }

    /// The body rows.
    pub fn rows(&self) -> &[Vec<String>] {
        &self.rows
    }

    fn numeric_columns(&self) -> Vec<bool> {
        (0..self.header.len())
            .map(|c| {
                let mut any = false;
                let all = self.rows.iter().all(|r| {
                    let cell = r[c].trim();
                    any |= !cell.is_empty();
                    cell.is_empty() || looks_numeric(cell)
                });
                all && any
            })
            .collect()
    }

    fn widths(&self) -> Vec<usize> {
        (0..self.header.len())
            .map(|c| {
                self.rows
                    .iter()
                    .map(|r| width(&r[c]))
                    .chain([width(&self.header[c])])
                    .max()
                    .unwrap_or(0)
            })
            .collect()
    }

    /// Plain text: columns separated by two spaces, a dashed rule under the header, trailing
    /// spaces trimmed, one `\n` after every line. An empty header gives an empty string.
    pub fn to_text(&self) -> String {
        if self.header.is_empty() {
            return String::new();
        }
        let numeric = self.numeric_columns();
        let widths = self.widths();
        let mut out = String::new();
        let mut line = |cells: &mut dyn Iterator<Item = String>| {
            let l: Vec<String> = cells.collect();
            out.push_str(l.join("  ").trim_end());
            out.push('\n');
        };
        let pad = |c: usize, s: &str| {
            let fill = " ".repeat(widths[c] - width(s));
            if numeric[c] {
                format!("{fill}{s}")
            } else {
                format!("{s}{fill}")
            }
        };
        line(&mut self.header.iter().enumerate().map(|(c, h)| pad(c, h)));
        line(&mut widths.iter().map(|&w| "-".repeat(w)));
        for r in &self.rows {
            line(&mut r.iter().enumerate().map(|(c, s)| pad(c, s)));
        }
        out
    }

    /// GitHub-flavoured Markdown, with `---:` alignment markers on numeric columns and `|`
    /// inside cells escaped. An empty header gives an empty string.
    pub fn to_markdown(&self) -> String {
        if self.header.is_empty() {
            return String::new();
        }
        let numeric = self.numeric_columns();
        let widths: Vec<usize> = self.widths().into_iter().map(|w| w.max(3)).collect();
        let esc = |s: &str| s.replace('|', "\\|");
        let row = |cells: &[String]| {
            let parts: Vec<String> = cells
                .iter()
                .enumerate()
                .map(|(c, s)| {
                    let s = esc(s);
                    let fill = " ".repeat(widths[c].saturating_sub(width(&s)));
                    if numeric[c] {
                        format!("{fill}{s}")
                    } else {
                        format!("{s}{fill}")
                    }
                })
                .collect();
            format!("| {} |\n", parts.join(" | "))
        };
        let mut out = row(&self.header);
        let rule: Vec<String> = widths
            .iter()
            .zip(&numeric)
            .map(|(&w, &n)| {
                if n {
                    format!("{}:", "-".repeat(w - 1))
                } else {
                    "-".repeat(w)
                }
            })
            .collect();
        out.push_str(&format!("| {} |\n", rule.join(" | ")));
        for r in &self.rows {
            out.push_str(&row(r));
        }
        out
    }
}

impl fmt::Display for Table {
    /// Same as [`Table::to_text`].
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.to_text())
    }
}

/// Display width in characters (`±`, `−` and Greek letters count one each).
fn width(s: &str) -> usize {
    s.chars().count()
}

/// True for `0.309`, `-1.2e-6`, `12%`, `1.9630 ± 0.0010`, `(-1.29998 ± 0.00021)e-6`, `NaN`.
fn looks_numeric(cell: &str) -> bool {
    let s: String = cell
        .chars()
        .filter(|c| !c.is_whitespace())
        .map(|c| if c == '−' { '-' } else { c })
        .collect();
    let s = s.strip_suffix('%').unwrap_or(&s);
    let number = |t: &str| t.parse::<f64>().is_ok();
    let value_pm = |t: &str| match t.split_once('±') {
        Some((v, e)) => number(v) && number(e),
        None => number(t),
    };
    match s.strip_prefix('(').and_then(|t| t.split_once(')')) {
        Some((inner, tail)) => {
            let tail_ok = tail.is_empty()
                || tail
                    .strip_prefix(['e', 'E'])
                    .is_some_and(|x| x.parse::<i32>().is_ok());
            tail_ok && value_pm(inner)
        }
        None => value_pm(s),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn example() -> Table {
        let mut t = Table::new(["Parameter", "estimate", "true"]);
        t.push_row(["ω₁²", "(-1.29998 ± 0.00021)e-6", "-1.3e-6"])
            .unwrap();
        t.push_row(["A_df", "0.8123 ± 0.0034", "0.81"]).unwrap();
        t
    }

    #[test]
    fn text_aligns_numbers_right_and_words_left() {
        let expected = "\
Parameter                 estimate     true
---------  -----------------------  -------
ω₁²        (-1.29998 ± 0.00021)e-6  -1.3e-6
A_df               0.8123 ± 0.0034     0.81
";
        assert_eq!(example().to_text(), expected);
        assert_eq!(example().to_string(), expected);
    }

    #[test]
    fn markdown_marks_numeric_columns_and_escapes_pipes() {
        let mut t = example();
        t.push_row(["a|b", "", "1"]).unwrap();
        let expected = "\
| Parameter |                estimate |    true |
| --------- | ----------------------: | ------: |
| ω₁²       | (-1.29998 ± 0.00021)e-6 | -1.3e-6 |
| A_df      |         0.8123 ± 0.0034 |    0.81 |
| a\\|b      |                         |       1 |
";
        assert_eq!(t.to_markdown(), expected);
    }

    #[test]
    fn wrong_row_width_is_a_typed_error() {
        let mut t = example();
        let e = t.push_row(["x", "1"]).unwrap_err();
        assert!(matches!(
            e,
            ReportError::RowWidth {
                row: 2,
                expected: 3,
                found: 2
            }
        ));
        assert_eq!(t.rows().len(), 2);
        assert_eq!(Table::new(Vec::<String>::new()).to_text(), "");
    }

    #[test]
    fn numeric_detection() {
        for s in [
            "0.309",
            "-1.2e-6",
            "1.9630 ± 0.0010",
            "(-1 ± 2)e-6",
            "NaN",
            "-inf",
            "12%",
        ] {
            assert!(looks_numeric(s), "{s}");
        }
        for s in [
            "RJMCMC",
            "strong evidence for X",
            "e",
            "-",
            "n/a",
            "1 s",
            "fan1",
            "(1)x",
        ] {
            assert!(!looks_numeric(s), "{s}");
        }
    }
}
