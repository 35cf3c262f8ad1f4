//! raylab: a physically based renderer for comparing light-transport algorithms.
//!
//! Data flows one way: `scene` (RON -> hecs world -> flattened render scene, which implements
//! the integrators' `Scene` trait over `accel`, the BVH) -> `render` (tile loop, film) ->
//! `output` (EXR, PNG). The integrators live in the `raylab-integrators` crate and know none
//! of these modules. Every `unsafe` block lives in `accel` and carries its own SAFETY comment.

#![deny(clippy::undocumented_unsafe_blocks)]

pub mod accel;
pub mod bench;
pub mod cli;
pub mod compare;
pub mod files;
pub mod live;
pub mod output;
pub mod render;
pub mod scene;
pub mod system;

pub use raylab_integrators as integrators;
