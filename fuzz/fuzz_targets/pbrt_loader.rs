//! Arbitrary bytes as a pbrt-v4 scene: converted to RON and, where that works, loaded and
//! built. Errors are fine, panics and crashes are bugs. See docs/robustness.md.
#![no_main]

use libfuzzer_sys::fuzz_target;
use raylab::formats::access::SceneFiles;
use raylab::scene::{parse_scene, ImportOptions, RenderScene};
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    // Includes resolve in an empty folder: the fuzzer reaches no file of the machine.
    let dir = std::env::temp_dir().join("raylab-fuzz-pbrt");
    let _ = std::fs::create_dir_all(&dir);
    let path = dir.join("fuzz.pbrt");
    let files = SceneFiles::new(&path, &[]);
    let options = ImportOptions {
        approximate: data.first().is_some_and(|b| b & 1 == 1),
        ..ImportOptions::default()
    };
    let Ok(imported) = raylab::formats::pbrt::to_ron(&path, text, &files, &options) else {
        return;
    };
    let Ok(ron) = imported.ron() else {
        return;
    };
    if let Ok(loaded) = parse_scene(&ron, Path::new("fuzz.pbrt")) {
        RenderScene::build(&loaded);
    }
});
