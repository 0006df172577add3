//! The run's text tables (`table.md`, `table.txt`) as HTML tables: the page shows exactly the
//! numbers the command printed.

use super::escape::esc;

/// A piece of a table file: a table, or a line of text between tables.
#[derive(Debug, Clone, PartialEq)]
pub enum Block {
    Table {
        header: Vec<String>,
        rows: Vec<Vec<String>>,
        /// Per column: right-aligned (numbers).
        right: Vec<bool>,
    },
    Text(String),
    /// Consecutive Markdown list items (`- …`), without their markers, each with its depth
    /// (0 at the margin; one more per indent of two or more spaces beyond its parent's).
    List(Vec<(usize, String)>),
}

/// Splits a Markdown pipe-table row into its cells (`\|` is a literal bar).
fn md_cells(line: &str) -> Vec<String> {
    let inner = line.trim().trim_start_matches('|');
    let inner = inner.strip_suffix('|').unwrap_or(inner);
    let mut cells = vec![String::new()];
    let mut chars = inner.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '\\' if chars.peek() == Some(&'|') => {
                chars.next();
                cells.last_mut().unwrap().push('|');
            }
            '|' => cells.push(String::new()),
            c => cells.last_mut().unwrap().push(c),
        }
    }
    cells.into_iter().map(|c| c.trim().to_string()).collect()
}

fn is_md_separator(cells: &[String]) -> bool {
    !cells.is_empty()
        && cells.iter().all(|c| {
            let t = c.trim_matches(':');
            !t.is_empty() && t.chars().all(|x| x == '-')
        })
}

/// Parses a Markdown file of pipe tables and text lines.
pub fn parse_markdown(text: &str) -> Vec<Block> {
    let lines: Vec<&str> = text.lines().collect();
    let mut out = Vec::new();
    // the indents of the open list levels, outermost first
    let mut indents: Vec<usize> = Vec::new();
    let mut i = 0;
    while i < lines.len() {
        let l = lines[i];
        if l.trim_start().starts_with('|') && i + 1 < lines.len() {
            let sep = md_cells(lines[i + 1]);
            if is_md_separator(&sep) {
                let header = md_cells(l);
                let right = sep.iter().map(|c| c.ends_with(':')).collect();
                let mut rows = Vec::new();
                i += 2;
                while i < lines.len() && lines[i].trim_start().starts_with('|') {
                    rows.push(md_cells(lines[i]));
                    i += 1;
                }
                out.push(Block::Table {
                    header,
                    rows,
                    right,
                });
                continue;
            }
        }
        // a list item joins the list just before it, else starts one; indented further than
        // the item before it, it is a sub-item of that one
        if let Some(item) = l.trim_start().strip_prefix("- ") {
            let item = item.trim_end().to_string();
            let indent = l.len() - l.trim_start().len();
            match out.last_mut() {
                Some(Block::List(items)) => {
                    indents.retain(|&i| i < indent);
                    items.push((indents.len(), item));
                    indents.push(indent);
                }
                _ => {
                    indents = vec![indent];
                    out.push(Block::List(vec![(0, item)]));
                }
            }
        } else if !l.trim().is_empty() {
            out.push(Block::Text(l.trim_end().to_string()));
        }
        i += 1;
    }
    out
}

/// The columns of a rule line (`-----  ---  ----`): the char offsets where each run of dashes
/// starts; `None` when the line is not a rule.
fn rule_columns(line: &str) -> Option<Vec<usize>> {
    let t = line.trim_end();
    if t.is_empty() || !t.chars().all(|c| c == '-' || c == ' ') || !t.starts_with('-') {
        return None;
    }
    let chars: Vec<char> = t.chars().collect();
    Some(
        (0..chars.len())
            .filter(|&k| chars[k] == '-' && (k == 0 || chars[k - 1] == ' '))
            .collect(),
    )
}

/// The cells of a fixed-width line at the given column starts.
fn cut(line: &str, starts: &[usize]) -> Vec<String> {
    let chars: Vec<char> = line.chars().collect();
    starts
        .iter()
        .enumerate()
        .map(|(k, &a)| {
            let b = starts
                .get(k + 1)
                .copied()
                .unwrap_or(chars.len())
                .min(chars.len());
            let a = a.min(b);
            chars[a..b].iter().collect::<String>().trim().to_string()
        })
        .collect()
}

/// Whether `line` is laid out on the columns `starts` (the separator of the text tables is at
/// least two spaces).
fn is_row(line: &str, starts: &[usize]) -> bool {
    let chars: Vec<char> = line.chars().collect();
    starts
        .iter()
        .filter(|&&s| s >= 2 && s < chars.len())
        .all(|&s| chars[s - 1] == ' ' && chars[s - 2] == ' ')
}

/// Whether a cell reads as a number (for right alignment).
fn numeric(c: &str) -> bool {
    let c = c.trim();
    !c.is_empty()
        && c.chars().next().is_some_and(|x| {
            x.is_ascii_digit() || x == '-' || x == '−' || x == '(' || x == '+' || x == '.'
        })
        && c.chars().any(|x| x.is_ascii_digit())
}

/// Parses a fixed-width text table file (a header line, a rule of dashes, rows up to a blank
/// line), keeping the other lines as text.
pub fn parse_text(text: &str) -> Vec<Block> {
    let lines: Vec<&str> = text.lines().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < lines.len() {
        let l = lines[i];
        if let Some(starts) = lines.get(i + 1).and_then(|r| rule_columns(r))
            && !l.trim().is_empty()
        {
            let header = cut(l, &starts);
            let mut rows = Vec::new();
            i += 2;
            while i < lines.len() && !lines[i].trim().is_empty() {
                // text right after the table (no blank line between) is not a row: a row
                // has two spaces before every column it reaches
                if !is_row(lines[i], &starts) {
                    break;
                }
                rows.push(cut(lines[i], &starts));
                i += 1;
            }
            let right = (0..header.len())
                .map(|k| {
                    let cells: Vec<&String> = rows.iter().filter_map(|r| r.get(k)).collect();
                    let filled: Vec<&&String> = cells
                        .iter()
                        .filter(|c| !c.is_empty() && c.as_str() != "–")
                        .collect();
                    !filled.is_empty() && filled.iter().all(|c| numeric(c))
                })
                .collect();
            out.push(Block::Table {
                header,
                rows,
                right,
            });
            continue;
        }
        if !l.trim().is_empty() {
            out.push(Block::Text(l.trim_end().to_string()));
        }
        i += 1;
    }
    out
}

/// A text column with a cell longer than this (characters) is prose: it wraps.
const WRAP_CHARS: usize = 60;

/// The blocks as HTML (every cell escaped).
pub fn to_html(blocks: &[Block]) -> String {
    let mut h = String::new();
    for b in blocks {
        match b {
            Block::Text(t) => {
                h.push_str(&format!("<p class=\"tabletext\">{}</p>\n", esc(t)));
            }
            Block::List(items) => {
                h.push_str("<ul class=\"tabletext\">\n");
                let mut depth = 0;
                for (k, (d, t)) in items.iter().enumerate() {
                    // a sub-list opens inside the item before it, which stays open until then
                    if k > 0 {
                        if *d > depth {
                            h.push_str("\n<ul>\n");
                        } else {
                            h.push_str("</li>\n");
                        }
                    }
                    for _ in *d..depth {
                        h.push_str("</ul></li>\n");
                    }
                    depth = *d;
                    h.push_str(&format!("<li>{}", esc(t)));
                }
                h.push_str("</li>\n");
                for _ in 0..depth {
                    h.push_str("</ul></li>\n");
                }
                h.push_str("</ul>\n");
            }
            Block::Table {
                header,
                rows,
                right,
            } => {
                // a column of prose (notes) wraps, so that the table fits the page and no note
                // is read by scrolling sideways; numbers and names stay on one line
                let prose: Vec<bool> = (0..header.len())
                    .map(|k| {
                        rows.iter()
                            .any(|r| r.get(k).is_some_and(|c| c.chars().count() > WRAP_CHARS))
                    })
                    .collect();
                let cls = |k: usize| {
                    if right.get(k).copied().unwrap_or(false) {
                        " class=\"num\""
                    } else if prose.get(k).copied().unwrap_or(false) {
                        " class=\"wrap\""
                    } else {
                        ""
                    }
                };
                h.push_str("<div class=\"scroll\"><table class=\"file\">\n<thead><tr>");
                for (k, c) in header.iter().enumerate() {
                    h.push_str(&format!("<th{}>{}</th>", cls(k), esc(c)));
                }
                h.push_str("</tr></thead>\n<tbody>\n");
                for r in rows {
                    h.push_str("<tr>");
                    for (k, c) in r.iter().enumerate() {
                        h.push_str(&format!("<td{}>{}</td>", cls(k), esc(c)));
                    }
                    h.push_str("</tr>\n");
                }
                h.push_str("</tbody></table></div>\n");
            }
        }
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `- …` lines are a list (one per run of them), not raw text (issue 52: the report showed
    /// select's table.md notes as "- …").
    #[test]
    fn markdown_list_items_are_a_list() {
        let b = parse_markdown("head\n- one <a>\n- two\ntext\n- three\n");
        assert_eq!(
            b,
            vec![
                Block::Text("head".into()),
                Block::List(vec![(0, "one <a>".into()), (0, "two".into())]),
                Block::Text("text".into()),
                Block::List(vec![(0, "three".into())]),
            ]
        );
        let h = to_html(&b);
        assert!(h.contains("<li>one &lt;a&gt;</li>\n<li>two</li>"), "{h}");
        assert!(!h.contains("- one"), "{h}");
    }

    /// Indented items are a sub-list of the item above them, as select's table.md writes its
    /// models and its answer (issue 52: the report showed them flat).
    #[test]
    fn indented_list_items_nest() {
        let md = "- models: 2\n    - X 7 free\n    - Y 5 free\n- answer: Y\n    - ln B = 1\n        - deep\n- last\n";
        let b = parse_markdown(md);
        let items = |v: &[(usize, &str)]| v.iter().map(|&(d, t)| (d, t.to_string())).collect();
        assert_eq!(
            b,
            vec![Block::List(items(&[
                (0, "models: 2"),
                (1, "X 7 free"),
                (1, "Y 5 free"),
                (0, "answer: Y"),
                (1, "ln B = 1"),
                (2, "deep"),
                (0, "last"),
            ]))]
        );
        let h = to_html(&b);
        assert_eq!(
            h,
            "<ul class=\"tabletext\">\n<li>models: 2\n<ul>\n<li>X 7 free</li>\n<li>Y 5 free</li>\n</ul></li>\n<li>answer: Y\n<ul>\n<li>ln B = 1\n<ul>\n<li>deep</li>\n</ul></li>\n</ul></li>\n<li>last</li>\n</ul>\n"
        );
        // a list that ends deep closes every level
        let h = to_html(&parse_markdown("- a\n  - b\n"));
        assert_eq!(
            h,
            "<ul class=\"tabletext\">\n<li>a\n<ul>\n<li>b</li>\n</ul></li>\n</ul>\n"
        );
    }

    #[test]
    fn markdown_tables_keep_cells_alignment_and_escaped_bars() {
        let md = "| name | ln B |\n| ---- | ---: |\n| a\\|b | -1.5 |\n| <x> |  |\n";
        let b = parse_markdown(md);
        assert_eq!(
            b,
            vec![Block::Table {
                header: vec!["name".into(), "ln B".into()],
                rows: vec![
                    vec!["a|b".into(), "-1.5".into()],
                    vec!["<x>".into(), "".into()]
                ],
                right: vec![false, true],
            }]
        );
        let h = to_html(&b);
        assert!(h.contains("<td>&lt;x&gt;</td>") && h.contains("<td class=\"num\">-1.5</td>"));
    }

    #[test]
    fn a_column_of_notes_wraps_and_numbers_and_names_do_not() {
        let note =
            "assumes a Gaussian posterior around the MAP, the prior box ignored (MAP 0.3 σ inside)";
        let md = format!(
            "| estimator | ln B | note |\n| --- | ---: | --- |\n| Laplace-Fisher raw | -0.264 | {note} |\n| RJMCMC visits | -1.213 |  |\n"
        );
        let h = to_html(&parse_markdown(&md));
        assert!(
            h.contains(&format!("<td class=\"wrap\">{note}</td>")),
            "{h}"
        );
        assert!(h.contains("<td class=\"wrap\"></td>"), "{h}");
        assert!(
            h.contains("<td>Laplace-Fisher raw</td><td class=\"num\">-0.264</td>"),
            "{h}"
        );
    }

    #[test]
    fn text_tables_are_cut_at_the_rule_columns_and_text_lines_stay_text() {
        let t = "2 realisations per point\n\npair X/Y\n\
                 axis  reference ln B [16, 84]  agree\n\
                 ----  -----------------------  -----\n\
                 \u{20} 20  -0.015 [-0.04, 0.01]      1.00\n\
                 3000  –                        0.50\n\
                 Y wins from 3000 on\n";
        let b = parse_text(t);
        assert_eq!(b.len(), 4, "{b:?}");
        assert_eq!(b[0], Block::Text("2 realisations per point".into()));
        assert_eq!(b[1], Block::Text("pair X/Y".into()));
        match &b[2] {
            Block::Table {
                header,
                rows,
                right,
            } => {
                assert_eq!(header, &["axis", "reference ln B [16, 84]", "agree"]);
                assert_eq!(rows[0], ["20", "-0.015 [-0.04, 0.01]", "1.00"]);
                assert_eq!(rows[1], ["3000", "–", "0.50"]);
                assert_eq!(right, &[true, true, true]);
            }
            x => panic!("{x:?}"),
        }
        assert_eq!(b[3], Block::Text("Y wins from 3000 on".into()));
    }

    #[test]
    fn empty_and_tableless_files() {
        assert!(parse_text("").is_empty());
        assert!(parse_markdown("").is_empty());
        assert_eq!(
            parse_text("just a line"),
            vec![Block::Text("just a line".into())]
        );
        // a rule with no header above it is text
        assert_eq!(parse_text("\n----\n").len(), 1);
        // a table with no rows
        match &parse_markdown("| a |\n|---|\n")[0] {
            Block::Table { rows, .. } => assert!(rows.is_empty()),
            x => panic!("{x:?}"),
        }
        assert_eq!(to_html(&[]), "");
    }
}
