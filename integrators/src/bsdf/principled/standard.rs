//! Mitsuba 3's `principled` (RON `Principled`): Burley's diffuse base with a sheen, a GGX
//! dielectric specular that a metal blends into, an optional glossy transmission, and a
//! clear coat of Berry's distribution.
//!
//! With `brdf = (1 - metallic)(1 - spec_trans)` and `bsdf = (1 - metallic) spec_trans`, the
//! front side holds (cosine-free; `F` the dielectric Fresnel at the half vector `h`, `D`, `G`
//! the GGX terms of `alpha = roughness^2` stretched by the anisotropy):
//!
//! ```text
//! specular reflection  F' D G / (4 |cos v cos l|),  F' = (1 - metallic)(1 - spec_tint) F
//!                      + metallic Schlick(base) + (1 - metallic) spec_tint Schlick(tint R0)
//! transmission         sqrt(base) bsdf (1 - F) D G |v.h l.h| / (|cos v cos l| (v.h + eta l.h)^2)
//! clear coat           clearcoat / 4  Schlick(0.04) D_gtr1 G_ggx(0.25)
//! diffuse              brdf base / pi  Burley's diffuse (and flatness)
//! sheen                sheen (1 - metallic) Schlick weight at l.h  (tinted by sheen_tint)
//! ```
//!
//! (the clear coat's value is Mitsuba's as it is, without the microfacet's `1 / 4 cos cos`).
//! From the back side, only a transmitting material answers, with the plain dielectric.
//! Sampling picks diffuse, clear coat, transmission or reflection with Mitsuba's probabilities
//! (their sum does not depend on the Fresnel term, so the density is exactly the mixture's);
//! the specular lobes sample GGX's visible normals, the coat Berry's distribution. `eta` is
//! given or comes from `specular` (`eta = 2 / (1 - sqrt(0.08 specular)) - 1`). Unbiased. Without
//! `spec_trans` the material is opaque, and two-sided as every opaque model of the crate
//! (Mitsuba's is black from behind).

use super::{compatible, cosine_pdf, mulsign, schlick, schlick_r0, Burley, Gtr1};
use crate::bsdf::fresnel::fresnel_dielectric;
use crate::bsdf::microfacet::{reflect, refract};
use crate::bsdf::{BsdfSample, Bxdf, Lobes};
use crate::Spectrum;
use glam::{Vec2, Vec3A};

/// How often each lobe is sampled, relative to Mitsuba's weights (all 1 by default):
/// `main_specular_sampling_rate`, `clearcoat_sampling_rate`,
/// `diffuse_reflectance_sampling_rate`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrincipledRates {
    pub specular: f32,
    pub clearcoat: f32,
    pub diffuse: f32,
}

impl Default for PrincipledRates {
    fn default() -> Self {
        PrincipledRates {
            specular: 1.0,
            clearcoat: 1.0,
            diffuse: 1.0,
        }
    }
}

/// Mitsuba 3's principled BSDF (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Principled {
    pub burley: Burley,
    pub metallic: f32,
    pub clearcoat: f32,
    /// The coat's gloss: its roughness runs from 0.1 (0) to 0.001 (1).
    pub clearcoat_gloss: f32,
    /// Relative IOR of the dielectric.
    pub eta: f32,
    /// Whether the material transmits (`spec_trans` was given): only then is it seen from
    /// behind and has a transmission lobe.
    pub transmits: bool,
    pub rates: PrincipledRates,
}

/// Mitsuba's lobe probabilities at one pair of directions, normalised.
struct Probabilities {
    spec_reflect: f32,
    spec_trans: f32,
    clearcoat: f32,
    diffuse: f32,
}

impl Principled {
    /// A checked model: parameters in `[0, 1]`, `eta > 0` (1 nudged to 1.001 when the
    /// material transmits, as Mitsuba does), rates non-negative with one positive.
    pub fn new(
        burley: Burley,
        metallic: f32,
        clearcoat: f32,
        clearcoat_gloss: f32,
        eta: f32,
        transmits: bool,
        rates: PrincipledRates,
    ) -> Result<Principled, String> {
        burley.check()?;
        for (name, x) in [
            ("metallic", metallic),
            ("clearcoat", clearcoat),
            ("clearcoat_gloss", clearcoat_gloss),
        ] {
            if !(0.0..=1.0).contains(&x) {
                return Err(format!("`{name}` must lie in [0, 1], got {x}"));
            }
        }
        if !(eta > 0.0 && eta.is_finite()) {
            return Err(format!("`eta` must be positive and finite, got {eta}"));
        }
        let r = [rates.specular, rates.clearcoat, rates.diffuse];
        if r.iter().any(|x| !(*x >= 0.0 && x.is_finite())) || rates.specular <= 0.0 {
            return Err(format!(
                "the sampling rates must be finite and non-negative, the specular one positive, got {r:?}"
            ));
        }
        Ok(Principled {
            burley,
            metallic,
            clearcoat,
            clearcoat_gloss,
            eta: if transmits && eta == 1.0 { 1.001 } else { eta },
            transmits,
            rates,
        })
    }

    /// The relative IOR Mitsuba makes from `specular` (0 nudged to 0.001 when the material
    /// transmits: eta 1 cannot refract).
    pub fn eta_from_specular(specular: f32, transmits: bool) -> f32 {
        let s = if transmits && specular == 0.0 {
            1e-3
        } else {
            specular
        };
        2.0 / (1.0 - (0.08 * s).sqrt()) - 1.0
    }

    /// `(1 - metallic)(1 - spec_trans)` and `(1 - metallic) spec_trans`.
    #[inline]
    fn weights(&self) -> (f32, f32) {
        let dielectric = 1.0 - self.metallic;
        let spec_trans = if self.transmits {
            self.burley.spec_trans
        } else {
            0.0
        };
        (dielectric * (1.0 - spec_trans), dielectric * spec_trans)
    }

    /// The coat's distribution.
    #[inline]
    fn coat(&self) -> Gtr1 {
        Gtr1 {
            alpha: 0.1 + (0.001 - 0.1) * self.clearcoat_gloss,
        }
    }

    /// The lobes' probabilities on side `front` where the dielectric reflects `f`.
    #[inline]
    fn probabilities(&self, front: bool, f: f32) -> Probabilities {
        let (brdf, bsdf) = self.weights();
        let r = &self.rates;
        let mut p = if front {
            Probabilities {
                spec_reflect: r.specular * (1.0 - bsdf * (1.0 - f)),
                spec_trans: if self.transmits {
                    r.specular * bsdf * (1.0 - f)
                } else {
                    0.0
                },
                clearcoat: 0.25 * self.clearcoat * r.clearcoat,
                diffuse: brdf * r.diffuse,
            }
        } else {
            Probabilities {
                spec_reflect: f,
                spec_trans: if self.transmits { 1.0 - f } else { 0.0 },
                clearcoat: 0.0,
                diffuse: 0.0,
            }
        };
        let total = p.spec_reflect + p.spec_trans + p.clearcoat + p.diffuse;
        let k = 1.0 / total;
        p.spec_reflect *= k;
        p.spec_trans *= k;
        p.clearcoat *= k;
        p.diffuse *= k;
        p
    }

    /// The half vector of `v` and `l` (turned up), their relative IOR along the path, and
    /// whether they reflect.
    #[inline]
    fn half_vector(&self, v: Vec3A, l: Vec3A) -> (Vec3A, f32, bool) {
        let reflect = v.z * l.z > 0.0;
        let eta_path = if v.z > 0.0 { self.eta } else { 1.0 / self.eta };
        let h = (v + l * if reflect { 1.0 } else { eta_path }).normalize_or_zero();
        (mulsign(h, h.z), eta_path, reflect)
    }

    /// The specular reflection's Fresnel term `F'` (see the module docs).
    #[inline]
    fn fresnel(&self, f: f32, cos_vh: f32, front: bool) -> Spectrum {
        let b = &self.burley;
        let (_, bsdf) = self.weights();
        if !front {
            return Spectrum::splat(bsdf * f);
        }
        let mut schlicks = Spectrum::ZERO;
        if self.metallic > 0.0 {
            schlicks += self.metallic * schlick(b.base_color, cos_vh, self.eta);
        }
        if b.spec_tint > 0.0 {
            let eta_it = if cos_vh >= 0.0 {
                self.eta
            } else {
                1.0 / self.eta
            };
            let r0 = b.tint() * schlick_r0(eta_it);
            schlicks += (1.0 - self.metallic) * b.spec_tint * schlick(r0, cos_vh, self.eta);
        }
        Spectrum::splat((1.0 - self.metallic) * (1.0 - b.spec_tint) * f) + schlicks
    }

    fn value(&self, v: Vec3A, l: Vec3A) -> Spectrum {
        let b = &self.burley;
        let (cos_v, cos_l) = (v.z, l.z);
        if cos_v == 0.0 || cos_l == 0.0 {
            return Spectrum::ZERO;
        }
        let (brdf, bsdf) = self.weights();
        let front = cos_v > 0.0;
        let (h, eta_path, reflect) = self.half_vector(v, l);
        let refract = !reflect;
        let f = fresnel_dielectric(v.dot(h), self.eta);
        let reflection_ok = compatible(h, v, l, cos_v, true);
        let refraction_ok = compatible(h, v, l, cos_v, false);
        let mf = b.distribution(b.roughness);
        let (d, g) = (mf.d(h), mf.g(v, l, h));
        let cos_vl = (cos_v * cos_l).abs();
        let mut value = Spectrum::ZERO;
        if reflect && reflection_ok && f > 0.0 {
            value += self.fresnel(f, v.dot(h), front) * (d * g / (4.0 * cos_vl));
        }
        if self.transmits && bsdf > 0.0 && refract && refraction_ok && f < 1.0 {
            let (vh, lh) = (v.dot(h), l.dot(h));
            let denom = vh + eta_path * lh;
            let t = ((1.0 - f) * d * g * vh * lh / (cos_vl * denom * denom)).abs();
            value += b.base_color.map(f32::sqrt) * (bsdf * t);
        }
        if !(front && reflect) {
            return value;
        }
        if self.clearcoat > 0.0 && reflection_ok {
            let fcc = schlick(Spectrum::splat(0.04), v.dot(h), self.eta).x;
            let g_cc = super::clearcoat_g1(v, h, 0.25) * super::clearcoat_g1(l, h, 0.25);
            value += Spectrum::splat(self.clearcoat * 0.25 * fcc * self.coat().d(h) * g_cc);
        }
        let cos_d = h.dot(l);
        if brdf > 0.0 {
            value += b.base_color
                * (brdf * std::f32::consts::FRAC_1_PI * b.diffuse(cos_v, cos_l, cos_d));
        }
        if b.sheen > 0.0 && self.metallic < 1.0 {
            value += b.sheen(cos_d) * (1.0 - self.metallic);
        }
        value
    }

    fn density(&self, v: Vec3A, l: Vec3A) -> f32 {
        let cos_v = v.z;
        if cos_v == 0.0 {
            return 0.0;
        }
        let b = &self.burley;
        let front = cos_v > 0.0;
        let (h, eta_path, reflect) = self.half_vector(v, l);
        let f = fresnel_dielectric(v.dot(h), self.eta);
        let p = self.probabilities(front, f);
        let (vh, lh) = (v.dot(h), l.dot(h));
        let jacobian = if reflect || !self.transmits {
            (1.0 / (4.0 * lh)).abs()
        } else {
            let denom = vh + eta_path * lh;
            (eta_path * eta_path * lh / (denom * denom)).abs()
        };
        let mf = b.distribution(b.roughness);
        let v_up = mulsign(v, cos_v);
        let mut pdf = 0.0;
        let reflection_ok = reflect && compatible(h, v, l, cos_v, true);
        if reflection_ok {
            pdf += p.spec_reflect * mf.pdf(v_up, h) * jacobian;
        }
        if reflect {
            pdf += p.diffuse * cosine_pdf(l);
        }
        if self.transmits && !reflect && compatible(h, v, l, cos_v, false) {
            pdf += p.spec_trans * mf.pdf(v_up, h) * jacobian;
        }
        if self.clearcoat > 0.0 && reflection_ok {
            pdf += p.clearcoat * self.coat().pdf(h) * jacobian;
        }
        pdf
    }
}

impl Bxdf for Principled {
    fn lobes(&self) -> Lobes {
        let reflection = Lobes::DIFFUSE_REFLECTION.with(Lobes::GLOSSY_REFLECTION);
        if self.transmits {
            reflection.with(Lobes::GLOSSY_TRANSMISSION)
        } else {
            reflection
        }
    }

    fn eval(&self, wo: Vec3A, wi: Vec3A) -> Spectrum {
        self.value(wo, wi)
    }

    fn pdf(&self, wo: Vec3A, wi: Vec3A) -> f32 {
        self.density(wo, wi)
    }

    fn sample(&self, wo: Vec3A, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        let v = wo;
        let cos_v = v.z;
        let front = cos_v > 0.0;
        let (_, bsdf) = self.weights();
        if cos_v == 0.0 || !(front || bsdf > 0.0) {
            return None;
        }
        let b = &self.burley;
        let mf = b.distribution(b.roughness);
        let m = mf.sample(mulsign(v, cos_v), u);
        let f = fresnel_dielectric(v.dot(m), self.eta);
        let p = self.probabilities(front, f);
        let mut eta = 1.0;
        let l = if u_lobe < p.diffuse {
            let l = crate::sampling::cosine_hemisphere(u);
            (cos_v * l.z > 0.0).then_some(l)?
        } else if u_lobe < p.diffuse + p.clearcoat {
            let m = self.coat().sample(u);
            let l = reflect(v, m);
            (cos_v * l.z > 0.0 && compatible(m, v, l, cos_v, true)).then_some(l)?
        } else if u_lobe < p.diffuse + p.clearcoat + p.spec_trans {
            eta = if v.dot(m) >= 0.0 {
                self.eta
            } else {
                1.0 / self.eta
            };
            let l = refract(v, m, eta)?;
            (cos_v * l.z < 0.0 && compatible(m, v, l, cos_v, false)).then_some(l)?
        } else {
            let l = reflect(v, m);
            (cos_v * l.z > 0.0 && compatible(m, v, l, cos_v, true)).then_some(l)?
        };
        let (f, pdf) = self.eval_pdf(v, l);
        (pdf > 0.0 && pdf.is_finite()).then_some(BsdfSample {
            wi: l,
            f,
            pdf,
            specular: false,
            eta,
        })
    }

    fn albedo(&self) -> Spectrum {
        self.burley.base_color
    }
}
