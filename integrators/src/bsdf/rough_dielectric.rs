//! Rough dielectric: frosted glass, a microfacet distribution of smooth dielectric facets
//! (Walter et al. 2007, "Microfacet models for refraction through rough surfaces"; Mitsuba 3's
//! `roughdielectric`, RON `RoughDielectric`).
//!
//! With `eta` the relative IOR of `wi`'s side over `wo`'s side, `h` the half vector (for
//! reflection `wo + wi`, for refraction `wo + eta wi`, normalised and turned to `z > 0`), `F`
//! the dielectric Fresnel term at `wo.h`, `D` and `G` the [`Microfacet`] terms:
//!
//! ```text
//! reflection:  f = reflectance   F D G / (4 |cos(wo) cos(wi)|)
//! refraction:  f = transmittance (1 - F) D G |wo.h| |wi.h| / (|cos(wo) cos(wi)| (wo.h + eta wi.h)^2)
//! ```
//!
//! The refraction lobe is the radiance form (it carries the `1 / eta^2` compression of
//! radiance; a path carrying importance takes `eta^2` times its weight, see
//! [`super::Material::sample_weight`]). Sampling: a normal from the distribution (GGX: visible
//! from `wo`), then reflection with probability `F` and refraction otherwise, so the density is
//! `pdf(m) F / (4 |wo.m|)` or `pdf(m) (1 - F) eta^2 |wi.m| / (wo.m + eta wi.m)^2`. Parameters:
//! `ior` as [`super::Dielectric`], the two tints, and the distribution. Like the smooth
//! dielectric it sees the true side (`wo.z > 0`: arriving from outside).

use super::fresnel::fresnel_dielectric;
use super::microfacet::{reflect, refract, Microfacet};
use super::{BsdfSample, Bxdf, Lobes};
use crate::Spectrum;
use glam::{Vec2, Vec3A};

/// Frosted glass (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct RoughDielectric {
    pub ior: f32,
    pub reflectance: Spectrum,
    pub transmittance: Spectrum,
    pub microfacet: Microfacet,
}

/// The geometry of a pair of directions at a rough interface: the microfacet normal that
/// connects them, the relative IOR and the Fresnel reflectance there.
struct Facet {
    h: Vec3A,
    reflect: bool,
    /// IOR of `wi`'s side over `wo`'s side.
    eta: f32,
    fresnel: f32,
}

impl RoughDielectric {
    /// Frosted glass of relative IOR `ior`, tinted per lobe, roughened by `microfacet`.
    pub fn new(
        ior: f32,
        reflectance: Spectrum,
        transmittance: Spectrum,
        microfacet: Microfacet,
    ) -> Result<RoughDielectric, String> {
        let d = super::Dielectric::new(ior, reflectance, transmittance)?;
        Ok(RoughDielectric {
            ior: d.ior,
            reflectance: d.reflectance,
            transmittance: d.transmittance,
            microfacet,
        })
    }

    /// The facet joining `wo` and `wi`, or `None` when none can (a direction in the surface's
    /// plane, or one that would see the facet's back).
    #[inline]
    fn facet(&self, wo: Vec3A, wi: Vec3A) -> Option<Facet> {
        if wo.z == 0.0 || wi.z == 0.0 {
            return None;
        }
        let reflect = wo.z * wi.z > 0.0;
        let eta = if wo.z > 0.0 { self.ior } else { 1.0 / self.ior };
        let h = if reflect { wo + wi } else { wo + wi * eta };
        let len2 = h.length_squared();
        if !(len2 > 0.0 && len2.is_finite()) {
            return None;
        }
        let h = h / len2.sqrt();
        let h = if h.z < 0.0 { -h } else { h };
        // Each direction must see the facet's front from its own side.
        if wo.dot(h) * wo.z <= 0.0 || wi.dot(h) * wi.z <= 0.0 {
            return None;
        }
        Some(Facet {
            h,
            reflect,
            eta,
            fresnel: fresnel_dielectric(wo.dot(h), self.ior),
        })
    }
}

impl Bxdf for RoughDielectric {
    #[inline]
    fn lobes(&self) -> Lobes {
        Lobes::GLOSSY_REFLECTION.with(Lobes::GLOSSY_TRANSMISSION)
    }

    fn eval(&self, wo: Vec3A, wi: Vec3A) -> Spectrum {
        let Some(fc) = self.facet(wo, wi) else {
            return Spectrum::ZERO;
        };
        let mf = &self.microfacet;
        let d_g = mf.d(fc.h) * mf.g(wo, wi, fc.h);
        if d_g == 0.0 {
            return Spectrum::ZERO;
        }
        let cos = (wo.z * wi.z).abs();
        if fc.reflect {
            self.reflectance * (fc.fresnel * d_g / (4.0 * cos))
        } else {
            let (oh, ih) = (wo.dot(fc.h), wi.dot(fc.h));
            let denom = oh + fc.eta * ih;
            self.transmittance
                * ((1.0 - fc.fresnel) * d_g * (oh * ih).abs() / (cos * denom * denom))
        }
    }

    fn pdf(&self, wo: Vec3A, wi: Vec3A) -> f32 {
        let Some(fc) = self.facet(wo, wi) else {
            return 0.0;
        };
        let up = if wo.z > 0.0 { wo } else { -wo };
        let pdf_m = self.microfacet.pdf(up, fc.h);
        let (oh, ih) = (wo.dot(fc.h), wi.dot(fc.h));
        if fc.reflect {
            pdf_m * fc.fresnel / (4.0 * oh.abs())
        } else {
            let denom = oh + fc.eta * ih;
            pdf_m * (1.0 - fc.fresnel) * fc.eta * fc.eta * ih.abs() / (denom * denom)
        }
    }

    fn sample(&self, wo: Vec3A, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z == 0.0 || !wo.is_finite() {
            return None;
        }
        let up = if wo.z > 0.0 { wo } else { -wo };
        let m = self.microfacet.sample(up, u);
        let cos = wo.dot(m);
        if cos * wo.z <= 0.0 {
            return None; // wo sees the facet's back (rounding at grazing angles)
        }
        let fresnel = fresnel_dielectric(cos, self.ior);
        let eta = if wo.z > 0.0 { self.ior } else { 1.0 / self.ior };
        let reflected = u_lobe < fresnel;
        let (wi, eta) = if reflected {
            (reflect(wo, m).normalize(), 1.0)
        } else {
            (refract(wo, m, eta)?.normalize(), eta)
        };
        // The lobe must leave on its own side: reflection on wo's, refraction on the other.
        if (wi.z * wo.z > 0.0) != reflected || wi.z == 0.0 {
            return None;
        }
        BsdfSample::evaluated(self, wo, wi).map(|s| BsdfSample { eta, ..s })
    }

    fn albedo(&self) -> Spectrum {
        self.reflectance
    }
}
