//! `parse_csv` (and the time column's sample rate) on arbitrary bytes.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(t) = occam::data::dataset::parse_csv(std::path::Path::new("fuzz.csv"), data) {
        let _ = t.sample_rate();
    }
});
