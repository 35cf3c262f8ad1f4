//! What files say, beside the ECS world: the scene description (the RON schema,
//! `schema.rs`, with `texture_desc.rs`, `medium_desc.rs` and `transform_desc.rs`), the importers that build it from other renderers'
//! scenes (`mitsuba/`, `pbrt/`, sharing `import.rs`), and the readers of the files scenes
//! name (meshes: `mesh_files.rs` for OBJ and glTF, `ply.rs`, `serialized.rs`; images:
//! `images.rs`, `pfm.rs`, `octahedral.rs`; spectra: `spectra.rs`), with which files a scene may read
//! (`access.rs`). Nothing here knows the world, its components or the render scene.

pub mod access;
pub mod images;
pub mod import;
pub mod medium_desc;
pub mod memory;
pub mod mesh_files;
pub mod mitsuba;
pub mod octahedral;
pub mod pbrt;
pub mod pfm;
pub mod ply;
pub mod schema;
pub mod serialized;
pub mod spectra;
pub mod texture_desc;
pub mod transform_desc;
pub mod volume_grid;
