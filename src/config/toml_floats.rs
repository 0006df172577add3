//! Floats of serialised TOML in scientific form where the fixed form is long: the `toml` crate
//! writes every float with Rust's `Display`, which never uses an exponent (`1e-14` comes out as
//! `0.00000000000001`, `5e300` as three hundred digits).

/// Below this magnitude (and at or above [`LARGE`]) a float is written as `1e-14`.
const SMALL: f64 = 1e-3;
/// See [`SMALL`].
const LARGE: f64 = 1e6;

/// `text` (TOML as the `toml` crate writes it) with every float value of magnitude below 10⁻³
/// or from 10⁶ up rewritten in the shortest scientific form that reads back to the same `f64`,
/// bit for bit. Strings, comments and keys are left alone; a rewrite that would not read back
/// exactly is not made.
pub(crate) fn scientific_floats(text: &str) -> String {
    let b = text.as_bytes();
    let mut out = String::with_capacity(text.len());
    let (mut i, mut copied) = (0, 0);
    while i < b.len() {
        match b[i] {
            b'#' => i = line_end(b, i),
            b'"' | b'\'' => i = string_end(b, i),
            c if c.is_ascii_digit() || c == b'-' || c == b'+' => {
                let start = i;
                let mut j = i;
                while j < b.len() && (b[j].is_ascii_alphanumeric() || b"_.+-".contains(&b[j])) {
                    j += 1;
                }
                let value_position = start == 0 || b" \t=[,{".contains(&b[start - 1]);
                let is_key = text[j..].trim_start_matches([' ', '\t']).starts_with('=');
                if let Some(sci) = (value_position && !is_key)
                    .then(|| scientific(&text[start..j]))
                    .flatten()
                {
                    out.push_str(&text[copied..start]);
                    out.push_str(&sci);
                    copied = j;
                }
                i = j;
            }
            _ => i += 1,
        }
    }
    out.push_str(&text[copied..]);
    out
}

/// The scientific form of a fixed-form float token (`-0.00001` → `-1e-5`) when its magnitude
/// calls for one and it reads back exactly; `None` for anything else.
fn scientific(token: &str) -> Option<String> {
    let digits = token.trim_start_matches(['+', '-']);
    let (int, frac) = digits.split_once('.')?;
    let all_digits = |s: &str| !s.is_empty() && s.bytes().all(|c| c.is_ascii_digit());
    if !(all_digits(int) && all_digits(frac)) {
        return None;
    }
    let v: f64 = token.parse().ok()?;
    if v == 0.0 || !v.is_finite() || (SMALL..LARGE).contains(&v.abs()) {
        return None;
    }
    let sci = format!("{v:e}");
    (sci.parse::<f64>().ok()?.to_bits() == v.to_bits()).then_some(sci)
}

/// The index of the line break ending the line that `i` is on (or the end).
fn line_end(b: &[u8], i: usize) -> usize {
    b[i..]
        .iter()
        .position(|&c| c == b'\n')
        .map_or(b.len(), |k| i + k)
}

/// The index just past the string that starts at `i` (basic or literal, one-line or
/// multi-line), or the end of the text if it is not closed.
fn string_end(b: &[u8], i: usize) -> usize {
    let q = b[i];
    let triple = b.len() >= i + 3 && b[i + 1] == q && b[i + 2] == q;
    let mut j = if triple { i + 3 } else { i + 1 };
    while j < b.len() {
        if q == b'"' && b[j] == b'\\' {
            j += 2;
            continue;
        }
        if b[j] == q && (!triple || (b.len() >= j + 3 && b[j + 1] == q && b[j + 2] == q)) {
            // a multi-line string may end in up to two more quotes of its own
            let mut end = if triple { j + 3 } else { j + 1 };
            while triple && end < b.len() && b[end] == q && end < j + 5 {
                end += 1;
            }
            return end;
        }
        if !triple && b[j] == b'\n' {
            return j;
        }
        j += 1;
    }
    b.len()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_float_values_outside_strings_and_comments_change() {
        let t = "a = 0.00000000000001\nb = [0.01, 3.0, -0.000002]\n\"0.00001\" = 2.0\ns = \"x = 0.00001\"\nl = '0.00001'\n# 0.00001\nm = \"\"\"\n0.00001\"\"\"\nbig = 123456789.0\nn = 12\nk = { lo = -0.0001 }\n";
        let r = scientific_floats(t);
        assert_eq!(
            r,
            "a = 1e-14\nb = [0.01, 3.0, -2e-6]\n\"0.00001\" = 2.0\ns = \"x = 0.00001\"\nl = '0.00001'\n# 0.00001\nm = \"\"\"\n0.00001\"\"\"\nbig = 1.23456789e8\nn = 12\nk = { lo = -1e-4 }\n"
        );
    }

    #[test]
    fn escaped_quotes_do_not_end_a_string() {
        let t = "s = \"a \\\" 0.00001\"\nv = 0.00001\n";
        assert_eq!(scientific_floats(t), "s = \"a \\\" 0.00001\"\nv = 1e-5\n");
    }

    #[test]
    fn every_rewrite_reads_back_bit_for_bit() {
        for v in [
            1e-14f64,
            1.0000000000000002e-300,
            6.02214076e23,
            -9.87654321e-7,
            5e-324,
        ] {
            // as the toml crate writes them: integral values with `.0`
            let fixed = if v % 1.0 == 0.0 {
                format!("{v}.0")
            } else {
                format!("{v}")
            };
            let s = scientific_floats(&format!("x = {fixed}\n"));
            let back: toml::Table = s.parse().unwrap();
            assert_eq!(back["x"].as_float().unwrap().to_bits(), v.to_bits(), "{s}");
            assert!(s.contains('e'), "{s}");
        }
    }
}
