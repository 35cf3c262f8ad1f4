//! Light transport for raylab.
//!
//! This crate knows nothing of RON, hecs, obvhs or the command line. It defines what it needs
//! from a scene as the narrow [`Scene`] trait, and provides the BSDFs, light sampling, the
//! [`Integrator`] trait, the registry of integrators, and the integrators themselves.
//!
//! # Conventions
//!
//! * Radiance is linear RGB in W·sr⁻¹·m⁻² per channel ([`Rgb`]); it is never rescaled.
//! * Directions in BSDF code are in the local shading frame, where `z` is the shading normal.
//!   Both `wo` (towards the viewer) and `wi` (towards the light) point away from the surface.
//! * **Depth convention** (used by every integrator and parameter in raylab): the depth of a
//!   light path is the number of surface scattering events between the emitter and the camera.
//!   Depth 0 is an emitter seen directly, depth 1 is direct illumination, depth 2 adds one
//!   indirect bounce, and so on. A `max-depth` of `D` keeps every path of depth `<= D`. This is
//!   pbrt-v4's `maxdepth`; Mitsuba 3's `max_depth` counts path segments, so Mitsuba's
//!   `max_depth = D + 1` equals raylab's `max-depth = D`.

#![forbid(unsafe_code)]

pub mod bsdf;
pub mod camera;
pub mod cutout;
pub mod filter;
pub mod geometry;
pub mod integrator;
pub mod light;
pub mod medium;
pub mod mlt;
pub mod named;
pub mod photon_map;
pub mod random;
pub mod sampler;
pub mod sampling;
pub mod scene;
pub mod sd_tree;
pub mod special;
pub mod spectrum;
#[cfg(any(test, feature = "testing"))]
pub mod testing;
pub mod texture;

pub use integrator::registry;

pub use bsdf::{BsdfSample, Material, SurfaceMaterial};
pub use camera::{Camera, CameraWiSample};
pub use filter::Filter;
pub use geometry::{Frame, Hit, MediumId, MediumInterface, Pending, Ray};
pub use integrator::{
    Batch, BatchIntegrator, ChainContext, Demand, Integrator, PassContext, PixelSample,
    RayCounters, RayIntegrator, SampleContext, ShardBy, Splats, Stop, Tracer, Work,
};
pub use light::{LeSample, Light, LightSample, LightTable};
pub use medium::{Medium, Phase};
pub use registry::{find, IntegratorEntry, ParamError, ParamKind, ParamSpec, Params, REGISTRY};
pub use sampler::Sampler;
pub use scene::Scene;

/// A linear RGB colour: a reflectance, a texture's value, an emitter's given colour.
pub type Rgb = glam::Vec3A;

/// Radiance, importance and path throughput as integrators carry them: four lanes, the
/// values at a sample's four wavelengths in spectral mode (pbrt-v4's `SampledSpectrum`), or
/// in RGB mode linear RGB's three channels with the red one repeated in the fourth lane
/// ([`spectrum::of_rgb`]). Every operation lane by lane keeps that repetition, so the
/// largest and smallest lanes are the channels' and RGB renders see only their channels;
/// sums and averages over lanes ask the sample's [`spectrum::Wavelengths`] how many there
/// are. Code that carries light says `Spectrum`; code that holds a colour says [`Rgb`].
pub type Spectrum = glam::Vec4;

/// Relative luminance of a linear sRGB/Rec.709 colour.
#[inline]
pub fn luminance(c: Rgb) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// The depth convention in one sentence, for listings.
pub const DEPTH_CONVENTION: &str = "depth = scattering events on a path: 0 emitters seen directly, 1 direct light, 2 one indirect bounce (pbrt-v4's maxdepth; Mitsuba 3 max_depth = raylab max-depth + 1)";
