//! Mitsuba 3's `principledthin` (RON `PrincipledThin`): Burley's model for a sheet with no
//! inside (a leaf, paper, a curtain), the same from both faces. Both directions are turned to
//! the viewer's face first; then (cosine-free, `h` the half vector of `v` and `l` mirrored to
//! `v`'s face, `F` the dielectric Fresnel of IOR `eta` there, `dt = diff_trans / 2`):
//!
//! ```text
//! specular reflection    spec_trans F_tint D G / (4 |cos v cos l|)   (F tinted by spec_tint)
//! specular transmission  spec_trans base (1 - F) D' G' / (4 |cos v cos l|)   (l through the sheet)
//! diffuse reflection     (1 - spec_trans)(1 - dt) base / pi  Burley's diffuse, plus the sheen
//! diffuse transmission   (1 - spec_trans) dt base / pi
//! ```
//!
//! `D'`, `G'` belong to the roughness scaled by `0.65 eta - 0.35` (Burley 2015's thin-surface
//! roughening). The transmitted direction is the reflected one mirrored through the sheet, so
//! nothing bends (`eta` 1 for the path). Sampling picks a lobe with Mitsuba's probabilities
//! (independent of the directions): the specular lobes sample GGX's visible normals, the
//! diffuse ones the cosine. Unbiased. `diff_trans` runs over `[0, 2]` as in Mitsuba.

use super::{compatible, cosine_pdf, Burley};
use crate::bsdf::fresnel::fresnel_dielectric;
use crate::bsdf::microfacet::reflect;
use crate::bsdf::{BsdfSample, Bxdf, Lobes};
use crate::Spectrum;
use glam::{Vec2, Vec3A};
use std::f32::consts::FRAC_1_PI;

/// How often each lobe is sampled relative to Mitsuba's weights (all 1 by default):
/// `specular_reflectance_sampling_rate`, `specular_transmittance_sampling_rate`,
/// `diffuse_reflectance_sampling_rate`, `diffuse_transmittance_sampling_rate`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThinRates {
    pub specular_reflection: f32,
    pub specular_transmission: f32,
    pub diffuse_reflection: f32,
    pub diffuse_transmission: f32,
}

impl Default for ThinRates {
    fn default() -> Self {
        ThinRates {
            specular_reflection: 1.0,
            specular_transmission: 1.0,
            diffuse_reflection: 1.0,
            diffuse_transmission: 1.0,
        }
    }
}

/// Mitsuba 3's thin principled BSDF (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct PrincipledThin {
    pub burley: Burley,
    /// Diffuse transmission in `[0, 2]` (half of it is the transmitted share).
    pub diff_trans: f32,
    /// The sheet's IOR.
    pub eta: f32,
    pub rates: ThinRates,
}

/// The lobes' probabilities, normalised.
struct Probabilities {
    spec_reflect: f32,
    spec_trans: f32,
    diffuse_reflect: f32,
    diffuse_trans: f32,
}

impl PrincipledThin {
    /// A checked model.
    pub fn new(
        burley: Burley,
        diff_trans: f32,
        eta: f32,
        rates: ThinRates,
    ) -> Result<PrincipledThin, String> {
        burley.check()?;
        if !(0.0..=2.0).contains(&diff_trans) {
            return Err(format!("`diff_trans` must lie in [0, 2], got {diff_trans}"));
        }
        if !(eta > 0.0 && eta.is_finite()) {
            return Err(format!("`eta` must be positive and finite, got {eta}"));
        }
        let r = [
            rates.specular_reflection,
            rates.specular_transmission,
            rates.diffuse_reflection,
            rates.diffuse_transmission,
        ];
        if r.iter().any(|x| !(*x >= 0.0 && x.is_finite())) || rates.diffuse_reflection <= 0.0 {
            return Err(format!(
                "the sampling rates must be finite and non-negative, the diffuse reflection's positive, got {r:?}"
            ));
        }
        Ok(PrincipledThin {
            burley,
            diff_trans,
            eta,
            rates,
        })
    }

    #[inline]
    fn probabilities(&self) -> Probabilities {
        let (st, dt, r) = (self.burley.spec_trans, self.diff_trans / 2.0, &self.rates);
        let mut p = Probabilities {
            spec_reflect: st * r.specular_reflection / 2.0,
            spec_trans: st * r.specular_transmission / 2.0,
            diffuse_reflect: r.diffuse_reflection * (1.0 - st) * (1.0 - dt),
            diffuse_trans: r.diffuse_transmission * (1.0 - st) * dt,
        };
        let k = 1.0 / (p.spec_reflect + p.spec_trans + p.diffuse_reflect + p.diffuse_trans);
        p.spec_reflect *= k;
        p.spec_trans *= k;
        p.diffuse_reflect *= k;
        p.diffuse_trans *= k;
        p
    }

    /// The transmission's roughness: Burley's `(0.65 eta - 0.35) roughness`.
    #[inline]
    fn transmission_roughness(&self) -> f32 {
        (0.65 * self.eta - 0.35) * self.burley.roughness
    }

    /// `v` and `l` turned to `v`'s face, and the half vector of `v` and `l` mirrored there.
    #[inline]
    fn on_viewer_face(v: Vec3A, l: Vec3A) -> (Vec3A, Vec3A, Vec3A) {
        let s = if v.z >= 0.0 { 1.0 } else { -1.0 };
        let (v, l) = (v * s, l * s);
        let mirrored = Vec3A::new(l.x, l.y, l.z.abs());
        (v, l, (v + mirrored).normalize_or_zero())
    }

    fn value(&self, v: Vec3A, l: Vec3A) -> Spectrum {
        let b = &self.burley;
        if v.z == 0.0 || l.z == 0.0 {
            return Spectrum::ZERO;
        }
        let (v, l, h) = Self::on_viewer_face(v, l);
        let (cos_v, cos_l) = (v.z, l.z);
        let reflect = cos_l > 0.0;
        let (st, dt) = (b.spec_trans, self.diff_trans / 2.0);
        let cos_vl = (cos_v * cos_l).abs();
        let mut value = Spectrum::ZERO;
        if st > 0.0 {
            let f = fresnel_dielectric(v.dot(h), self.eta);
            if reflect && compatible(h, v, l, cos_v, true) {
                let mf = b.distribution(b.roughness);
                let mut fresnel = Spectrum::splat(f);
                if b.spec_tint > 0.0 {
                    let r0 = b.tint() * super::schlick_r0(self.eta);
                    let schlick = super::schlick(r0, v.dot(h), self.eta);
                    fresnel = fresnel.lerp(schlick, b.spec_tint);
                }
                value += fresnel * (st * mf.d(h) * mf.g(v, l, h) / (4.0 * cos_vl));
            }
            if !reflect && compatible(h, v, l, cos_v, false) {
                let mf = b.distribution(self.transmission_roughness());
                value += b.base_color * (st * (1.0 - f) * mf.d(h) * mf.g(v, l, h) / (4.0 * cos_vl));
            }
        }
        if st < 1.0 {
            if reflect && dt < 1.0 {
                let diffuse = b.diffuse(cos_v, cos_l, h.dot(l)) * FRAC_1_PI;
                value += b.base_color * ((1.0 - st) * (1.0 - dt) * diffuse);
                if b.sheen > 0.0 {
                    value += b.sheen(h.dot(l)) * ((1.0 - st) * (1.0 - dt));
                }
            }
            if !reflect && dt > 0.0 {
                value += b.base_color * ((1.0 - st) * dt * FRAC_1_PI);
            }
        }
        value
    }

    fn density(&self, v: Vec3A, l: Vec3A) -> f32 {
        if v.z == 0.0 {
            return 0.0;
        }
        let b = &self.burley;
        let (v, l, h) = Self::on_viewer_face(v, l);
        let reflect = l.z > 0.0;
        let refract = l.z < 0.0;
        let p = self.probabilities();
        let mut pdf = 0.0;
        if b.spec_trans > 0.0 {
            let mirrored = Vec3A::new(l.x, l.y, l.z.abs());
            let jacobian = (1.0 / (4.0 * mirrored.dot(h))).abs();
            if reflect && compatible(h, v, l, v.z, true) {
                let mf = b.distribution(b.roughness);
                pdf += p.spec_reflect * mf.pdf(v, h) * jacobian;
            }
            if refract && compatible(h, v, l, v.z, false) {
                let mf = b.distribution(self.transmission_roughness());
                pdf += p.spec_trans * mf.pdf(v, h) * jacobian;
            }
        }
        if reflect {
            pdf += p.diffuse_reflect * cosine_pdf(l);
        }
        if refract {
            pdf += p.diffuse_trans * cosine_pdf(-l);
        }
        pdf
    }
}

impl Bxdf for PrincipledThin {
    fn lobes(&self) -> Lobes {
        let diffuse = Lobes::DIFFUSE_REFLECTION
            .with(Lobes::DIFFUSE_TRANSMISSION)
            .with(Lobes::GLOSSY_REFLECTION);
        if self.burley.spec_trans > 0.0 {
            diffuse.with(Lobes::GLOSSY_TRANSMISSION)
        } else {
            diffuse
        }
    }

    fn eval(&self, wo: Vec3A, wi: Vec3A) -> Spectrum {
        self.value(wo, wi)
    }

    fn pdf(&self, wo: Vec3A, wi: Vec3A) -> f32 {
        self.density(wo, wi)
    }

    fn sample(&self, wo: Vec3A, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let s = if wo.z >= 0.0 { 1.0 } else { -1.0 };
        let v = wo * s;
        let b = &self.burley;
        let p = self.probabilities();
        let l = if u_lobe < p.spec_reflect {
            let m = b.distribution(b.roughness).sample(v, u);
            let l = reflect(v, m);
            (l.z > 0.0 && compatible(m, v, l, v.z, true)).then_some(l)?
        } else if u_lobe < p.spec_reflect + p.spec_trans {
            let m = b.distribution(self.transmission_roughness()).sample(v, u);
            let r = reflect(v, m);
            let l = Vec3A::new(r.x, r.y, -r.z);
            (l.z < 0.0 && compatible(m, v, l, v.z, false)).then_some(l)?
        } else if u_lobe < p.spec_reflect + p.spec_trans + p.diffuse_reflect {
            crate::sampling::cosine_hemisphere(u)
        } else {
            -crate::sampling::cosine_hemisphere(u)
        };
        let wi = l * s;
        let (f, pdf) = self.eval_pdf(wo, wi);
        (pdf > 0.0 && pdf.is_finite()).then_some(BsdfSample {
            wi,
            f,
            pdf,
            specular: false,
            eta: 1.0,
        })
    }

    fn albedo(&self) -> Spectrum {
        self.burley.base_color
    }
}
