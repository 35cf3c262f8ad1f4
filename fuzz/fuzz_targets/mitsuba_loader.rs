//! Arbitrary bytes as a Mitsuba 3 XML scene: converted to RON and, where that works, loaded
//! and built. Errors are fine, panics and crashes are bugs. See docs/robustness.md.
#![no_main]

use libfuzzer_sys::fuzz_target;
use raylab::scene::{parse_scene, RenderScene};
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(imported) = raylab::formats::mitsuba::to_ron(text, &[]) else {
        return;
    };
    let Ok(ron) = imported.ron() else {
        return;
    };
    if let Ok(loaded) = parse_scene(&ron, Path::new("fuzz.xml")) {
        RenderScene::build(&loaded);
    }
});
