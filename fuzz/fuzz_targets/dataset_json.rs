//! `Dataset::from_bytes` with an arbitrary `dataset.json` beside a valid `dataset.npz`.
#![no_main]
use libfuzzer_sys::fuzz_target;
mod common;

fuzz_target!(|data: &[u8]| {
    let (_, _, npz) = common::pair();
    let _ = occam::dataset::Dataset::from_bytes(data, npz);
});
