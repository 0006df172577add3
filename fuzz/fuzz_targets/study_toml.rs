//! `Study::from_toml` on arbitrary UTF-8: any text is a study or an error, never a panic.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = occam::config::Study::from_toml(text, "fuzz.toml", std::path::Path::new("."));
    }
});
