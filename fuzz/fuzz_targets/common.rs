//! The valid dataset the dataset targets pair with fuzzed input: written once per process.

use occam::dataset::{Dataset, ExperimentData};
use std::sync::OnceLock;

/// `(dataset.json, dataset.json without its npz digest, dataset.npz)` of a small dataset.
pub fn pair() -> &'static (Vec<u8>, Vec<u8>, Vec<u8>) {
    static PAIR: OnceLock<(Vec<u8>, Vec<u8>, Vec<u8>)> = OnceLock::new();
    PAIR.get_or_init(|| {
        let v = |a: f64, n: usize| (0..n).map(|k| a * (k as f64 + 1.0)).collect::<Vec<_>>();
        let mut e = ExperimentData::new(
            "inv1",
            10.0,
            [v(1.0, 32), v(2.0, 32)],
            [v(3.0, 32), v(4.0, 32)],
            [v(5.0, 16), v(6.0, 16)],
        );
        e.extra.insert("g1".into(), v(0.5, 32));
        e.noise_extra.insert("g1".into(), v(0.25, 16));
        let d = Dataset {
            experiments: vec![e],
            seed: Some(1),
            truth: Some(Default::default()),
            extra: serde_json::Value::Null,
        };
        let dir = std::env::temp_dir().join(format!("occam-fuzz-{}", std::process::id()));
        let (npz, json) = d.write(&dir).expect("the sample dataset is valid");
        let (npz, json) = (std::fs::read(npz).unwrap(), std::fs::read(json).unwrap());
        let _ = std::fs::remove_dir_all(&dir);
        let mut old: serde_json::Value = serde_json::from_slice(&json).unwrap();
        old.as_object_mut().unwrap().remove("npz_digest");
        (json, serde_json::to_vec_pretty(&old).unwrap(), npz)
    })
}
