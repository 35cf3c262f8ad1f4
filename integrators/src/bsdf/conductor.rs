//! Smooth conductor (metal): a mirror whose reflectance is the conductor's Fresnel term
//! (Mitsuba 3's `conductor`; RON `Conductor`).
//!
//! Parameters and units:
//! * `ior`: the metal's complex index of refraction `eta + i k` relative to the outside, per
//!   channel, unitless; or none, for a perfect mirror (Fresnel reflectance 1: Mitsuba's
//!   material `none`). Named metals come from [`super::ior`].
//! * `reflectance`: per-channel multiplier, unitless, in `[0, 1]` (Mitsuba's
//!   `specular_reflectance`).
//!
//! One Dirac lobe: `wi` is `wo` mirrored about the normal, and the throughput weight is
//! `reflectance * F(cos(wo))`. Two-sided like every opaque material. Without an IOR it is
//! the report's perfect mirror (RON `Mirror(tint)`): `F` is exactly 1.

use super::fresnel::fresnel_conductor;
use super::{BsdfSample, Bxdf, Lobes};
use crate::Spectrum;
use glam::{Vec2, Vec3A};

/// A conductor's complex index of refraction `eta + i k`, per channel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ComplexIor {
    pub eta: Spectrum,
    pub k: Spectrum,
}

impl ComplexIor {
    /// A complex IOR whose parts are finite and non-negative.
    pub fn new(eta: Spectrum, k: Spectrum) -> Result<ComplexIor, String> {
        Ok(ComplexIor {
            eta: super::checks::colour("eta", eta)?,
            k: super::checks::colour("k", k)?,
        })
    }
}

/// The Fresnel reflectance of an optional complex IOR (none: a perfect mirror).
#[inline]
pub fn conductor_fresnel(ior: Option<ComplexIor>, cos: f32) -> Spectrum {
    match ior {
        Some(c) => fresnel_conductor(cos, c.eta, c.k),
        None => Spectrum::ONE,
    }
}

/// A smooth metal (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Conductor {
    /// The complex IOR, or none for a perfect mirror.
    pub ior: Option<ComplexIor>,
    /// Per-channel multiplier of the reflection, unitless.
    pub reflectance: Spectrum,
}

impl Conductor {
    /// A perfect mirror tinted by `tint`, unchecked: for tests and built-in scenes (RON's
    /// `Mirror(tint)` is this, checked).
    pub const fn perfect_mirror(tint: Spectrum) -> Conductor {
        Conductor {
            ior: None,
            reflectance: tint,
        }
    }

    /// A smooth metal of complex IOR `ior` (none: a perfect mirror) tinted by `reflectance`.
    pub fn new(ior: Option<ComplexIor>, reflectance: Spectrum) -> Result<Conductor, String> {
        Ok(Conductor {
            ior,
            reflectance: super::checks::reflectance("specular_reflectance", reflectance)?,
        })
    }
}

impl Bxdf for Conductor {
    #[inline]
    fn lobes(&self) -> Lobes {
        Lobes::DELTA_REFLECTION
    }

    fn eval(&self, _wo: Vec3A, _wi: Vec3A) -> Spectrum {
        Spectrum::ZERO
    }

    fn pdf(&self, _wo: Vec3A, _wi: Vec3A) -> f32 {
        0.0
    }

    fn sample(&self, wo: Vec3A, _u_lobe: f32, _u: Vec2) -> Option<BsdfSample> {
        let wi = Vec3A::new(-wo.x, -wo.y, wo.z);
        if wi.z <= 0.0 {
            return None;
        }
        let f = self.reflectance * conductor_fresnel(self.ior, wo.z);
        Some(BsdfSample {
            wi,
            f: f / wi.z,
            pdf: 1.0,
            specular: true,
            eta: 1.0,
        })
    }

    fn albedo(&self) -> Spectrum {
        self.reflectance * conductor_fresnel(self.ior, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::chi2::dir;

    #[test]
    fn reflects_the_fresnel_weighted_mirror_direction() {
        let gold = super::super::ior::metal("Au").unwrap();
        let c = Conductor::new(gold, Spectrum::ONE).unwrap();
        let wo = dir(60.0, 30.0);
        let s = c.sample(wo, 0.5, Vec2::splat(0.5)).unwrap();
        assert!(s.specular && (s.wi - Vec3A::new(-wo.x, -wo.y, wo.z)).length() < 1e-6);
        let expected = conductor_fresnel(gold, wo.z);
        assert!((s.weight() - expected).abs().max_element() < 1e-6);
        // Gold reflects red more than blue.
        assert!(expected.x > expected.z + 0.2, "{expected}");
        // No IOR: a perfect mirror, weighted by its tint alone.
        let mirror = Conductor::new(None, Spectrum::splat(0.7)).unwrap();
        let s = mirror.sample(wo, 0.5, Vec2::splat(0.5)).unwrap();
        assert!((s.weight() - Spectrum::splat(0.7)).abs().max_element() < 1e-6);
        assert!(ComplexIor::new(Spectrum::ONE, Spectrum::splat(-1.0)).is_err());
    }
}
