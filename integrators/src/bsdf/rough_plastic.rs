//! Rough plastic: a diffuse base under a rough dielectric coating (Mitsuba 3's `roughplastic`;
//! RON `RoughPlastic`).
//!
//! ```text
//! f(wo, wi) = specular F(wo.h) D(h) G(wo, wi, h) / (4 cos(wo) cos(wi))
//!           + rho' t(cos(wo)) t(cos(wi)) / (eta^2 pi)
//! ```
//!
//! The first term is the coating's microfacet reflection ([`Microfacet`], `h` the half vector).
//! The second is the base seen through the rough coating: `t(mu)` is the fraction of light
//! arriving at incidence `mu` that the rough interface transmits (one scattering event on
//! the microfacets, shadowing included), and `rho'` sums the bounces between base and coating
//! as for [`super::Plastic`], with the internal diffuse reflectance of the rough interface
//! in place of the smooth one. Both `t` and the internal reflectance are integrals over the
//! microfacet normals, computed when the material is made (64 incidences, interpolated
//! linearly, as Mitsuba 3 tabulates them; see [`internal_reflectance`] for its one
//! shortcut, kept).
//!
//! Sampling chooses the coating's lobe with probability `(1 - t(wo)) s / ((1 - t(wo)) s + t(wo)
//! (1 - s))` (`s` as for plastic), then a microfacet normal (GGX: visible normals) and its
//! reflection, or a cosine-weighted direction for the base; the density is the mixture of
//! both, so MIS sees one smooth lobe. Parameters: `diffuse` (`rho`), `specular` (tint), `ior`
//! (> 1), `nonlinear`, the distribution. Two-sided like every opaque material.

use super::fresnel::fresnel_dielectric;
use super::microfacet::{reflect, refract, Distribution, HalfVector, Microfacet};
use super::plastic::{coating_probability, multiple_bounces, Coating};
use super::{BsdfSample, Bxdf, Lobes};
use crate::Spectrum;
use glam::{Vec2, Vec3A};
use rayon::prelude::*;
use std::collections::HashMap;
use std::f32::consts::FRAC_1_PI;
use std::sync::{Arc, Mutex, OnceLock};

/// Incidences at which the coating's transmittance is tabulated, `mu = i / (TABLE - 1)`.
const TABLE: usize = 64;

/// Rough plastic (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct RoughPlastic {
    pub diffuse: Spectrum,
    pub specular: Spectrum,
    pub ior: f32,
    pub nonlinear: bool,
    pub microfacet: Microfacet,
    /// `t(mu)` at `mu = i / (TABLE - 1)`; shared, so that the per-hit copy of a textured
    /// rough plastic allocates nothing.
    transmittance: Arc<[f32; TABLE]>,
    /// Diffuse reflectance of the rough interface seen from inside.
    internal: f32,
    specular_weight: f32,
}

/// Integrates `g(m) D_wo(m)` over the microfacet normals visible from `wo` (upper side), with
/// `D_wo` the distribution of visible normals: a midpoint rule in `phi` and in `u`, where
/// `tan(theta_m) = 8 alpha u / (1 - u)` packs the nodes where the lobe is.
fn over_visible_normals(mf: &Microfacet, wo: Vec3A, g: impl Fn(Vec3A) -> f32) -> f64 {
    const NT: usize = 256;
    const NP: usize = 96;
    let alpha = mf.alpha_u.max(mf.alpha_v) as f64;
    // The azimuths' cosines and sines, the same for every theta.
    let azimuths: [(f64, f64); NP] = std::array::from_fn(|j| {
        let phi = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / NP as f64;
        (phi.cos(), phi.sin())
    });
    let mut sum = 0.0f64;
    for i in 0..NT {
        let u = (i as f64 + 0.5) / NT as f64;
        let s = 8.0 * alpha;
        let theta = (s * u / (1.0 - u)).atan();
        // d theta / d u = s / ((1 - u)^2 + (s u)^2)
        let dtheta = s / ((1.0 - u) * (1.0 - u) + (s * u) * (s * u)) / NT as f64;
        let (st, ct) = theta.sin_cos();
        for &(cos_phi, sin_phi) in &azimuths {
            let m = Vec3A::new((st * cos_phi) as f32, (st * sin_phi) as f32, ct as f32);
            let visible = mf.g1(wo, m) * wo.dot(m).max(0.0) * mf.d(m) / wo.z;
            if visible > 0.0 {
                sum += (visible * g(m)) as f64
                    * st
                    * dtheta
                    * (2.0 * std::f64::consts::PI / NP as f64);
            }
        }
    }
    sum
}

/// The direction of incidence `mu` in the `xz` plane.
fn at_incidence(mu: f32) -> Vec3A {
    let mu = mu.clamp(1e-6, 1.0);
    Vec3A::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu)
}

/// `t(mu)`: the fraction of light arriving from outside at incidence `mu` that the rough
/// interface of relative IOR `ior` transmits.
fn rough_transmittance(mf: &Microfacet, ior: f32, mu: f32) -> f32 {
    let wo = at_incidence(mu);
    over_visible_normals(mf, wo, |m| {
        let cos = wo.dot(m);
        let f = fresnel_dielectric(cos, ior);
        match refract(wo, m, ior) {
            Some(wt) if wt.z < 0.0 => (1.0 - f) * mf.g1(wt, m),
            _ => 0.0,
        }
    })
    .clamp(0.0, 1.0) as f32
}

/// The diffuse reflectance of the rough interface seen from inside (relative IOR `1 / ior`):
/// `2 integral r(mu) mu dmu` of its directional reflectance `r`, summed over the table's 64
/// nodes `mu = i / 63` with equal weights, exactly as Mitsuba 3 sums it. That sum counts both
/// ends in full and is about 1.5% below the integral (0.575 against 0.584 for Beckmann 0.1
/// and IOR 1.49); raylab keeps it so that a `RoughPlastic` is Mitsuba's `roughplastic`.
fn internal_reflectance(mf: &Microfacet, ior: f32) -> f32 {
    const N: usize = TABLE;
    // The nodes' terms in parallel, then summed in order (the same sum on any thread count).
    let terms: Vec<f64> = (0..N)
        .into_par_iter()
        .map(|i| {
            let mu = i as f32 / (N - 1) as f32;
            let wo = at_incidence(mu);
            let r = over_visible_normals(mf, wo, |m| {
                let f = fresnel_dielectric(wo.dot(m), 1.0 / ior);
                let wr = reflect(wo, m);
                if wr.z > 0.0 {
                    f * mf.g1(wr, m)
                } else {
                    0.0
                }
            });
            r * mu as f64
        })
        .collect();
    let mut sum = 0.0f64;
    for term in terms {
        sum += term;
    }
    (2.0 * sum / N as f64).clamp(0.0, 1.0) as f32
}

/// A rough coating's tables: `t(mu)` at the table's incidences, and the internal reflectance.
type CoatingTables = (Arc<[f32; TABLE]>, f32);

/// The tables of the coating of roughness `mf` and relative IOR `ior`, computed once per
/// process for each (distribution, roughnesses, IOR): the field's scenes give many rough
/// plastics one coating and different colours, and a live session remakes its materials on
/// every edit, while the tables take some 50 ms of CPU. They are a function of the key alone,
/// so whichever thread computes them first, every material gets the same values.
fn coating_tables(mf: &Microfacet, ior: f32) -> CoatingTables {
    /// Coatings kept at most: the cache starts afresh beyond (a live session sweeping a
    /// roughness makes a new coating per step; a scene of more coatings than this gains
    /// little from it, and stays correct).
    const CAPACITY: usize = 256;
    type Key = (Distribution, u32, u32, u32);
    static CACHE: OnceLock<Mutex<HashMap<Key, CoatingTables>>> = OnceLock::new();
    let key = (
        mf.distribution,
        mf.alpha_u.to_bits(),
        mf.alpha_v.to_bits(),
        ior.to_bits(),
    );
    let cache = CACHE.get_or_init(Mutex::default);
    // A poisoned lock only means another thread panicked while holding it; the map is whole.
    let lock = || cache.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(tables) = lock().get(&key) {
        return tables.clone();
    }
    // Each entry on its own (in parallel: the tables are most of a rough plastic's load),
    // outside the lock.
    let mut table = [0.0; TABLE];
    table.par_iter_mut().enumerate().for_each(|(i, t)| {
        *t = rough_transmittance(mf, ior, i as f32 / (TABLE - 1) as f32);
    });
    let tables = (Arc::new(table), internal_reflectance(mf, ior));
    let mut map = lock();
    if map.len() >= CAPACITY {
        map.clear();
    }
    map.entry(key).or_insert(tables).clone()
}

impl RoughPlastic {
    /// Rough plastic with base `diffuse`, coating tint `specular`, relative IOR `ior` (> 1)
    /// and the coating's roughness `microfacet`.
    pub fn new(
        diffuse: Spectrum,
        specular: Spectrum,
        ior: f32,
        nonlinear: bool,
        microfacet: Microfacet,
    ) -> Result<RoughPlastic, String> {
        let c = Coating::new(diffuse, specular, ior)?;
        let (transmittance, internal) = coating_tables(&microfacet, ior);
        Ok(RoughPlastic {
            diffuse: c.diffuse,
            specular: c.specular,
            ior,
            nonlinear,
            microfacet,
            transmittance,
            internal,
            specular_weight: c.specular_weight,
        })
    }

    /// `t(mu)`, interpolated in the table.
    #[inline]
    fn t(&self, mu: f32) -> f32 {
        let x = mu.clamp(0.0, 1.0) * (TABLE - 1) as f32;
        let i = (x as usize).min(TABLE - 2);
        let f = x - i as f32;
        self.transmittance[i] * (1.0 - f) + self.transmittance[i + 1] * f
    }

    /// Probability of sampling the coating's lobe at `wo`.
    #[inline]
    fn coating_probability(&self, wo: Vec3A) -> f32 {
        coating_probability(1.0 - self.t(wo.z), self.specular_weight)
    }
}

impl RoughPlastic {
    /// `f(wo, wi)` for upper-side directions with half vector `hv`.
    #[inline]
    fn value(&self, wo: Vec3A, wi: Vec3A, hv: &HalfVector) -> Spectrum {
        let coat = fresnel_dielectric(wo.dot(hv.h), self.ior)
            * hv.d
            * (hv.g1_wo * self.microfacet.g1(wi, hv.h))
            / (4.0 * wo.z * wi.z);
        let base = multiple_bounces(self.diffuse, self.internal, self.nonlinear)
            * (self.t(wo.z) * self.t(wi.z) * FRAC_1_PI / (self.ior * self.ior));
        self.specular * coat + base
    }

    /// The density of `wi` for upper-side directions with half vector `hv`: the coating's
    /// reflected visible normals or the cosine-weighted base, in proportion to the coating's
    /// probability at `wo`.
    #[inline]
    fn density(&self, wo: Vec3A, wi: Vec3A, hv: &HalfVector) -> f32 {
        let p = self.coating_probability(wo);
        p * hv.reflection_pdf(wo) + (1.0 - p) * wi.z * FRAC_1_PI
    }
}

impl Bxdf for RoughPlastic {
    #[inline]
    fn lobes(&self) -> Lobes {
        Lobes::GLOSSY_REFLECTION.with(Lobes::DIFFUSE_REFLECTION)
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
        self.density(wo, wi, &self.microfacet.half_vector(wo, wi))
    }

    /// Both, with what they share computed once.
    fn eval_pdf(&self, wo: Vec3A, wi: Vec3A) -> (Spectrum, f32) {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return (Spectrum::ZERO, 0.0);
        }
        let hv = self.microfacet.half_vector(wo, wi);
        (self.value(wo, wi, &hv), self.density(wo, wi, &hv))
    }

    fn sample(&self, wo: Vec3A, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let wi = if u_lobe < self.coating_probability(wo) {
            reflect(wo, self.microfacet.sample(wo, u)).normalize()
        } else {
            crate::sampling::cosine_hemisphere(u)
        };
        if wi.z <= 0.0 {
            return None;
        }
        BsdfSample::evaluated(self, wo, wi)
    }

    fn albedo(&self) -> Spectrum {
        self.diffuse
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coatings_alike_share_their_tables_and_the_cache_computes_what_a_fresh_build_does() {
        let mf = Microfacet::new(Distribution::Ggx, 0.37, 0.37).unwrap();
        let (red, grey) = (crate::spectrum::rgb(0.8, 0.1, 0.1), Spectrum::splat(0.5));
        let a = RoughPlastic::new(red, Spectrum::ONE, 1.43, false, mf).unwrap();
        let b = RoughPlastic::new(grey, Spectrum::ONE, 1.43, true, mf).unwrap();
        assert!(Arc::ptr_eq(&a.transmittance, &b.transmittance));
        assert_eq!(a.internal.to_bits(), b.internal.to_bits());
        // The cached values are those of the integrals themselves.
        for i in [0, 17, TABLE - 1] {
            let fresh = rough_transmittance(&mf, 1.43, i as f32 / (TABLE - 1) as f32);
            assert_eq!(a.transmittance[i].to_bits(), fresh.to_bits());
        }
        assert_eq!(
            a.internal.to_bits(),
            internal_reflectance(&mf, 1.43).to_bits()
        );
        // Another roughness, IOR or distribution is another coating.
        let rougher_u = Microfacet::new(Distribution::Ggx, 0.38, 0.37).unwrap();
        let rougher_v = Microfacet::new(Distribution::Ggx, 0.37, 0.38).unwrap();
        let beckmann = Microfacet::new(Distribution::Beckmann, 0.37, 0.37).unwrap();
        let others = [
            (rougher_u, 1.43),
            (rougher_v, 1.43),
            (mf, 1.44),
            (beckmann, 1.43),
        ];
        for (mf, ior) in others {
            let c = RoughPlastic::new(red, Spectrum::ONE, ior, false, mf).unwrap();
            assert!(!Arc::ptr_eq(&a.transmittance, &c.transmittance));
            assert_ne!(a.transmittance[20], c.transmittance[20]);
        }
    }
}
