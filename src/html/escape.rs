//! Making text and figures safe to put into the page: user text (model names, warnings, the
//! study) is escaped, figures lose anything executable.

/// `s` with the five characters that matter to HTML and XML replaced by entities.
pub fn esc(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            '\'' => o.push_str("&#39;"),
            // control characters are not allowed in XHTML; a damaged file must not break the page
            c if c.is_control() && c != '\n' && c != '\t' && c != '\r' => o.push('\u{FFFD}'),
            c => o.push(c),
        }
    }
    o
}

/// Case-insensitive (ASCII) position of `needle` in `hay` at or after `from`.
fn find_ci(hay: &str, needle: &str, from: usize) -> Option<usize> {
    let h = hay.as_bytes();
    let n = needle.as_bytes();
    if n.is_empty() || h.len() < n.len() {
        return None;
    }
    (from..=h.len() - n.len()).find(|&i| h[i..i + n.len()].eq_ignore_ascii_case(n))
}

/// The `<svg …>…</svg>` element of an SVG file, ready to inline: the XML prolog and doctype
/// before it dropped, and every `<script>` element (or an unterminated `<script` tag) and
/// `<foreignObject>` removed. Plotters writes neither; this is defence in depth for a file
/// someone edited. `None` when the text holds no `<svg` element.
pub fn inline_svg(text: &str) -> Option<String> {
    let start = find_ci(text, "<svg", 0)?;
    let end = text
        .to_ascii_lowercase()
        .rfind("</svg>")
        .map_or(text.len(), |e| e + "</svg>".len());
    if end <= start {
        return None;
    }
    let mut s = text[start..end].to_string();
    for tag in ["script", "foreignobject"] {
        // repeated from the start: removing one element may join the pieces of another
        while let Some(a) = find_ci(&s, &format!("<{tag}"), 0) {
            let close = format!("</{tag}");
            let b = match find_ci(&s, &close, a) {
                Some(c) => s[c..].find('>').map_or(s.len(), |g| c + g + 1),
                None => s[a..].find('>').map_or(s.len(), |g| a + g + 1),
            };
            s.replace_range(a..b, "");
        }
    }
    Some(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escapes_markup_quotes_and_control_characters() {
        assert_eq!(
            esc("<script>alert('x') & \"y\"</script>"),
            "&lt;script&gt;alert(&#39;x&#39;) &amp; &quot;y&quot;&lt;/script&gt;"
        );
        assert_eq!(esc(""), "");
        assert_eq!(esc("a\u{1}b\nc"), "a\u{FFFD}b\nc");
        assert_eq!(esc("ω² ∈ [−5e−6, 5e−6]"), "ω² ∈ [−5e−6, 5e−6]");
    }

    #[test]
    fn svg_keeps_its_element_and_loses_prolog_and_scripts() {
        let t = "<?xml version=\"1.0\"?>\n<!DOCTYPE svg>\n<svg width=\"1\"><rect/>\
                 <SCRIPT type=\"x\">alert(1)</Script><text>a</text></svg>\n";
        assert_eq!(
            inline_svg(t).unwrap(),
            "<svg width=\"1\"><rect/><text>a</text></svg>"
        );
        // pieces that join into a new script once the inner one is gone
        let t = "<svg><scr<script></script>ipt>alert(1)</script></svg>";
        let s = inline_svg(t).unwrap();
        assert!(!s.to_ascii_lowercase().contains("<script"), "{s}");
        // unterminated
        let s = inline_svg("<svg><script src=x></svg>").unwrap();
        assert!(!s.contains("script"), "{s}");
        let s = inline_svg("<svg><foreignObject><p>x</p></foreignObject></svg>").unwrap();
        assert_eq!(s, "<svg></svg>");
    }

    #[test]
    fn text_without_an_svg_element_is_refused() {
        assert!(inline_svg("").is_none());
        assert!(inline_svg("PNG\u{0}binary").is_none());
        assert!(inline_svg("</svg><svg").is_none());
    }
}
