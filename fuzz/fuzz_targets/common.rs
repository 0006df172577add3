//! The valid dataset the dataset targets pair with fuzzed input: the committed seed pair
//! (written by `occam simulate` on a small study).

use std::sync::OnceLock;

/// The seed `dataset.json`.
pub const JSON: &[u8] = include_bytes!("../seeds/dataset_json/dataset.json");
/// The seed `dataset.npz`, which `JSON` describes.
pub const NPZ: &[u8] = include_bytes!("../seeds/dataset_npz/dataset.npz");

/// `JSON` without its npz digest, as a sidecar written before digests existed: paired with a
/// fuzzed archive, the readers' checks are reached instead of stopping at the hash.
pub fn old_json() -> &'static [u8] {
    static OLD: OnceLock<Vec<u8>> = OnceLock::new();
    OLD.get_or_init(|| {
        let mut v: serde_json::Value = serde_json::from_slice(JSON).unwrap();
        v.as_object_mut().unwrap().remove("npz_digest");
        let old = serde_json::to_vec_pretty(&v).unwrap();
        // the pair itself must read, or the targets test nothing
        occam::data::dataset::Dataset::from_bytes(JSON, NPZ).expect("the seed pair reads");
        occam::data::dataset::Dataset::from_bytes(&old, NPZ).expect("the old-format seed pair reads");
        old
    })
}
