//! What the importers of other renderers' scenes share: how they are asked (`-D`,
//! `--approximate`), what they give back (the scene's description), and how `raylab import`
//! writes it as RON.

use super::schema::{SceneFile, TransformDesc};
use glam::Affine3A;

/// How a scene of another format is read.
#[derive(Clone, Debug, Default)]
pub struct ImportOptions {
    /// A Mitsuba scene's `<default>` parameters, as `-D NAME=VALUE` sets them.
    pub defines: Vec<(String, String)>,
    /// Replace what raylab does not have by the nearest thing it has, and say so in the
    /// warnings and the report, instead of refusing the scene.
    pub approximate: bool,
    /// Folders searched for the files a Mitsuba scene names, after its own folder and its
    /// `<path>` folders (`-a DIR`, as `mitsuba -a`); the scene may read files in them.
    pub search: Vec<std::path::PathBuf>,
}

impl ImportOptions {
    /// The folders besides the scene's that a scene read with these options may read files
    /// from: `allowed` (`--allow-path`) and the search folders.
    pub fn readable(&self, allowed: &[std::path::PathBuf]) -> Vec<std::path::PathBuf> {
        allowed.iter().chain(&self.search).cloned().collect()
    }
}

/// The most entities a scene may have (a shape placed by instancing counts once per
/// placement).
pub const MAX_ENTITIES: usize = 1 << 22;

/// Memory an entity takes at the peak of a load, in bytes: its RON text, its description,
/// its components and the edit's record of it. Measured: 3.2 kB for each of 100,000
/// instanced spheres of a pbrt-v4 scene (324 MB at the peak).
pub const BYTES_PER_ENTITY: u64 = 3300;

/// Refuses a scene of `entities` entities beyond [`MAX_ENTITIES`], or whose entities need
/// more memory than `room` (the room when the making began): an error before they are made,
/// not an abort while they are.
pub fn check_entities(entities: usize, room: &crate::system::Room) -> Result<(), String> {
    if entities > MAX_ENTITIES {
        return Err(format!("the scene places more than {MAX_ENTITIES} shapes"));
    }
    room.check(
        entities as u64 * BYTES_PER_ENTITY,
        &format!("{entities} shapes"),
    )
}

/// [`check_entities`] as an importer makes them one by one: checked at every 1024th.
pub fn check_entities_made(entities: usize, room: &crate::system::Room) -> Result<(), String> {
    if entities.is_multiple_of(1024) || entities > MAX_ENTITIES {
        check_entities(entities, room)
    } else {
        Ok(())
    }
}

/// A scene of another format as raylab's scene description, with what the conversion did.
#[derive(Debug)]
pub struct Imported {
    /// The scene as the importer built it.
    pub scene: SceneFile,
    /// The comment `raylab import` writes above the RON: where the scene came from.
    pub header: String,
    /// One line per mapping that is not one to one (an approximation, a changed convention),
    /// as `what: how`.
    pub report: Vec<String>,
    /// The lines of the report that are approximations (`--approximate`), to warn about.
    pub approximated: Vec<String>,
    /// Where each entity and material (by name) came from in the scene's files, so that an
    /// error found when the scene is loaded names the place the user wrote (an included
    /// file's too).
    pub origins: Origins,
}

impl Imported {
    /// The scene as RON text (what `raylab import` writes).
    pub fn ron(&self) -> Result<String, String> {
        write_ron(&self.scene, &self.header)
    }
}

/// A placement given by its matrix (`transform: (matrix: [...])`).
pub fn placed(m: &Affine3A) -> TransformDesc {
    let matrix = (0..3)
        .flat_map(|r| {
            let row = m.matrix3.row(r);
            [row.x, row.y, row.z, m.translation[r]]
        })
        .collect();
    TransformDesc {
        matrix: Some(matrix),
        ..TransformDesc::default()
    }
}

/// The places the importer made each entity and material from, by their names.
#[derive(Debug, Default)]
pub struct Origins {
    pub entities: std::collections::HashMap<String, Place>,
    pub materials: std::collections::HashMap<String, Place>,
}

/// A file, line and column.
pub type Place = (std::path::PathBuf, u32, u32);

/// A scene description as RON text that reads back as the same description: one material,
/// mesh and entity per line, under a `//` comment line `header`.
pub fn write_ron(file: &super::schema::SceneFile, header: &str) -> Result<String, String> {
    let config = ron::ser::PrettyConfig::new()
        .depth_limit(2)
        .indentor("    ")
        .new_line("\n")
        .extensions(ron::extensions::Extensions::IMPLICIT_SOME);
    let body = ron::ser::to_string_pretty(file, config)
        .map_err(|e| format!("the scene cannot be written as RON: {e}"))?;
    Ok(format!("// {}\n{body}\n", header.replace('\n', " ")))
}
