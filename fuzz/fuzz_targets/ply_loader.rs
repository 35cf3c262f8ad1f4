//! Arbitrary bytes into the PLY reader: errors are fine, panics and crashes are bugs. See
//! docs/robustness.md.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let _ = raylab::formats::ply::parse_ply(Path::new("fuzz.ply"), data);
});
