//! Burley's principled BSDF ("Physically-based shading at Disney", 2012 and 2015) as Mitsuba 3
//! implements it: [`Principled`] (`principled`: a surface, opaque unless `spec_trans`) and
//! [`PrincipledThin`] (`principledthin`: a thin sheet, two-sided, that transmits).
//!
//! What both share lives here: the parameters of the base layer ([`Burley`]), Schlick's
//! Fresnel approximation, the GGX distribution a roughness and an anisotropy make, Burley's
//! diffuse with its retro-reflection and fake subsurface, the sheen, and the check that a
//! microfacet and the macro-surface agree on which side each direction lies.
//!
//! Inside this module `v` is the direction towards the viewer (the crate's `wo`, Mitsuba's
//! `si.wi`) and `l` the other one (the crate's `wi`, Mitsuba's `wo`). The models return the
//! BSDF without the cosine, as every model of the crate; Mitsuba's `eval` includes it.

mod standard;
mod thin;

pub use standard::{Principled, PrincipledRates};
pub use thin::{PrincipledThin, ThinRates};

use super::microfacet::{Distribution, Microfacet};
use crate::Spectrum;
use glam::{Vec2, Vec3A};
use std::f32::consts::{FRAC_1_PI, PI};

/// The base layer's parameters, each in `[0, 1]` (Mitsuba's names), looked up per hit where a
/// texture gives them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Burley {
    /// The colour of the diffuse base, the metal, the transmission and the tints.
    pub base_color: Spectrum,
    /// Perceptual roughness: the GGX `alpha` is its square (at least 0.001).
    pub roughness: f32,
    /// Stretches the specular lobe along the tangent (`aspect = sqrt(1 - 0.9 anisotropic)`).
    pub anisotropic: f32,
    /// The share of the dielectric part that transmits (a glossy refraction; through the sheet
    /// for the thin model).
    pub spec_trans: f32,
    /// Tints the dielectric's Fresnel towards the base colour.
    pub spec_tint: f32,
    /// A grazing retro-reflective lobe (cloth).
    pub sheen: f32,
    /// Tints the sheen towards the base colour.
    pub sheen_tint: f32,
    /// Blends the diffuse towards Hanrahan-Krueger's flattened, subsurface-like lobe.
    pub flatness: f32,
}

impl Burley {
    /// Mitsuba's defaults: base colour 0.5, roughness 0.5, the rest 0.
    pub fn new(base_color: Spectrum) -> Burley {
        Burley {
            base_color,
            roughness: 0.5,
            anisotropic: 0.0,
            spec_trans: 0.0,
            spec_tint: 0.0,
            sheen: 0.0,
            sheen_tint: 0.0,
            flatness: 0.0,
        }
    }

    /// Checks that every parameter lies where the model is defined.
    pub fn check(&self) -> Result<(), String> {
        super::checks::finite(
            "a principled parameter",
            &[
                self.roughness,
                self.anisotropic,
                self.spec_trans,
                self.spec_tint,
                self.sheen,
                self.sheen_tint,
                self.flatness,
            ],
        )?;
        for (name, x) in [
            ("roughness", self.roughness),
            ("anisotropic", self.anisotropic),
            ("spec_trans", self.spec_trans),
            ("spec_tint", self.spec_tint),
            ("sheen", self.sheen),
            ("sheen_tint", self.sheen_tint),
            ("flatness", self.flatness),
        ] {
            if !(0.0..=1.0).contains(&x) {
                return Err(format!("`{name}` must lie in [0, 1], got {x}"));
            }
        }
        if self.base_color.min_element() < 0.0 || !self.base_color.is_finite() {
            return Err(format!(
                "`base_color` must be finite and non-negative, got {}",
                crate::spectrum::rgb_of(self.base_color)
            ));
        }
        Ok(())
    }

    /// The specular lobe's GGX distribution for `roughness` (Mitsuba's `calc_dist_params`).
    #[inline]
    fn distribution(&self, roughness: f32) -> Microfacet {
        let r2 = roughness * roughness;
        let aspect = (1.0 - 0.9 * self.anisotropic).sqrt();
        Microfacet {
            distribution: Distribution::Ggx,
            alpha_u: (r2 / aspect).max(0.001),
            alpha_v: (r2 * aspect).max(0.001),
        }
    }

    /// The base colour over its luminance (white where it is black): the tint colour.
    #[inline]
    fn tint(&self) -> Spectrum {
        let lum = crate::luminance(crate::spectrum::rgb_of(self.base_color));
        if lum > 0.0 {
            self.base_color / lum
        } else {
            Spectrum::ONE
        }
    }

    /// Burley's diffuse over `base_color / pi`: the Schlick-weighted diffuse with its
    /// retro-reflection, blended towards the flattened lobe by `flatness`; `cos_v`, `cos_l`
    /// the cosines of the two directions, `cos_d` that of the half vector with `l`.
    #[inline]
    fn diffuse(&self, cos_v: f32, cos_l: f32, cos_d: f32) -> f32 {
        let (fo, fi) = (schlick_weight(cos_l.abs()), schlick_weight(cos_v.abs()));
        let f_diff = (1.0 - 0.5 * fi) * (1.0 - 0.5 * fo);
        let rr = 2.0 * self.roughness * cos_d * cos_d;
        let f_retro = rr * (fo + fi + fo * fi * (rr - 1.0));
        if self.flatness == 0.0 {
            return f_diff + f_retro;
        }
        let fss90 = rr / 2.0;
        let fss = lerp(1.0, fss90, fo) * lerp(1.0, fss90, fi);
        let f_ss = 1.25 * (fss * (1.0 / (cos_l.abs() + cos_v.abs()) - 0.5) + 0.5);
        lerp(f_diff + f_retro, f_ss, self.flatness)
    }

    /// The sheen's value (cosine-free) at half-vector cosine `cos_d`, before the model's
    /// weight.
    #[inline]
    fn sheen(&self, cos_d: f32) -> Spectrum {
        let fd = schlick_weight(cos_d.abs());
        if self.sheen_tint == 0.0 {
            Spectrum::splat(self.sheen * fd)
        } else {
            Spectrum::ONE.lerp(self.tint(), self.sheen_tint) * (self.sheen * fd)
        }
    }
}

/// `a + t (b - a)`.
#[inline]
fn lerp(a: f32, b: f32, t: f32) -> f32 {
    a * (1.0 - t) + b * t
}

/// Schlick's weight `(1 - cos)^5`, the cosine clamped to `[0, 1]`.
#[inline]
fn schlick_weight(cos: f32) -> f32 {
    let m = (1.0 - cos).clamp(0.0, 1.0);
    let m2 = m * m;
    m2 * m2 * m
}

/// Schlick's Fresnel from reflectance `r0` at normal incidence, for an interface of relative
/// IOR `eta` seen at cosine `cos_v` (negative: from inside); from the denser side, at the
/// transmitted angle (Mitsuba's `calc_schlick`).
#[inline]
fn schlick(r0: Spectrum, cos_v: f32, eta: f32) -> Spectrum {
    let (eta_it, eta_ti) = if cos_v >= 0.0 {
        (eta, 1.0 / eta)
    } else {
        (1.0 / eta, eta)
    };
    let weight = if eta_it > 1.0 {
        schlick_weight(cos_v.abs())
    } else {
        let cos_t2 = 1.0 - (1.0 - cos_v * cos_v) * eta_ti * eta_ti;
        schlick_weight(cos_t2.max(0.0).sqrt())
    };
    r0 + (Spectrum::ONE - r0) * weight
}

/// Normal-incidence reflectance of a dielectric of relative IOR `eta`.
#[inline]
fn schlick_r0(eta: f32) -> f32 {
    let r = (eta - 1.0) / (eta + 1.0);
    r * r
}

/// Whether microfacet `m` and the macro-surface agree: `v` and `l` see `m`'s front (flipped
/// to `v`'s side of the surface, by the sign of `side`) for a reflection, `l` its back for a
/// transmission.
#[inline]
fn compatible(m: Vec3A, v: Vec3A, l: Vec3A, side: f32, reflection: bool) -> bool {
    let m = if side >= 0.0 { m } else { -m };
    v.dot(m) > 0.0
        && if reflection {
            l.dot(m) > 0.0
        } else {
            l.dot(m) < 0.0
        }
}

/// `v` with the sign of `s` (`+0` counts as positive).
#[inline]
fn mulsign(v: Vec3A, s: f32) -> Vec3A {
    if s >= 0.0 {
        v
    } else {
        -v
    }
}

/// Berry's distribution (GTR with exponent 1) of the clear coat, isotropic of roughness `alpha`.
#[derive(Clone, Copy, Debug)]
struct Gtr1 {
    alpha: f32,
}

impl Gtr1 {
    /// Density of normals, `integral D(m) m.z dm = 1`.
    #[inline]
    fn d(&self, m: Vec3A) -> f32 {
        let a2 = self.alpha * self.alpha;
        let cos2 = m.z * m.z;
        let d = (a2 - 1.0) / (PI * a2.ln() * (1.0 + (a2 - 1.0) * cos2));
        if d * m.z > 1e-20 {
            d
        } else {
            0.0
        }
    }

    /// Density per solid angle of [`Gtr1::sample`]: `D(m) m.z`.
    #[inline]
    fn pdf(&self, m: Vec3A) -> f32 {
        if m.z < 0.0 {
            0.0
        } else {
            m.z * self.d(m)
        }
    }

    /// A normal drawn with density `D(m) m.z`.
    #[inline]
    fn sample(&self, u: Vec2) -> Vec3A {
        let (sin_phi, cos_phi) = (2.0 * PI * u.x).sin_cos();
        let a2 = self.alpha * self.alpha;
        let cos2 = (1.0 - a2.powf(1.0 - u.y)) / (1.0 - a2);
        let sin = (1.0 - cos2).max(0.0).sqrt();
        Vec3A::new(cos_phi * sin, sin_phi * sin, cos2.max(0.0).sqrt())
    }
}

/// The clear coat's masking of `w` at normal `m`: Smith's GGX `G1` of roughness `alpha`
/// (Mitsuba's `smith_ggx1`).
#[inline]
fn clearcoat_g1(w: Vec3A, m: Vec3A, alpha: f32) -> f32 {
    if w.dot(m) * w.z <= 0.0 {
        return 0.0;
    }
    if w.z == 1.0 {
        return 1.0;
    }
    let cos2 = w.z * w.z;
    let tan2 = (1.0 - cos2) / cos2;
    2.0 / (1.0 + (1.0 + alpha * alpha * tan2).sqrt())
}

/// Density of a cosine-weighted direction of the hemisphere around `+z` (may be negative
/// below it: callers weigh it by a zero probability there).
#[inline]
fn cosine_pdf(w: Vec3A) -> f32 {
    w.z * FRAC_1_PI
}

#[cfg(test)]
mod tests;
