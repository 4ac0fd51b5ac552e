//! Fuzz target, the monitor state file: `MonitorState::from_slice` on arbitrary bytes.
//! Errors are fine; a panic is a finding.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use liftwatch::monitor::MonitorState;

fuzz_target!(|data: &[u8]| {
    let _ = MonitorState::from_slice(data, Path::new("fuzz.state"));
});
