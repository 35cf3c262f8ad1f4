//! Fresnel reflectance of smooth interfaces: between two dielectrics, at a conductor (complex
//! IOR), and averaged over a hemisphere of directions (what a diffuse layer under a coating
//! loses back into itself).

use crate::Spectrum;

/// Unpolarised Fresnel reflectance of a dielectric interface. `cos_i` is the cosine of the
/// incident angle measured against the normal on the incident side's convention (positive:
/// arriving from outside); `eta` = inside IOR / outside IOR. Returns 1 on total internal
/// reflection.
///
/// This is the exact average of the parallel and perpendicular reflectances (pbrt-v4's
/// `FrDielectric`); for `cos_i < 0` the roles of the two media are swapped.
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let mut cos_i = cos_i.clamp(-1.0, 1.0);
    let mut eta = eta;
    if cos_i < 0.0 {
        eta = 1.0 / eta;
        cos_i = -cos_i;
    }
    let sin2_i = (1.0 - cos_i * cos_i).max(0.0);
    let sin2_t = sin2_i / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
    let r_parallel = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perpendicular = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (r_parallel * r_parallel + r_perpendicular * r_perpendicular)
}

/// Unpolarised Fresnel reflectance of a conductor of complex relative IOR `eta + i k`, per
/// channel, at incidence `cos_i` (clamped to `[0, 1]`): the exact expression for an absorbing
/// medium (pbrt-v3's `FrConductor`, Mitsuba 3's `fresnel_conductor`).
pub fn fresnel_conductor(cos_i: f32, eta: Spectrum, k: Spectrum) -> Spectrum {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let cos2 = cos_i * cos_i;
    let sin2 = 1.0 - cos2;
    let sin4 = sin2 * sin2;
    let temp = eta * eta - k * k - Spectrum::splat(sin2);
    let a2b2 = (temp * temp + 4.0 * k * k * eta * eta).max(Spectrum::ZERO);
    let a2b2 = a2b2.map(f32::sqrt);
    let a = ((a2b2 + temp) * 0.5).max(Spectrum::ZERO);
    let a = a.map(f32::sqrt);
    let term1 = a2b2 + Spectrum::splat(cos2);
    let term2 = 2.0 * cos_i * a;
    let r_s = (term1 - term2) / (term1 + term2);
    let term3 = a2b2 * cos2 + Spectrum::splat(sin4);
    let term4 = term2 * sin2;
    let r_p = r_s * (term3 - term4) / (term3 + term4);
    let r = 0.5 * (r_s + r_p);
    // Rounding at cos_i = 0 with k = 0 gives 0/0: reflectance is 1 at grazing incidence.
    r.map(|r| if r.is_finite() { r } else { 1.0 })
        .clamp(Spectrum::ZERO, Spectrum::ONE)
}

/// Hemispherical average of the dielectric Fresnel reflectance, `2 integral_0^1 F(mu, eta)
/// mu dmu`: the fraction of diffuse light arriving at the interface from the side whose
/// relative IOR (other side over this side) is `eta` that it reflects back. Integrated
/// numerically (Mitsuba 3 uses Egan and Hilgeman's fit, within 0.6% of this for `eta` below
/// 2).
pub fn fresnel_diffuse_reflectance(eta: f32) -> f32 {
    // fresnel_dielectric takes inside over outside with the cosine's sign picking the side:
    // light arriving on the outside (cos > 0) at an interface of relative IOR eta.
    const N: usize = 4096;
    let sum: f64 = (0..N)
        .map(|i| {
            let mu = (i as f64 + 0.5) / N as f64;
            fresnel_dielectric(mu as f32, eta) as f64 * mu
        })
        .sum();
    (2.0 * sum / N as f64) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conductor_reduces_to_dielectric_without_absorption_and_to_a_mirror_at_grazing() {
        for cos in [1.0f32, 0.8, 0.5, 0.2, 0.05] {
            let c = fresnel_conductor(cos, Spectrum::splat(1.5), Spectrum::ZERO).x;
            let d = fresnel_dielectric(cos, 1.5);
            assert!((c - d).abs() < 1e-5, "{cos}: {c} vs {d}");
        }
        // Gold at normal incidence: ((n-1)^2 + k^2) / ((n+1)^2 + k^2).
        let (n, k) = (
            crate::spectrum::rgb(0.143, 0.374, 1.442),
            crate::spectrum::rgb(3.983, 2.385, 1.603),
        );
        let r = fresnel_conductor(1.0, n, k);
        let expected = ((n - Spectrum::ONE) * (n - Spectrum::ONE) + k * k)
            / ((n + Spectrum::ONE) * (n + Spectrum::ONE) + k * k);
        assert!(
            (r - expected).abs().max_element() < 1e-5,
            "{r} vs {expected}"
        );
        assert!(
            (fresnel_conductor(0.0, n, k) - Spectrum::ONE)
                .abs()
                .max_element()
                < 1e-5
        );
    }

    #[test]
    fn diffuse_reflectance_matches_known_values() {
        // Total internal reflection makes diffuse light from the dense side mostly return:
        // 1 - (1 - F_ext) / eta^2, by reciprocity of the two sides' transmitted energy.
        for eta in [1.33f32, 1.5, 2.0] {
            let ext = fresnel_diffuse_reflectance(eta);
            let int = fresnel_diffuse_reflectance(1.0 / eta);
            assert!(
                ((1.0 - int) - (1.0 - ext) / (eta * eta)).abs() < 1e-4,
                "{eta}"
            );
        }
        // Egan and Hilgeman's fit (Mitsuba 3) at 1.5: 0.0918 from outside, 0.5963 inside.
        assert!((fresnel_diffuse_reflectance(1.5) - 0.0918).abs() < 1e-3);
        assert!((fresnel_diffuse_reflectance(1.0 / 1.5) - 0.5963).abs() < 2e-3);
    }
}
