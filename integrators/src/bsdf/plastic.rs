//! Smooth plastic: a diffuse base under a smooth dielectric coating (Mitsuba 3's `plastic`;
//! RON `Plastic`).
//!
//! Light either reflects off the coating (a Dirac lobe weighted by the Fresnel reflectance
//! `F(wo)` and `specular_reflectance`) or enters it, scatters diffusely in the base, possibly
//! several times between base and coating, and leaves:
//!
//! ```text
//! f_diffuse(wo, wi) = rho' (1 - F(wo)) (1 - F(wi)) / (eta^2 pi)
//! rho' = rho / (1 - F_dr)            (linear: Mitsuba's default)
//! rho' = rho / (1 - rho F_dr)        (nonlinear: the internal bounces tint, as wet paint)
//! ```
//!
//! with `F_dr` the coating's diffuse reflectance seen from inside
//! ([`super::fresnel::fresnel_diffuse_reflectance`] of `1 / eta`). Parameters: `diffuse` (`rho`,
//! in `[0, 1]`), `specular` (the coating's tint, in `[0, 1]`), `ior` (`int_ior / ext_ior`),
//! `nonlinear`.
//!
//! Sampling picks the coating's reflection with probability `F(wo) s / (F(wo) s + (1 - F(wo))
//! (1 - s))`, `s` the mean specular tint over the sum of the mean tints (Mitsuba's
//! `specular_sampling_weight`), and a cosine-weighted direction otherwise. Two-sided like every
//! opaque material. A mixed material: [`super::Material::has_delta_lobe`] is true, so
//! Whitted-style tracers follow the coating's reflection and light the base directly.

use super::fresnel::{fresnel_dielectric, fresnel_diffuse_reflectance};
use super::{BsdfSample, Bxdf, Lobes};
use crate::Spectrum;
use glam::{Vec2, Vec3A};
use std::f32::consts::FRAC_1_PI;

/// Smooth plastic (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Plastic {
    pub diffuse: Spectrum,
    pub specular: Spectrum,
    pub ior: f32,
    pub nonlinear: bool,
    /// Internal diffuse reflectance of the coating, `F_dr(1 / ior)`.
    fdr_int: f32,
    /// Mitsuba's `specular_sampling_weight`.
    specular_weight: f32,
}

/// The checked parameters and precomputed constants every coated material shares.
pub(super) struct Coating {
    pub diffuse: Spectrum,
    pub specular: Spectrum,
    pub specular_weight: f32,
}

impl Coating {
    pub(super) fn new(diffuse: Spectrum, specular: Spectrum, ior: f32) -> Result<Coating, String> {
        let diffuse = super::checks::reflectance("diffuse_reflectance", diffuse)?;
        let specular = super::checks::reflectance("specular_reflectance", specular)?;
        super::checks::finite("ior", &[ior])?;
        if !(ior > 1.0 && ior <= 4.0) {
            return Err(format!(
                "a coating's ior int_ior / ext_ior must be in (1, 4], got {ior}"
            ));
        }
        let (d, s) = (mean(diffuse), mean(specular));
        Ok(Coating {
            diffuse,
            specular,
            specular_weight: if d + s > 0.0 { s / (d + s) } else { 0.0 },
        })
    }
}

/// The mean of a colour's channels.
#[inline]
fn mean(c: Spectrum) -> f32 {
    (c.x + c.y + c.z) / 3.0
}

/// Probability of choosing the coating's lobe given its reflectance `f` there (Fresnel
/// reflectance, or the rough coating's specular albedo) and the sampling weight.
#[inline]
pub(super) fn coating_probability(f: f32, specular_weight: f32) -> f32 {
    let s = f * specular_weight;
    let d = (1.0 - f) * (1.0 - specular_weight);
    if s + d > 0.0 {
        s / (s + d)
    } else {
        0.0
    }
}

/// `rho'`: the base's reflectance with the internal bounces summed.
#[inline]
pub(super) fn multiple_bounces(diffuse: Spectrum, internal: f32, nonlinear: bool) -> Spectrum {
    if nonlinear {
        diffuse / (Spectrum::ONE - diffuse * internal)
    } else {
        diffuse / (1.0 - internal)
    }
}

impl Plastic {
    /// Smooth plastic with base `diffuse`, coating tint `specular`, relative IOR `ior` (> 1).
    pub fn new(
        diffuse: Spectrum,
        specular: Spectrum,
        ior: f32,
        nonlinear: bool,
    ) -> Result<Plastic, String> {
        let c = Coating::new(diffuse, specular, ior)?;
        Ok(Plastic {
            diffuse: c.diffuse,
            specular: c.specular,
            ior,
            nonlinear,
            fdr_int: fresnel_diffuse_reflectance(1.0 / ior),
            specular_weight: c.specular_weight,
        })
    }

    /// Probability of sampling the coating's reflection at incidence `cos` (> 0): `sample`
    /// picks it exactly when `u_lobe` is below this.
    #[inline]
    pub fn coating_probability(&self, cos: f32) -> f32 {
        coating_probability(fresnel_dielectric(cos, self.ior), self.specular_weight)
    }

    /// The diffuse part for two upper-side directions.
    #[inline]
    fn diffuse_part(&self, wo: Vec3A, wi: Vec3A) -> Spectrum {
        let t =
            (1.0 - fresnel_dielectric(wo.z, self.ior)) * (1.0 - fresnel_dielectric(wi.z, self.ior));
        multiple_bounces(self.diffuse, self.fdr_int, self.nonlinear)
            * (t * FRAC_1_PI / (self.ior * self.ior))
    }
}

impl Bxdf for Plastic {
    #[inline]
    fn lobes(&self) -> Lobes {
        Lobes::DELTA_REFLECTION.with(Lobes::DIFFUSE_REFLECTION)
    }

    fn eval(&self, wo: Vec3A, wi: Vec3A) -> Spectrum {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Spectrum::ZERO;
        }
        self.diffuse_part(wo, wi)
    }

    fn pdf(&self, wo: Vec3A, wi: Vec3A) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        (1.0 - self.coating_probability(wo.z)) * wi.z * FRAC_1_PI
    }

    fn sample(&self, wo: Vec3A, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let fresnel = fresnel_dielectric(wo.z, self.ior);
        let p = coating_probability(fresnel, self.specular_weight);
        if u_lobe < p {
            let wi = Vec3A::new(-wo.x, -wo.y, wo.z);
            return Some(BsdfSample {
                wi,
                f: self.specular * (fresnel / wi.z),
                pdf: p,
                specular: true,
                eta: 1.0,
            });
        }
        let wi = crate::sampling::cosine_hemisphere(u);
        let pdf = (1.0 - p) * wi.z * FRAC_1_PI;
        (pdf > 0.0).then(|| BsdfSample::reflection(wi, self.diffuse_part(wo, wi), pdf))
    }

    fn albedo(&self) -> Spectrum {
        self.diffuse
    }
}
