//! Scenes: loading a scene description (see [`crate::formats`]) into a hecs world, the ECS
//! systems, edits of the world, and flattening it into the render scene.

pub mod assets;
pub mod components;
pub mod describe;
pub mod edit;
pub mod error;
pub mod file_materials;
pub mod flatten;
pub mod inputs;
pub mod load;
pub mod materials;
pub mod media;
pub mod procedural;
pub mod references;
mod stamps;
pub mod systems;
pub mod textures;

pub use crate::formats::import::{ImportOptions, Imported};
pub use error::SceneError;
pub use flatten::RenderScene;
pub use inputs::SceneInputs;
pub use load::{
    import_scene, is_imported, is_mitsuba, is_pbrt, load_scene, load_scene_defined, load_scene_in,
    load_scene_with, parse_scene, read_scene_file,
};
pub use raylab_integrators::Camera;

use raylab_integrators::{Rgb, SurfaceMaterial};
use std::path::PathBuf;

/// A loaded scene: the ECS world of entities and the resources beside it.
pub struct LoadedScene {
    /// The file it came from (for messages and relative paths).
    pub path: PathBuf,
    /// One entity per object, with `Name`, `Transform` and optionally `Shape`, `MaterialRef`,
    /// `Emitter`; after loading, shaped entities also carry their baked `WorldShape`, and
    /// instances (shape `Instance`) an `Instanced` pointing at their shared mesh asset.
    pub world: hecs::World,
    pub camera: Camera,
    pub render: crate::formats::schema::RenderDesc,
    /// The material table (file order; a black material may be appended for pure emitters).
    pub materials: Vec<SurfaceMaterial>,
    pub material_names: Vec<String>,
    /// The mesh assets instances place (loaded ones only, in order of first use); entities
    /// refer to them through their `Instanced` component.
    pub meshes: Vec<std::sync::Arc<components::LocalMesh>>,
    /// Constant environment radiance, if any.
    pub environment: Option<Rgb>,
    /// The participating media, their names and the camera's.
    pub media: media::Media,
    /// Non-fatal problems found while loading (e.g. dropped degenerate triangles).
    pub warnings: Vec<String>,
    /// Every file the load read, and how the scene was read: what no output may replace,
    /// and the scene's identity.
    pub inputs: SceneInputs,
}

#[cfg(test)]
mod tests;
