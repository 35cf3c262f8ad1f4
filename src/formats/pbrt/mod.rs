//! pbrt-v4 scenes, turned into raylab's RON (RON stays the hub: the text this writes is
//! loaded by the one RON loader, with its checks and messages, and `raylab import` writes it
//! out for a person to edit).
//!
//! What is read: the tokenizer's whole grammar; `Include` and `Import`; the transform
//! directives (`Translate`, `Scale`, `Rotate`, `LookAt`, `Transform`, `ConcatTransform`,
//! `Identity`, `CoordinateSystem`, `CoordSysTransform`), `ReverseOrientation`,
//! `AttributeBegin/End`, `TransformBegin/End`, `ObjectBegin/End/Instance`; the `perspective`
//! camera (fov on the shorter axis, screen window, crop window) as an image-plane camera that
//! keeps pbrt's image orientation; the `rgb` film, `box`/`triangle`/`gaussian` filters with
//! their radii, the sampler's pixel samples; the `path` family of integrators with maxdepth
//! and `sppm`; materials `diffuse`, `coateddiffuse` (as plastic), `conductor`, `dielectric`,
//! `thindielectric`; textures `imagemap`, `checkerboard`, `constant`, `scale`; lights
//! `point`, `spot` (with pbrt's smoothstep falloff), `distant`, `infinite` (constant, or an octahedral image), `diffuse`
//! area lights;
//! shapes `trianglemesh`, `bilinearmesh`, `plymesh`, `sphere`, `disk`, `cylinder`;
//! participating media (`MakeNamedMedium` `homogeneous` and `uniformgrid`, `MediumInterface`,
//! the `interface` material as raylab's `Null`), rendered with `volpath`.
//! Anything else is an error at its file, line and column, or with `--approximate` the
//! nearest thing raylab has, listed in the report.

mod convert;
mod directives;
mod materials;
mod params;
mod tokens;

pub use convert::{to_ron, PbrtError};
