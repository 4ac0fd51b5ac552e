//! Fuzz target, elevator.toml: `Elevator::from_toml_str` on arbitrary text. Errors are
//! fine; a panic is a finding, and so is an accepted description that does not survive
//! its own `to_toml_string` round trip.
#![no_main]

use libfuzzer_sys::fuzz_target;
use liftwatch::Elevator;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(e) = Elevator::from_toml_str(text) {
        let again = Elevator::from_toml_str(&e.to_toml_string());
        assert!(again.is_ok(), "{again:?}");
    }
});
