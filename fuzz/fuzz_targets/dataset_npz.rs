//! `Dataset::from_bytes` with an arbitrary `dataset.npz` beside the seed sidecar without its
//! digest (an old-format pair: with the digest every change would stop at the hash).
#![no_main]
use libfuzzer_sys::fuzz_target;
mod common;

fuzz_target!(|data: &[u8]| {
    let _ = occam::data::dataset::Dataset::from_bytes(common::old_json(), data);
});
