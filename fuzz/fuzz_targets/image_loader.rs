//! Arbitrary bytes into the image readers (PFM, TGA by its name, and whatever the `image`
//! crate recognises): errors are fine, panics and crashes are bugs. See docs/robustness.md.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    for name in ["fuzz.pfm", "fuzz.tga", "fuzz.png"] {
        let _ = raylab::formats::images::parse_linear_rgb(Path::new(name), data, false);
    }
});
