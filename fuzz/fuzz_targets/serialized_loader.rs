//! Arbitrary bytes into the Mitsuba `.serialized` reader, for its first and a later mesh:
//! errors are fine, panics, crashes and huge allocations are bugs. See docs/robustness.md.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    for index in [0, 1] {
        let _ =
            raylab::formats::serialized::parse_serialized(Path::new("fuzz.serialized"), data, index);
    }
});
