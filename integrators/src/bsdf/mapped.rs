//! The BSDF at a shading point, with what a normal or bump map and a cut-out mask add to the
//! material's own model.
//!
//! **Maps.** Mitsuba 3 (since 3.7) evaluates a mapped BSDF in the tilted frame, and:
//!
//! * passes only directions on the same side of the tilted and of the surface's own shading
//!   normal (its `cos_theta(wo) * cos_theta(perturbed_wo) > 0`);
//! * attenuates the value (not the density) by Estevez et al.'s microfacet shadowing term
//!   (Ray Tracing Gems, 2019, "A microfacet-based shadowing function to solve the bump
//!   terminator problem"): `G(w) = 2 / (1 + sqrt(1 + alpha^2 tan^2 theta_0(w)))`, with
//!   `alpha^2 = min(tan^2(tilt) / 8, 1)` and `theta_0` measured from the surface's own
//!   shading normal, for the direction leaving the point away from the path's arrival.
//!
//! **Masks.** Mitsuba's `mask` of opacity `a`: the material's value and density times `a`,
//! and with probability `1 - a` a null event, a path going on straight through the surface
//! unchanged (a delta transmission of weight 1, `eta` 1). Shadow rays still stop at the
//! surface, as in Mitsuba 3's path tracer. The null lobe is taken when `u_lobe < 1 - a`, the
//! material's lobes above (rescaled), so that delta events stay those below
//! [`MappedBsdf::delta_probability`].
//!
//! [`MappedBsdf`] is the material as a [`Cow`] of [`Material`] (it dereferences to it) whose
//! `eval`, `pdf`, `eval_pdf`, `sample`, `sample_weight` and lobe queries apply both; without a
//! map or mask they are the material's own. Its arguments are those of [`Material`]'s (local
//! frame, `wo` first): the map's term belongs to the direction that is not the arrival `wo`
//! the point was built with, which callers pass as either argument (a light subpath's vertex
//! evaluates with the two swapped), so the value carries `G(a) G(b) / G(arrival)`: `G` of the
//! other direction whichever it is.

use super::{BsdfSample, Lobes, Material, TransportMode};
use crate::Spectrum;
use glam::{Vec2, Vec3A};
use std::borrow::Cow;
use std::ops::Deref;

/// A normal or bump map's terms at one shading point, in its (tilted) shading frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapTerms {
    /// The surface's shading normal before the map, in the tilted frame (unaligned: a
    /// shading point carries it beside the material).
    pub n0: glam::Vec3,
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
            n0: n0.into(),
            alpha2,
            g_arrival: 1.0,
        };
        t.g_arrival = t.shadowing(wo);
        t
    }

    /// Whether `w` lies on the same side of the tilted normal and of the unperturbed one.
    #[inline]
    fn passes(&self, w: Vec3A) -> bool {
        w.z * w.dot(Vec3A::from(self.n0)) > 0.0
    }

    /// Estevez's shadowing of direction `w` (1 without the term).
    #[inline]
    fn shadowing(&self, w: Vec3A) -> f32 {
        if self.alpha2 == 0.0 {
            return 1.0;
        }
        let c2 = w.dot(Vec3A::from(self.n0)).powi(2);
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
/// map, the map's terms; under a mask, its opacity there (1: opaque).
#[derive(Clone, Debug)]
pub struct MappedBsdf<'a> {
    pub material: Cow<'a, Material>,
    pub map: Option<MapTerms>,
    pub opacity: f32,
    /// Seen from the front only (Mitsuba 3's opaque BSDFs outside a `twosided`): nothing
    /// passes unless both directions lie above the shading normal, and nothing is sampled
    /// from behind it (a mask's null event still is).
    pub one_sided: bool,
}

impl Deref for MappedBsdf<'_> {
    type Target = Material;
    #[inline]
    fn deref(&self) -> &Material {
        &self.material
    }
}

impl<'a> MappedBsdf<'a> {
    /// A material without a map or mask.
    pub fn plain(material: Cow<'a, Material>) -> MappedBsdf<'a> {
        MappedBsdf {
            material,
            map: None,
            opacity: 1.0,
            one_sided: false,
        }
    }

    /// The same, owning its material.
    pub fn into_owned(self) -> MappedBsdf<'static> {
        MappedBsdf {
            material: Cow::Owned(self.material.into_owned()),
            map: self.map,
            opacity: self.opacity,
            one_sided: self.one_sided,
        }
    }

    /// A copy borrowing this one's material.
    pub fn borrowed(&self) -> MappedBsdf<'_> {
        MappedBsdf {
            material: Cow::Borrowed(&self.material),
            map: self.map,
            opacity: self.opacity,
            one_sided: self.one_sided,
        }
    }

    /// Whether a mask lets some paths through.
    #[inline]
    fn see_through(&self) -> bool {
        self.opacity < 1.0
    }

    /// The lobes: the material's, and a delta transmission where a mask lets paths through.
    #[inline]
    pub fn lobes(&self) -> Lobes {
        let own = if self.opacity > 0.0 {
            self.material.lobes()
        } else {
            Lobes::DELTA_TRANSMISSION
        };
        if self.see_through() {
            own.with(Lobes::DELTA_TRANSMISSION)
        } else {
            own
        }
    }

    /// See [`Material::is_transmissive`]: also a mask that lets paths through.
    #[inline]
    pub fn is_transmissive(&self) -> bool {
        self.lobes().any(Lobes::TRANSMISSION)
    }

    /// See [`Material::is_specular`].
    #[inline]
    pub fn is_specular(&self) -> bool {
        self.lobes().only(Lobes::DELTA)
    }

    /// See [`Material::has_delta_lobe`].
    #[inline]
    pub fn has_delta_lobe(&self) -> bool {
        self.lobes().any(Lobes::DELTA)
    }

    /// See [`Material::delta_probability`]: the null event's `1 - a`, and `a` times the
    /// material's.
    #[inline]
    pub fn delta_probability(&self, wo: Vec3A) -> f32 {
        if !self.see_through() {
            return self.material.delta_probability(wo);
        }
        (1.0 - self.opacity) + self.opacity * self.material.delta_probability(wo)
    }

    /// [`Material::eval`] with the map's terms and the mask's opacity.
    #[inline]
    pub fn eval(&self, wo: Vec3A, wi: Vec3A) -> Spectrum {
        if self.behind(wo, wi) {
            return Spectrum::ZERO;
        }
        let g = match &self.map {
            None => 1.0,
            Some(m) => m.factor(wo, wi),
        } * self.opacity;
        if g == 0.0 {
            return Spectrum::ZERO;
        }
        let f = self.material.eval(wo, wi);
        if g == 1.0 {
            f
        } else {
            f * g
        }
    }

    /// [`Material::pdf`], zero across either normal, times the mask's opacity.
    #[inline]
    pub fn pdf(&self, wo: Vec3A, wi: Vec3A) -> f32 {
        if self.behind(wo, wi) {
            return 0.0;
        }
        match &self.map {
            Some(m) if !(m.passes(wo) && m.passes(wi)) => 0.0,
            _ if self.see_through() => self.material.pdf(wo, wi) * self.opacity,
            _ => self.material.pdf(wo, wi),
        }
    }

    /// [`Material::eval_pdf`] with the map's terms and the mask's opacity.
    #[inline]
    pub fn eval_pdf(&self, wo: Vec3A, wi: Vec3A) -> (Spectrum, f32) {
        if self.behind(wo, wi) {
            return (Spectrum::ZERO, 0.0);
        }
        let g = match &self.map {
            None => 1.0,
            Some(m) => m.factor(wo, wi),
        };
        if g == 0.0 || self.opacity == 0.0 {
            return (Spectrum::ZERO, 0.0);
        }
        let (f, pdf) = self.material.eval_pdf(wo, wi);
        if g == 1.0 && !self.see_through() {
            (f, pdf)
        } else {
            (f * (g * self.opacity), pdf * self.opacity)
        }
    }

    /// [`Material::sample`]: under a mask, the null event or the material's lobes; `None` for
    /// a direction across either normal of a map.
    #[inline]
    pub fn sample(&self, wo: Vec3A, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        let mut u_lobe = u_lobe;
        if self.see_through() {
            let null = 1.0 - self.opacity;
            if u_lobe < null {
                // Straight on: weight f |cos| / pdf = 1.
                let wi = -wo;
                let cos = wi.z.abs();
                return (cos > 0.0).then_some(BsdfSample {
                    wi,
                    f: Spectrum::splat(null / cos),
                    pdf: null,
                    specular: true,
                    eta: 1.0,
                });
            }
            u_lobe = ((u_lobe - null) / self.opacity).min(1.0 - f32::EPSILON);
        }
        if self.one_sided && wo.z <= 0.0 {
            return None;
        }
        let mut s = self.material.sample(wo, u_lobe, u)?;
        if self.one_sided && s.wi.z <= 0.0 {
            return None;
        }
        if let Some(m) = &self.map {
            if !m.passes(s.wi) {
                return None;
            }
        }
        if self.see_through() {
            s.f *= self.opacity;
            s.pdf *= self.opacity;
        }
        Some(s)
    }

    /// What passes straight through the surface from `wo`'s side, undeviated (Mitsuba 3's
    /// `eval_null_transmission`): a mask's null event, and a thin dielectric's transmission.
    /// Volumetric tracers count such a crossing as no scattering event, and let shadow rays
    /// through with this weight.
    #[inline]
    pub fn null_transmission(&self, wo: Vec3A) -> Spectrum {
        let own = if self.opacity > 0.0 {
            self.material.null_transmission(wo) * self.opacity
        } else {
            Spectrum::ZERO
        };
        Spectrum::splat(1.0 - self.opacity) + own
    }

    /// Whether a one-sided material sees `wo` or `wi` from behind.
    #[inline]
    fn behind(&self, wo: Vec3A, wi: Vec3A) -> bool {
        self.one_sided && !(wo.z > 0.0 && wi.z > 0.0)
    }

    /// [`Material::sample_weight`] times the shadowing of the sampled direction.
    #[inline]
    pub fn sample_weight(&self, wo: Vec3A, s: &BsdfSample, mode: TransportMode) -> Spectrum {
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
        Material::Lambert(Lambert::new(Spectrum::ONE).unwrap())
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
            opacity: 1.0,
            one_sided: false,
        };
        let wi = Vec3A::new(0.5, 0.0, 1.0).normalize();
        assert_eq!(flat.eval(wo, wi), lambert().eval(wo, wi));
        // The unperturbed normal leans 30 degrees towards -x in the tilted frame.
        let n0 = Vec3A::new(-0.5, 0.0, 0.75f32.sqrt());
        let alpha2 = (0.125f32 * (1.0 / 3.0)).min(1.0);
        let mapped = MappedBsdf {
            material: Cow::Owned(lambert()),
            map: Some(MapTerms::new(n0, alpha2, wo)),
            opacity: 1.0,
            one_sided: false,
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
        assert_eq!(mapped.eval(wo, across), Spectrum::ZERO);
        assert_eq!(mapped.pdf(wo, across), 0.0);
    }

    /// A mask of opacity a: value and density times a; the null event with probability 1 - a,
    /// straight through with weight 1; the delta probability and lobes say so.
    #[test]
    fn a_mask_scales_the_material_and_lets_the_rest_through() {
        let m = MappedBsdf {
            material: Cow::Owned(lambert()),
            map: None,
            opacity: 0.3,
            one_sided: false,
        };
        let (wo, wi) = (Vec3A::new(0.0, 0.3, 1.0).normalize(), Vec3A::Z);
        assert!(
            (m.eval(wo, wi) - lambert().eval(wo, wi) * 0.3)
                .abs()
                .max_element()
                < 1e-7
        );
        assert!((m.pdf(wo, wi) - lambert().pdf(wo, wi) * 0.3).abs() < 1e-7);
        assert!(m.has_delta_lobe() && m.is_transmissive() && !m.is_specular());
        assert!((m.delta_probability(wo) - 0.7).abs() < 1e-7);
        let mut s = crate::Sampler::new(5, 0, 0);
        let (mut through, n) = (0, 20_000);
        for _ in 0..n {
            let u_lobe = s.next_1d();
            let b = m.sample(wo, u_lobe, s.next_2d()).expect("a sample");
            assert_eq!(b.specular, u_lobe < m.delta_probability(wo));
            if b.specular {
                through += 1;
                assert_eq!(b.wi, -wo);
                assert!((b.weight() - Spectrum::ONE).abs().max_element() < 1e-5);
            } else {
                assert!((m.pdf(wo, b.wi) - b.pdf).abs() < 1e-5 * b.pdf);
                assert!((m.eval(wo, b.wi) - b.f).abs().max_element() < 1e-6);
            }
        }
        assert!((through as f64 / n as f64 - 0.7).abs() < 0.02);
    }
}
