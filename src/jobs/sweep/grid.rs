//! The sweep's grid: the points (one value per axis), the study file of each point (the base
//! file with the swept keys set), and the seed of each (point, realisation).

use anyhow::{Context, bail};
use toml::{Table, Value};

/// A swept study key and its values.
#[derive(Debug, Clone, PartialEq)]
pub struct Axis {
    pub key: String,
    pub values: Vec<f64>,
}

/// The product grid of one or two axes; point `p` has index `(p / n1, p % n1)`.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    pub axes: Vec<Axis>,
}

impl Grid {
    /// Number of points.
    pub fn len(&self) -> usize {
        self.axes.iter().map(|a| a.values.len()).product()
    }

    /// Whether the grid has no point (never, for a validated grid).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The axis values of point `p`, in axis order.
    pub fn point(&self, p: usize) -> Vec<f64> {
        let mut rest = p;
        let mut out = vec![0.0; self.axes.len()];
        for (k, a) in self.axes.iter().enumerate().rev() {
            out[k] = a.values[rest % a.values.len()];
            rest /= a.values.len();
        }
        out
    }

    /// `key=value, …` for point `p` (for messages).
    pub fn label(&self, p: usize) -> String {
        self.axes
            .iter()
            .zip(self.point(p))
            .map(|(a, v)| format!("{}={v}", a.key))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// An axis from the command line: `KEY=v1,v2,…`, `KEY=log:FROM:TO:N` or `KEY=lin:FROM:TO:N`,
/// checked like a `[[sweep.axis]]` table.
pub fn parse_axis(arg: &str) -> anyhow::Result<Axis> {
    use crate::config::{Spacing, SweepAxis};
    let (key, rhs) = arg.split_once('=').with_context(|| {
        format!("--axis `{arg}`: write KEY=v1,v2,… or KEY=log:FROM:TO:N (or lin:…)")
    })?;
    let num = |s: &str| -> anyhow::Result<f64> {
        s.trim()
            .parse::<f64>()
            .with_context(|| format!("--axis `{arg}`: `{s}` is not a number"))
    };
    let mut a = SweepAxis {
        key: key.trim().to_string(),
        values: None,
        from: None,
        to: None,
        points: None,
        spacing: Spacing::Log,
    };
    let range = rhs
        .strip_prefix("log:")
        .map(|r| (Spacing::Log, r))
        .or_else(|| rhs.strip_prefix("lin:").map(|r| (Spacing::Linear, r)));
    if let Some((spacing, r)) = range {
        let f: Vec<&str> = r.split(':').collect();
        let [from, to, n] = f[..] else {
            bail!("--axis `{arg}`: a range is {}:FROM:TO:N", &rhs[..3]);
        };
        a.spacing = spacing;
        a.from = Some(num(from)?);
        a.to = Some(num(to)?);
        a.points = Some(
            n.trim()
                .parse()
                .with_context(|| format!("--axis `{arg}`: N = `{n}` is not a whole number"))?,
        );
    } else {
        a.values = Some(rhs.split(',').map(num).collect::<anyhow::Result<_>>()?);
    }
    let values = a.grid("the command line", &format!("--axis {}", a.key))?;
    Ok(Axis { key: a.key, values })
}

/// One SplitMix64 step from state `z`: add the golden-ratio increment, then the output mix (a
/// bijection of 64 bits). The seeds of sweeps and of `occam design`'s realisations.
pub fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// The seed of realisation `r` at the point with axis values `values`: a mix of the run
/// seed, the bits of the values and `r`. It depends on the point's values, not its index, so
/// a grid refined or extended later reuses the realisations already computed; and never on the
/// worker that runs it.
pub fn task_seed(run_seed: u64, values: &[f64], r: usize) -> u64 {
    let mut h = mix(run_seed);
    for v in values {
        h = mix(h ^ v.to_bits());
    }
    mix(h ^ (r as u64))
}

/// The base study file with `key` set to `v`.
///
/// `key` is a dotted path: table keys, array indices (`snr_band.1`,
/// `experiment.0.x1.segments.2.freq`), and `[[experiment]]`/`[[model]]`-style arrays of
/// tables addressed by their `name` (`experiment.inv1.x1.freq`). A missing leaf (or table on
/// the way) is created, so a key the file leaves at its default can be swept
/// (`truth.d21`); the study's own validation then rejects a key that does not exist. An
/// existing leaf must be a number; an integer key takes only whole numbers.
pub fn set_key(doc: &mut Table, key: &str, v: f64) -> anyhow::Result<()> {
    let parts: Vec<&str> = key.split('.').collect();
    if parts.iter().any(|p| p.is_empty()) {
        bail!("sweep key `{key}`: an empty segment; write keys like `simulation.target_snr`");
    }
    let mut here: &mut Value = doc
        .entry(parts[0].to_string())
        .or_insert_with(|| Value::Table(Table::new()));
    let mut path = parts[0].to_string();
    for part in &parts[1..] {
        let at = path.clone();
        here = match here {
            Value::Table(t) => t
                .entry(part.to_string())
                .or_insert_with(|| Value::Table(Table::new())),
            Value::Array(a) => {
                let i = match part.parse::<usize>() {
                    Ok(i) => i,
                    Err(_) => a
                        .iter()
                        .position(|e| {
                            e.get("name").and_then(Value::as_str) == Some(*part)
                        })
                        .with_context(|| {
                            let names: Vec<&str> = a
                                .iter()
                                .filter_map(|e| e.get("name").and_then(Value::as_str))
                                .collect();
                            format!(
                                "sweep key `{key}`: `{at}` has no entry named `{part}` (names: {names:?}; or give an index 0..{})",
                                a.len()
                            )
                        })?,
                };
                let n = a.len();
                a.get_mut(i).with_context(|| {
                    format!("sweep key `{key}`: `{at}` has {n} entries, no index {i}")
                })?
            }
            other => bail!(
                "sweep key `{key}`: `{at}` is a {}, not a table or an array",
                other.type_str()
            ),
        };
        path = format!("{path}.{part}");
    }
    match here {
        Value::Integer(_) => {
            if v.fract() != 0.0 || v.abs() > 9.0e15 {
                bail!("sweep key `{key}` takes whole numbers (got {v})");
            }
            *here = Value::Integer(v as i64);
        }
        Value::Float(_) => *here = Value::Float(v),
        Value::Table(t) if t.is_empty() => *here = Value::Float(v),
        other => bail!(
            "sweep key `{key}` holds a {} in the study file; only numbers can be swept{}",
            other.type_str(),
            if other.is_table() {
                " (name a number inside it)"
            } else {
                ""
            }
        ),
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const STUDY: &str = r#"
seed = 1
output = "o"
[select]
rj_iterations = 10000
[simulation]
snr_band = [1e-4, 1.0]
[[experiment]]
name = "inv1"
x1 = { kind = "sine", freq = 0.01, amplitude = 1e-6, duration = 3000.0 }
[[experiment]]
name = "inv2"
x12 = { kind = "sine_train", segments = [{ freq = 0.1, amplitude = 1e-6, duration = 100.0 }] }
"#;

    fn doc() -> Table {
        STUDY.parse().unwrap()
    }

    #[test]
    fn keys_reach_tables_arrays_and_named_entries() {
        let mut d = doc();
        set_key(&mut d, "experiment.inv1.x1.freq", 0.05).unwrap();
        set_key(&mut d, "experiment.1.x12.segments.0.amplitude", 2e-6).unwrap();
        set_key(&mut d, "simulation.snr_band.1", 0.5).unwrap();
        set_key(&mut d, "simulation.target_snr", 30.0).unwrap();
        set_key(&mut d, "truth.d21", 1e-4).unwrap();
        set_key(&mut d, "select.rj_iterations", 20000.0).unwrap();
        let e = &d["experiment"][0]["x1"];
        assert_eq!(e["freq"].as_float(), Some(0.05));
        assert_eq!(
            d["experiment"][1]["x12"]["segments"][0]["amplitude"].as_float(),
            Some(2e-6)
        );
        assert_eq!(d["simulation"]["snr_band"][1].as_float(), Some(0.5));
        assert_eq!(d["simulation"]["target_snr"].as_float(), Some(30.0));
        assert_eq!(d["truth"]["d21"].as_float(), Some(1e-4));
        assert_eq!(d["select"]["rj_iterations"].as_integer(), Some(20000));
        // the edited document is still a study
        let text = toml::to_string(&d).unwrap();
        crate::config::Study::from_toml(&text, "t", std::path::Path::new(".")).unwrap();
    }

    #[test]
    fn bad_keys_say_what_is_wrong() {
        for (key, v, needle) in [
            ("experiment.inv9.x1.freq", 1.0, "no entry named `inv9`"),
            ("experiment.5.x1.freq", 1.0, "no index 5"),
            ("experiment.inv1.name", 1.0, "holds a string"),
            ("experiment.inv1.x1", 1.0, "name a number inside it"),
            ("seed.x", 1.0, "not a table or an array"),
            ("select.rj_iterations", 1.5, "whole numbers"),
            ("simulation..x", 1.0, "empty segment"),
        ] {
            let e = set_key(&mut doc(), key, v).unwrap_err().to_string();
            assert!(e.contains(needle) && e.contains(key), "{key}: {e}");
        }
        // an unknown key is created here and rejected by the study's own validation
        let mut d = doc();
        set_key(&mut d, "simulation.target_snrr", 3.0).unwrap();
        let e = crate::config::Study::from_toml(&toml::to_string(&d).unwrap(), "t", ".".as_ref())
            .unwrap_err()
            .to_string();
        assert!(e.contains("target_snrr"), "{e}");
    }

    #[test]
    fn command_line_axes() {
        let a = parse_axis("simulation.target_snr=5,10,20").unwrap();
        assert_eq!(a.key, "simulation.target_snr");
        assert_eq!(a.values, vec![5.0, 10.0, 20.0]);
        let a = parse_axis("experiment.inv1.x1.freq=log:1e-4:1:5").unwrap();
        assert_eq!(a.values.len(), 5);
        assert_eq!((a.values[0], a.values[4]), (1e-4, 1.0));
        let a = parse_axis("truth.d21=lin:-1e-4:1e-4:3").unwrap();
        assert_eq!(a.values, vec![-1e-4, 0.0, 1e-4]);
        for (bad, needle) in [
            ("simulation.target_snr", "KEY=v1"),
            ("k=1,x", "`x` is not a number"),
            ("k=log:1:2", "FROM:TO:N"),
            ("k=log:0:2:3", "linear"),
            ("k=lin:0:2:2.5", "whole number"),
            ("k=1,1", "twice"),
        ] {
            let e = format!("{:#}", parse_axis(bad).unwrap_err());
            assert!(e.contains(needle), "{bad}: {e}");
        }
    }

    #[test]
    fn grid_points_and_seeds() {
        let g = Grid {
            axes: vec![
                Axis {
                    key: "a".into(),
                    values: vec![1.0, 2.0, 3.0],
                },
                Axis {
                    key: "b".into(),
                    values: vec![10.0, 20.0],
                },
            ],
        };
        assert_eq!(g.len(), 6);
        assert_eq!(g.point(0), vec![1.0, 10.0]);
        assert_eq!(g.point(1), vec![1.0, 20.0]);
        assert_eq!(g.point(5), vec![3.0, 20.0]);
        assert_eq!(g.label(3), "a=2, b=20");
        let s = task_seed(7, &[1.0, 20.0], 0);
        assert_eq!(s, task_seed(7, &[1.0, 20.0], 0));
        let mut all = vec![
            s,
            task_seed(7, &[1.0, 20.0], 1),
            task_seed(8, &[1.0, 20.0], 0),
            task_seed(7, &[20.0, 1.0], 0),
            task_seed(7, &[1.0, 10.0], 0),
            task_seed(7, &[1.0], 0),
        ];
        all.sort();
        all.dedup();
        assert_eq!(
            all.len(),
            6,
            "seeds must differ across points, realisations and runs"
        );
    }
}
