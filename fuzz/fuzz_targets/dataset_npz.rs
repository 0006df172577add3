//! `Dataset::from_bytes` with an arbitrary `dataset.npz` beside a valid sidecar without a
//! digest (an old-format pair: with the digest every change would stop at the hash).
#![no_main]
use libfuzzer_sys::fuzz_target;
mod common;

fuzz_target!(|data: &[u8]| {
    let (_, old_json, _) = common::pair();
    let _ = occam::dataset::Dataset::from_bytes(old_json, data);
});
