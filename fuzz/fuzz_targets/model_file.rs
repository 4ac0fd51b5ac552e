//! Fuzz target, the model file (DATA.md §5): `file::load_str` on arbitrary text. Errors are
//! fine; a panic is a finding.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use liftwatch::file::load_str;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = load_str(text, Path::new("fuzz.json"));
    }
});
