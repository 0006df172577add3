//! `[a, b]` pairs of a study file read as exactly two numbers. serde reads a fixed-size array
//! from the first elements of a longer TOML array and drops the rest without a word
//! (`gaps = [[1, 2, 3]]` was a gap from 1 to 2 s), so pairs are read as lists and their
//! length checked; the error names the numbers given.

use serde::Deserialize;

fn two<E: serde::de::Error>(v: Vec<f64>) -> Result<[f64; 2], E> {
    match v[..] {
        [a, b] => Ok([a, b]),
        _ => Err(E::custom(format!(
            "expected exactly two numbers [from, to], got {} ({v:?})",
            v.len()
        ))),
    }
}

/// One pair (`#[serde(deserialize_with = "pair")]` on a `[f64; 2]`).
pub fn pair<'de, D: serde::Deserializer<'de>>(d: D) -> Result<[f64; 2], D::Error> {
    two(Vec::deserialize(d)?)
}

/// An optional pair (on an `Option<[f64; 2]>`; give the field `#[serde(default)]`).
pub fn opt_pair<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<[f64; 2]>, D::Error> {
    Option::<Vec<f64>>::deserialize(d)?.map(two).transpose()
}

/// A list of pairs (on a `Vec<[f64; 2]>`).
pub fn pairs<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<[f64; 2]>, D::Error> {
    Vec::<Vec<f64>>::deserialize(d)?
        .into_iter()
        .map(two)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Deserialize, Debug)]
    struct T {
        #[serde(default, deserialize_with = "pairs")]
        list: Vec<[f64; 2]>,
        #[serde(default, deserialize_with = "opt_pair")]
        maybe: Option<[f64; 2]>,
        #[serde(default, deserialize_with = "pair")]
        one: [f64; 2],
    }

    #[test]
    fn pairs_of_any_other_length_are_refused_naming_the_numbers() {
        let ok: T =
            toml::from_str("list = [[1, 2], [3.5, 4]]\nmaybe = [5, 6]\none = [7, 8]").unwrap();
        assert_eq!(ok.list, vec![[1.0, 2.0], [3.5, 4.0]]);
        assert_eq!((ok.maybe, ok.one), (Some([5.0, 6.0]), [7.0, 8.0]));
        let none: T = toml::from_str("").unwrap();
        assert!(none.list.is_empty() && none.maybe.is_none());
        for (text, key) in [
            ("list = [[1, 2], [1, 2, 3]]", "list"),
            ("maybe = [10, 3000, 1]", "maybe"),
            ("one = [1]", "one"),
        ] {
            let e = toml::from_str::<T>(text).unwrap_err().to_string();
            assert!(
                e.contains("exactly two numbers") && e.contains(key),
                "{text}: {e}"
            );
        }
    }
}
