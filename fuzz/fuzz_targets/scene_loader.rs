//! Arbitrary bytes into the scene loader and the build step (and, for scenes that load, a
//! tiny render): errors are fine, panics and crashes are bugs. See README.md, "Robustness".
#![no_main]

use libfuzzer_sys::fuzz_target;
use raylab::scene::RenderScene;
use raylab::render::{render, RenderSettings};
use raylab::scene::parse_scene;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(loaded) = parse_scene(text, Path::new("fuzz.ron")) else {
        return;
    };
    let built = RenderScene::build(&loaded);
    // 8x8 pixels, 1 spp, one thread: enough to trace every primitive kind near the camera.
    let camera = loaded.camera.with_resolution(8, 8);
    if camera.width as u64 * camera.height as u64 <= 64 * 64 {
        let mut normals = raylab::integrators::find("normals")
            .expect("normals is registered")
            .instantiate(&[])
            .expect("normals takes no parameters");
        let settings = RenderSettings::fixed(1, 0, Some(1));
        render(&built, &camera, normals.as_mut(), &settings).expect("a 1-thread pool builds");
    }
});
