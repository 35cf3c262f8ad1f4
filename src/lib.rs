//! raylab: a physically based renderer for comparing light-transport algorithms.
//!
//! Data flows one way: `scene` (RON -> hecs world) -> `build` (SoA + BVH, implements the
//! integrators' `Scene` trait) -> `render` (tile loop, film) -> `output` (EXR, PNG). The
//! integrators live in the `raylab-integrators` crate and know none of these modules.

pub mod bench;
pub mod build;
pub mod cli;
pub mod compare;
pub mod live;
pub mod output;
pub mod render;
pub mod scene;
pub mod serve;

pub use raylab_integrators as integrators;
