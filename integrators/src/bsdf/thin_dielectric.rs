//! Thin dielectric: a pane of glass thin enough that its two faces are one surface (Mitsuba 3's
//! `thindielectric`; RON `ThinDielectric`). Light reflects off it or passes straight through,
//! undeviated; the internal reflections between the faces are summed in closed form.
//!
//! With `R` the Fresnel reflectance of one face at the angle of `wo` and `T = 1 - R`, the pane
//! reflects `R' = R + T^2 R / (1 - R^2)` and transmits `1 - R'`. Both lobes are Dirac deltas,
//! picked with those probabilities; the throughput weights are `reflectance` and
//! `transmittance`. Parameters: `ior` (the pane's IOR relative to the medium around it,
//! unitless, in [`super::dielectric::IOR_RANGE`]), `reflectance` and `transmittance` (tints
//! in `[0, 1]`). Both sides are alike; the pane encloses no volume, so no radiance is
//! compressed (`eta` 1).

use super::fresnel::fresnel_dielectric;
use super::{BsdfSample, Bxdf, Lobes};
use crate::Spectrum;
use glam::{Vec2, Vec3A};

/// A thin pane of glass (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct ThinDielectric {
    pub ior: f32,
    pub reflectance: Spectrum,
    pub transmittance: Spectrum,
}

impl ThinDielectric {
    /// A pane of relative IOR `ior` with lobes tinted by `reflectance` and `transmittance`.
    pub fn new(
        ior: f32,
        reflectance: Spectrum,
        transmittance: Spectrum,
    ) -> Result<ThinDielectric, String> {
        let d = super::Dielectric::new(ior, reflectance, transmittance)?;
        Ok(ThinDielectric {
            ior: d.ior,
            reflectance: d.reflectance,
            transmittance: d.transmittance,
        })
    }

    /// The pane's reflectance at incidence `cos` (either side).
    pub fn pane_reflectance(&self, cos: f32) -> f32 {
        let r = fresnel_dielectric(cos.abs(), self.ior);
        if r < 1.0 {
            let t = 1.0 - r;
            r + t * t * r / (1.0 - r * r)
        } else {
            1.0
        }
    }
}

impl Bxdf for ThinDielectric {
    #[inline]
    fn lobes(&self) -> Lobes {
        Lobes::DELTA_REFLECTION.with(Lobes::DELTA_TRANSMISSION)
    }

    fn eval(&self, _wo: Vec3A, _wi: Vec3A) -> Spectrum {
        Spectrum::ZERO
    }

    fn pdf(&self, _wo: Vec3A, _wi: Vec3A) -> f32 {
        0.0
    }

    fn sample(&self, wo: Vec3A, u_lobe: f32, _u: Vec2) -> Option<BsdfSample> {
        if wo.z == 0.0 || !wo.z.is_finite() {
            return None;
        }
        let r = self.pane_reflectance(wo.z);
        let (wi, tint, p) = if u_lobe < r {
            (Vec3A::new(-wo.x, -wo.y, wo.z), self.reflectance, r)
        } else {
            (-wo, self.transmittance, 1.0 - r)
        };
        if p <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wi,
            f: tint * (p / wi.z.abs()),
            pdf: p,
            specular: true,
            eta: 1.0,
        })
    }

    fn albedo(&self) -> Spectrum {
        self.reflectance * self.pane_reflectance(1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::chi2::dir;
    use crate::Sampler;

    #[test]
    fn a_pane_reflects_both_faces_and_transmits_straight_through() {
        let pane = ThinDielectric::new(1.5, Spectrum::ONE, Spectrum::ONE).unwrap();
        // At normal incidence R = 0.04 per face: 0.04 + 0.96^2 0.04 / (1 - 0.04^2) = 0.0769.
        assert!((pane.pane_reflectance(1.0) - 0.076_923).abs() < 1e-5);
        let wo = dir(40.0, 10.0);
        let t = pane.sample(wo, 0.999, Vec2::ZERO).unwrap();
        assert!(
            t.wi == -wo && t.eta == 1.0 && (t.weight() - Spectrum::ONE).abs().max_element() < 1e-6
        );
        let r = pane.sample(-wo, 0.0, Vec2::ZERO).unwrap();
        assert!(
            r.wi.z < 0.0 && (r.wi.z - (-wo.z)).abs() < 1e-6,
            "same side, mirrored"
        );
        // The reflected fraction of many samples is R'.
        let mut s = Sampler::new(1201, 0, 0);
        let n = 200_000;
        let reflected = (0..n)
            .filter_map(|_| pane.sample(wo, s.next_1d(), s.next_2d()))
            .filter(|b| b.wi.z > 0.0)
            .count() as f64
            / n as f64;
        let expected = pane.pane_reflectance(wo.z) as f64;
        let sd = (expected * (1.0 - expected) / n as f64).sqrt();
        assert!(
            (reflected - expected).abs() < 5.0 * sd,
            "{reflected} vs {expected}"
        );
    }
}
