//! `Dataset::from_bytes` with an arbitrary `dataset.json` beside the seed `dataset.npz`.
#![no_main]
use libfuzzer_sys::fuzz_target;
mod common;

fuzz_target!(|data: &[u8]| {
    let _ = common::old_json();
    let _ = occam::data::dataset::Dataset::from_bytes(data, common::NPZ);
});
