//! Reading values out of a summary's JSON and writing them for the page: every field may be
//! missing (a run of an older occam) or `null` (a non-finite number), and neither may stop
//! the page.

use super::escape::esc;
use serde_json::Value;

/// The value at a dotted path (`"jumps.effective_jumps"`), if there is one.
pub fn at<'a>(v: &'a Value, path: &str) -> Option<&'a Value> {
    path.split('.').try_fold(v, |v, k| v.get(k))
}

/// `x` with about four significant digits, in scientific notation outside [1e-3, 1e5).
pub fn sig(x: f64) -> String {
    if !x.is_finite() {
        return "–".into();
    }
    let a = x.abs();
    if a == 0.0 {
        return "0".into();
    }
    if (1e-3..1e5).contains(&a) {
        let d = (3 - a.log10().floor() as i32).max(0) as usize;
        format!("{x:.d$}")
    } else {
        format!("{x:.3e}")
    }
}

/// A JSON value for a table cell, escaped: numbers with [`sig`] (integers whole), `null` and
/// missing as `–` (the summary writes non-finite numbers as `null`), lists joined.
pub fn cell(v: Option<&Value>) -> String {
    match v {
        None | Some(Value::Null) => "–".into(),
        Some(Value::Number(n)) => match (n.as_i64(), n.as_u64()) {
            (Some(i), _) => i.to_string(),
            (_, Some(u)) => u.to_string(),
            _ => sig(n.as_f64().unwrap_or(f64::NAN)),
        },
        Some(Value::Bool(b)) => if *b { "yes" } else { "no" }.into(),
        Some(Value::String(s)) => esc(s),
        Some(Value::Array(a)) => a
            .iter()
            .map(|x| cell(Some(x)))
            .collect::<Vec<_>>()
            .join(", "),
        Some(o @ Value::Object(_)) => esc(&o.to_string()),
    }
}

/// A number with `d` decimals (ln B and ln Z, whose differences matter to the last digits),
/// [`cell`] for anything else.
pub fn dec(v: Option<&Value>, d: usize) -> String {
    match v.and_then(Value::as_f64) {
        Some(x) if x.is_finite() && x.abs() < 1e9 => format!("{x:.d$}"),
        _ => cell(v),
    }
}

/// The numbers of a JSON list (`null` as NaN); empty when it is not a list.
pub fn numbers(v: Option<&Value>) -> Vec<f64> {
    v.and_then(Value::as_array)
        .map(|a| a.iter().map(|x| x.as_f64().unwrap_or(f64::NAN)).collect())
        .unwrap_or_default()
}

/// `min – max` of the finite numbers of a list, `–` when there are none.
pub fn range(xs: &[f64]) -> String {
    let f: Vec<f64> = xs.iter().copied().filter(|x| x.is_finite()).collect();
    if f.is_empty() {
        return "–".into();
    }
    let lo = f.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = f.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if lo == hi {
        sig(lo)
    } else {
        format!("{} – {}", sig(lo), sig(hi))
    }
}

/// A table from a header (plain text) and rows of cells that are already HTML.
pub fn table(header: &[&str], rows: &[Vec<String>]) -> String {
    let mut h = String::from("<div class=\"scroll\"><table>\n<thead><tr>");
    for c in header {
        h.push_str(&format!("<th>{}</th>", esc(c)));
    }
    h.push_str("</tr></thead>\n<tbody>\n");
    for r in rows {
        h.push_str("<tr>");
        for c in r {
            h.push_str(&format!("<td>{c}</td>"));
        }
        h.push_str("</tr>\n");
    }
    h.push_str("</tbody></table></div>\n");
    h
}

/// A list of facts (`term: value`, the value already HTML), skipping those without a value.
pub fn facts(items: &[(&str, String)]) -> String {
    let mut h = String::from("<dl class=\"facts\">\n");
    for (k, v) in items {
        if v != "–" && !v.is_empty() {
            h.push_str(&format!("<dt>{}</dt><dd>{v}</dd>\n", esc(k)));
        }
    }
    h.push_str("</dl>\n");
    h
}

/// `value` wrapped to be shown as a problem.
pub fn bad(html: String) -> String {
    format!("<span class=\"bad\">{html}</span>")
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn numbers_keep_four_significant_digits() {
        assert_eq!(sig(1.0184135), "1.018");
        assert_eq!(sig(334.849), "334.8");
        assert_eq!(sig(0.0012341), "0.001234");
        assert_eq!(sig(-12345.6), "-12346");
        assert_eq!(sig(141095.378), "1.411e5");
        assert_eq!(sig(2.7e-6), "2.700e-6");
        assert_eq!(sig(0.0), "0");
        assert_eq!(sig(f64::NAN), "–");
        assert_eq!(sig(f64::INFINITY), "–");
    }

    #[test]
    fn cells_for_every_json_shape() {
        let v = json!({"a": {"b": 3}, "n": null, "f": 0.5, "s": "<b>", "l": [1, null, 2.5],
                       "t": true, "big": 18446744073709551615u64});
        assert_eq!(cell(at(&v, "a.b")), "3");
        assert_eq!(cell(at(&v, "a.c")), "–");
        assert_eq!(cell(at(&v, "n")), "–");
        assert_eq!(cell(at(&v, "f")), "0.5000");
        assert_eq!(cell(at(&v, "s")), "&lt;b&gt;");
        assert_eq!(cell(at(&v, "l")), "1, –, 2.500");
        assert_eq!(cell(at(&v, "t")), "yes");
        assert_eq!(cell(at(&v, "big")), "18446744073709551615");
        assert_eq!(cell(at(&v, "a")), "{&quot;b&quot;:3}");
    }

    #[test]
    fn decimals_for_log_evidences() {
        let v = json!([11056.4173, null, 1e300, "x"]);
        assert_eq!(dec(v.get(0), 3), "11056.417");
        assert_eq!(dec(v.get(1), 3), "–");
        assert_eq!(dec(v.get(2), 3), "1.000e300");
        assert_eq!(dec(v.get(3), 3), "x");
    }

    #[test]
    fn ranges_skip_non_finite_numbers() {
        assert_eq!(range(&[]), "–");
        assert_eq!(range(&[f64::NAN]), "–");
        assert_eq!(range(&[0.5]), "0.5000");
        assert_eq!(range(&[0.5, f64::NAN, 0.25]), "0.2500 – 0.5000");
        assert_eq!(numbers(Some(&json!([1, null]))).len(), 2);
        assert!(numbers(None).is_empty());
        assert!(numbers(Some(&json!("x"))).is_empty());
    }

    #[test]
    fn facts_leave_out_missing_values_and_escape_terms() {
        let h = facts(&[("a<", "1".into()), ("b", "–".into())]);
        assert!(h.contains("<dt>a&lt;</dt><dd>1</dd>") && !h.contains("<dt>b"));
        assert!(table(&["x"], &[]).contains("<th>x</th>"));
    }
}
