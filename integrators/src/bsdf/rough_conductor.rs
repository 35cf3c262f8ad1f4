//! Rough conductor: a metal whose surface is a microfacet distribution of mirrors (Walter et
//! al. 2007; Mitsuba 3's `roughconductor`, RON `RoughConductor`).
//!
//! ```text
//! f(wo, wi) = reflectance * F(wo.h) D(h) G(wo, wi, h) / (4 cos(wo) cos(wi)),  h = |wo + wi|
//! ```
//!
//! Parameters and units: as [`super::Conductor`] (the complex IOR or a perfect mirror, and the
//! `reflectance` tint), plus the [`Microfacet`] distribution (GGX or Beckmann, `alpha_u` and
//! `alpha_v`, unitless roughness in `(0, 2]`).
//!
//! Sampling draws a normal from the distribution (GGX: visible normals) and mirrors `wo` about
//! it; samples below the horizon are rejected, so the density integrates to less than one at
//! grazing angles. Single scattering only: light that would bounce between microfacets is lost,
//! so a white rough conductor reflects less than 1 (the white-furnace test measures how much).
//! Two-sided like every opaque material.

use super::conductor::{conductor_fresnel, ComplexIor};
use super::microfacet::{reflect, HalfVector, Microfacet};
use super::{BsdfSample, Bxdf, Lobes};
use crate::Spectrum;
use glam::{Vec2, Vec3A};

/// A rough metal (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct RoughConductor {
    pub ior: Option<ComplexIor>,
    pub reflectance: Spectrum,
    pub microfacet: Microfacet,
}

impl RoughConductor {
    /// A rough metal of complex IOR `ior` (none: perfect mirrors) tinted by `reflectance`.
    pub fn new(
        ior: Option<ComplexIor>,
        reflectance: Spectrum,
        microfacet: Microfacet,
    ) -> Result<RoughConductor, String> {
        Ok(RoughConductor {
            ior,
            reflectance: super::checks::reflectance("specular_reflectance", reflectance)?,
            microfacet,
        })
    }
}

impl RoughConductor {
    /// `f(wo, wi)` for upper-side directions with half vector `hv`.
    #[inline]
    fn value(&self, wo: Vec3A, wi: Vec3A, hv: &HalfVector) -> Spectrum {
        let d_g = hv.d * (hv.g1_wo * self.microfacet.g1(wi, hv.h));
        if d_g == 0.0 {
            return Spectrum::ZERO;
        }
        self.reflectance * conductor_fresnel(self.ior, wo.dot(hv.h)) * (d_g / (4.0 * wo.z * wi.z))
    }
}

impl Bxdf for RoughConductor {
    #[inline]
    fn lobes(&self) -> Lobes {
        Lobes::GLOSSY_REFLECTION
    }

    fn eval(&self, wo: Vec3A, wi: Vec3A) -> Spectrum {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Spectrum::ZERO;
        }
        self.value(wo, wi, &self.microfacet.half_vector(wo, wi))
    }

    fn pdf(&self, wo: Vec3A, wi: Vec3A) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        self.microfacet.half_vector(wo, wi).reflection_pdf(wo)
    }

    /// Both, with the half vector, its density and shadowing from `wo` computed once.
    fn eval_pdf(&self, wo: Vec3A, wi: Vec3A) -> (Spectrum, f32) {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return (Spectrum::ZERO, 0.0);
        }
        let hv = self.microfacet.half_vector(wo, wi);
        (self.value(wo, wi, &hv), hv.reflection_pdf(wo))
    }

    fn sample(&self, wo: Vec3A, _u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let m = self.microfacet.sample(wo, u);
        let wi = reflect(wo, m).normalize();
        if wi.z <= 0.0 || wo.dot(m) <= 0.0 {
            return None;
        }
        BsdfSample::evaluated(self, wo, wi)
    }

    fn albedo(&self) -> Spectrum {
        self.reflectance * conductor_fresnel(self.ior, 1.0)
    }
}
