//! Fuzz target, stage 1 time stamps: `parse_time` (both starting forms and undecided),
//! `parse_seconds` and `parse_rfc3339` on arbitrary strings. Errors are fine; a panic is a
//! finding, and so is an accepted time that is not finite or beyond `MAX_ABS_TIME_S`.
#![no_main]

use libfuzzer_sys::fuzz_target;
use liftwatch::ingest::time::{parse_rfc3339, parse_seconds, parse_time, TimeForm};
use liftwatch::ingest::MAX_ABS_TIME_S;

fn accepted(t: f64) {
    assert!(t.is_finite() && t.abs() <= MAX_ABS_TIME_S, "{t}");
}

fuzz_target!(|data: &[u8]| {
    let Ok(s) = std::str::from_utf8(data) else {
        return;
    };
    for start in [None, Some(TimeForm::Seconds), Some(TimeForm::Rfc3339)] {
        let mut form = start;
        if let Ok(t) = parse_time(s, &mut form) {
            accepted(t);
        }
    }
    if let Ok(t) = parse_seconds(s) {
        accepted(t);
    }
    if let Ok(t) = parse_rfc3339(s) {
        accepted(t);
    }
});
