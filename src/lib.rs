//! raylab: a physically based renderer for comparing light-transport algorithms.
//!
//! Data flows one way: `scene` (RON -> hecs world -> flattened render scene, which implements
//! the integrators' `Scene` trait over `accel`, the BVH) -> `render` (tile loop, film) ->
//! `output` (EXR, PNG). The integrators live in the `raylab-integrators` crate and know none
//! of these modules. Every `unsafe` block lives in `accel` and carries its own SAFETY comment.

#![deny(clippy::undocumented_unsafe_blocks)]

/// `println!` for the program's output, which ignores a failure to print (a reader that went
/// away, `raylab integrators | head`) where `println!` would panic, and escapes control
/// characters (see `console`).
macro_rules! say {
    () => {
        $crate::console::print_out(format_args!("\n"))
    };
    ($($arg:tt)*) => {
        $crate::console::print_out(format_args!("{}\n", format_args!($($arg)*)))
    };
}

/// `eprintln!` for messages, which ignores a failure to print and escapes control characters
/// (see `console`).
macro_rules! note {
    ($($arg:tt)*) => {
        $crate::console::note(&format!($($arg)*))
    };
}

pub mod accel;
pub mod bench;
pub mod cli;
pub mod compare;
pub mod console;
pub mod files;
pub mod formats;
pub mod live;
pub mod output;
pub mod render;
pub mod scene;
pub mod system;

pub use raylab_integrators as integrators;
