//! Every warning a run recorded, each shown once with where it came from: `summary.json`
//! repeats some warnings at several levels (a pair's jump warning also in the run's list), and
//! a sweep's realisations repeat the same warning across tasks.

use serde_json::Value;

/// One warning and the places it was found.
#[derive(Debug, Clone, PartialEq)]
pub struct Warning {
    pub text: String,
    pub places: Vec<String>,
}

/// The warnings of a run, in the order first found.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Warnings(pub Vec<Warning>);

impl Warnings {
    /// Adds `text` found at `place`: a text already listed (or contained in a listed one, as
    /// `only 0 accepted jumps …` in `X/Y: only 0 accepted jumps …`) gains the place only.
    /// A listed text contained in a new one (found first at a deeper level) takes the new,
    /// longer text.
    pub fn add(&mut self, text: &str, place: &str) {
        let text = text.trim();
        if text.is_empty() {
            return;
        }
        let found = self
            .0
            .iter_mut()
            .find(|w| w.text.contains(text) || text.contains(w.text.as_str()));
        match found {
            Some(w) => {
                if text.len() > w.text.len() {
                    w.text = text.to_string();
                }
                if !w.places.iter().any(|p| p == place) {
                    w.places.push(place.to_string());
                }
            }
            None => self.0.push(Warning {
                text: text.to_string(),
                places: vec![place.to_string()],
            }),
        }
    }

    /// Adds every string under a key `warnings` (a list) or `warning` in `v`, at any depth;
    /// `place` names `v` and the path below it names the rest.
    pub fn collect(&mut self, v: &Value, place: &str) {
        match v {
            Value::Object(m) => {
                // this level's own warnings first: they are the fuller texts (`X/Y: …`)
                let own = |k: &String| k == "warnings" || k == "warning";
                let (first, rest): (Vec<_>, Vec<_>) = m.iter().partition(|(k, _)| own(k));
                for (k, x) in first.into_iter().chain(rest) {
                    let here = if place.is_empty() {
                        k.clone()
                    } else {
                        format!("{place}.{k}")
                    };
                    // a warning's place is the object that holds it
                    match (k.as_str(), x) {
                        ("warnings", Value::Array(a)) => {
                            for w in a.iter().filter_map(Value::as_str) {
                                self.add(w, place);
                            }
                        }
                        ("warning", Value::String(s)) => self.add(s, place),
                        _ => self.collect(x, &here),
                    }
                }
            }
            Value::Array(a) => {
                for (i, x) in a.iter().enumerate() {
                    self.collect(x, &format!("{place}[{i}]"));
                }
            }
            _ => {}
        }
    }

    /// How many distinct warnings.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn nested_repeats_are_shown_once_with_every_place() {
        let v = json!({
            "warnings": ["X/Y: only 0 accepted jumps", "R-hat of `a` is 1.2"],
            "pairs": [{"jumps": {"warning": "only 0 accepted jumps"}}],
            "rj": {"pairs": [{"warning": null}]},
            "models": [{"warnings": ["new one", 3]}]
        });
        let mut w = Warnings::default();
        w.collect(&v, "s");
        assert_eq!(w.len(), 3);
        assert_eq!(w.0[0].text, "X/Y: only 0 accepted jumps");
        assert_eq!(w.0[0].places, ["s", "s.pairs[0].jumps"]);
        assert_eq!(w.0[2].places, ["s.models[0]"]);
        // found the other way round: the fuller text wins and keeps both places
        let mut w = Warnings::default();
        w.add("only 0 jumps", "deep");
        w.add("X/Y: only 0 jumps", "top");
        assert_eq!(w.0.len(), 1);
        assert_eq!(w.0[0].text, "X/Y: only 0 jumps");
        assert_eq!(w.0[0].places, ["deep", "top"]);
    }

    #[test]
    fn nothing_to_warn_about() {
        let mut w = Warnings::default();
        w.collect(&json!({"warnings": [], "x": [1, 2]}), "");
        w.collect(&Value::Null, "");
        w.add("  ", "p");
        assert!(w.is_empty());
    }
}
