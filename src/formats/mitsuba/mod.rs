//! Mitsuba 3 XML scenes, turned into raylab's RON (RON stays the hub: the text this writes is
//! loaded by the one RON loader, with its checks and messages, and `raylab import` writes it
//! out for a person to edit).
//!
//! What is read: `<include>` and `<path>` (see [`include`]), `<default>` and `$name`
//! substitution (with `-D name=value` overrides),
//! `<ref>` and ids, `<transform>` (translate, rotate, scale, matrix, lookat, in order), `rgb`,
//! `spectrum` (uniform or by wavelength, through `formats::spectra`), `float`, `integer`, `boolean`, `string`, `point`, `vector`; the
//! `perspective` sensor with its `hdrfilm`, `rfilter` and sampler; the `path`, `direct` and `moment` integrators;
//! shapes `obj`, `ply`, `rectangle`, `cube`, `sphere`, `disk`, `cylinder` with
//! `flip_normals`; BSDFs `diffuse`, `conductor`, `roughconductor`, `dielectric`,
//! `roughdielectric`, `thindielectric`, `plastic`, `roughplastic`, `twosided`; emitters
//! `area`, `point`, `spot`, `directional`, `constant`, `envmap`. Anything else is an error at
//! its line and column: raylab does not guess.

mod convert;
pub mod include;
mod xml;

pub use convert::{to_ron, to_ron_in, to_ron_with, Imported};
