//! The BSDF at a shading point, with what a normal or bump map adds beyond tilting the
//! shading normal. Mitsuba 3 (since 3.7) evaluates a mapped BSDF in the tilted frame, and:
//!
//! * passes only directions on the same side of the tilted and of the surface's own shading
//!   normal (its `cos_theta(wo) * cos_theta(perturbed_wo) > 0`);
//! * attenuates the value (not the density) by Estevez et al.'s microfacet shadowing term
//!   (Ray Tracing Gems, 2019, "A microfacet-based shadowing function to solve the bump
//!   terminator problem"): `G(w) = 2 / (1 + sqrt(1 + alpha^2 tan^2 theta_0(w)))`, with
//!   `alpha^2 = min(tan^2(tilt) / 8, 1)` and `theta_0` measured from the surface's own
//!   shading normal, for the direction leaving the point away from the path's arrival.
//!
//! [`MappedBsdf`] is the material as a [`Cow`] of [`Material`] (it dereferences to it) whose
//! `eval`, `pdf`, `eval_pdf`, `sample` and `sample_weight` apply both; without a map they are
//! the material's own. Its arguments are those of [`Material`]'s (local frame, `wo` first):
//! the term belongs to the direction that is not the arrival `wo` the point was built with,
//! which callers pass as either argument (a light subpath's vertex evaluates with the two
//! swapped), so the value carries `G(a) G(b) / G(arrival)`: `G` of the other direction
//! whichever it is.

use super::{BsdfSample, Material, TransportMode};
use crate::Rgb;
use glam::{Vec2, Vec3A};
use std::borrow::Cow;
use std::ops::Deref;

/// A normal or bump map's terms at one shading point, in its (tilted) shading frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapTerms {
    /// The surface's shading normal before the map, in the tilted frame.
    pub n0: Vec3A,
    /// Estevez's `alpha^2` of the tilt; 0 without the shadowing term.
    pub alpha2: f32,
    /// `G` of the arrival direction.
    pub g_arrival: f32,
}

impl MapTerms {
    /// The terms for a tilted frame in which the unperturbed normal is `n0`, with shadowing
    /// roughness `alpha2`, for a path arriving along `wo` (local).
    pub fn new(n0: Vec3A, alpha2: f32, wo: Vec3A) -> MapTerms {
        let mut t = MapTerms {
            n0,
            alpha2,
            g_arrival: 1.0,
        };
        t.g_arrival = t.shadowing(wo);
        t
    }

    /// Whether `w` lies on the same side of the tilted normal and of the unperturbed one.
    #[inline]
    fn passes(&self, w: Vec3A) -> bool {
        w.z * w.dot(self.n0) > 0.0
    }

    /// Estevez's shadowing of direction `w` (1 without the term).
    #[inline]
    fn shadowing(&self, w: Vec3A) -> f32 {
        if self.alpha2 == 0.0 {
            return 1.0;
        }
        let c2 = w.dot(self.n0).powi(2);
        let tan2 = (1.0 - c2).max(0.0) / c2;
        2.0 / (1.0 + (1.0 + self.alpha2 * tan2).sqrt())
    }

    /// The factor on `f(a, b)`: 0 across either normal, else `G` of the direction that is not
    /// the arrival.
    #[inline]
    fn factor(&self, a: Vec3A, b: Vec3A) -> f32 {
        if !(self.passes(a) && self.passes(b)) {
            return 0.0;
        }
        let g = self.shadowing(a) * self.shadowing(b) / self.g_arrival;
        if g.is_finite() {
            g
        } else {
            0.0
        }
    }
}

/// A shading point's BSDF: the material (looked up at the hit) and, under a normal or bump
/// map, the map's terms.
#[derive(Clone, Debug)]
pub struct MappedBsdf<'a> {
    pub material: Cow<'a, Material>,
    pub map: Option<MapTerms>,
}

impl Deref for MappedBsdf<'_> {
    type Target = Material;
    #[inline]
    fn deref(&self) -> &Material {
        &self.material
    }
}

impl<'a> MappedBsdf<'a> {
    /// A material without a map.
    pub fn plain(material: Cow<'a, Material>) -> MappedBsdf<'a> {
        MappedBsdf {
            material,
            map: None,
        }
    }

    /// The same, owning its material.
    pub fn into_owned(self) -> MappedBsdf<'static> {
        MappedBsdf {
            material: Cow::Owned(self.material.into_owned()),
            map: self.map,
        }
    }

    /// A copy borrowing this one's material.
    pub fn borrowed(&self) -> MappedBsdf<'_> {
        MappedBsdf {
            material: Cow::Borrowed(&self.material),
            map: self.map,
        }
    }

    /// [`Material::eval`] with the map's terms.
    #[inline]
    pub fn eval(&self, wo: Vec3A, wi: Vec3A) -> Rgb {
        match &self.map {
            None => self.material.eval(wo, wi),
            Some(m) => match m.factor(wo, wi) {
                0.0 => Rgb::ZERO,
                g => self.material.eval(wo, wi) * g,
            },
        }
    }

    /// [`Material::pdf`], zero across either normal.
    #[inline]
    pub fn pdf(&self, wo: Vec3A, wi: Vec3A) -> f32 {
        match &self.map {
            Some(m) if !(m.passes(wo) && m.passes(wi)) => 0.0,
            _ => self.material.pdf(wo, wi),
        }
    }

    /// [`Material::eval_pdf`] with the map's terms.
    #[inline]
    pub fn eval_pdf(&self, wo: Vec3A, wi: Vec3A) -> (Rgb, f32) {
        match &self.map {
            None => self.material.eval_pdf(wo, wi),
            Some(m) => match m.factor(wo, wi) {
                0.0 => (Rgb::ZERO, 0.0),
                g => {
                    let (f, pdf) = self.material.eval_pdf(wo, wi);
                    (f * g, pdf)
                }
            },
        }
    }

    /// [`Material::sample`]; `None` for a direction across either normal.
    #[inline]
    pub fn sample(&self, wo: Vec3A, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        let s = self.material.sample(wo, u_lobe, u)?;
        match &self.map {
            Some(m) if !m.passes(s.wi) => None,
            _ => Some(s),
        }
    }

    /// [`Material::sample_weight`] times the shadowing of the sampled direction.
    #[inline]
    pub fn sample_weight(&self, wo: Vec3A, s: &BsdfSample, mode: TransportMode) -> Rgb {
        let w = self.material.sample_weight(wo, s, mode);
        match &self.map {
            None => w,
            Some(m) => w * m.shadowing(s.wi),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::Lambert;

    fn lambert() -> Material {
        Material::Lambert(Lambert::new(Rgb::ONE).unwrap())
    }

    /// Without a tilt the terms change nothing; with one, the value of the direction that is
    /// not the arrival is shadowed whichever argument it is, directions across the surface's
    /// own normal are refused, and the density is untouched.
    #[test]
    fn the_terms_follow_the_direction_that_is_not_the_arrival() {
        let wo = Vec3A::new(0.0, 0.3, 1.0).normalize();
        let flat = MappedBsdf {
            material: Cow::Owned(lambert()),
            map: Some(MapTerms::new(Vec3A::Z, 0.0, wo)),
        };
        let wi = Vec3A::new(0.5, 0.0, 1.0).normalize();
        assert_eq!(flat.eval(wo, wi), lambert().eval(wo, wi));
        // The unperturbed normal leans 30 degrees towards -x in the tilted frame.
        let n0 = Vec3A::new(-0.5, 0.0, 0.75f32.sqrt());
        let alpha2 = (0.125f32 * (1.0 / 3.0)).min(1.0);
        let mapped = MappedBsdf {
            material: Cow::Owned(lambert()),
            map: Some(MapTerms::new(n0, alpha2, wo)),
        };
        let g = |w: Vec3A| {
            let c = w.dot(n0);
            2.0 / (1.0 + (1.0 + alpha2 * (1.0 - c * c) / (c * c)).sqrt())
        };
        let f = lambert().eval(wo, wi);
        for (a, b) in [(wo, wi), (wi, wo)] {
            let got = mapped.eval(a, b);
            assert!((got - f * g(wi)).abs().max_element() < 1e-6, "{got}");
            assert_eq!(mapped.pdf(a, b), lambert().pdf(a, b));
        }
        assert!(g(wi) < 1.0);
        // Above the tilted normal, below the unperturbed one: refused.
        let across = Vec3A::new(0.9, 0.0, 0.2).normalize();
        assert!(across.z > 0.0 && across.dot(n0) < 0.0);
        assert_eq!(mapped.eval(wo, across), Rgb::ZERO);
        assert_eq!(mapped.pdf(wo, across), 0.0);
    }
}
