//! Tentative collisions along a ray through a medium, drawn against its majorant: the one
//! routine the volumetric integrators sample distances with (pbrt-v4's `SampleT_maj`).
//!
//! Collisions are drawn at rate `sigma_maj[hero]` of one channel, the hero; the caller sees
//! each with the coefficients there and the majorant transmittance `T_maj` since the previous
//! one (all channels), and decides whether it is real (delta tracking), weighs it and goes on
//! (ratio tracking), or stops. Channels other than the hero are carried by the caller's
//! weights, so that a coloured medium is sampled by one channel and weighted by all.

use super::{Medium, MediumPoint};
use crate::spectrum::Wavelengths;
use crate::{Ray, Sampler, Spectrum};
use glam::Vec3A;

/// What the caller of [`sample_t_maj`] sees at a tentative collision.
#[derive(Clone, Copy, Debug)]
pub struct Collision {
    /// Where (world) and at what distance along the ray.
    pub p: Vec3A,
    pub t: f32,
    /// The medium's coefficients there.
    pub point: MediumPoint,
    /// The majorant there.
    pub sigma_maj: Spectrum,
    /// The majorant transmittance from the previous collision (or the ray's origin).
    pub t_maj: Spectrum,
}

/// Draws tentative collisions along `ray` up to `tmax` in `medium`, channel `hero` setting
/// the rate, and hands each to `collision` (which returns `false` to stop). Returns the
/// majorant transmittance from the last collision to `tmax`, or `Spectrum::ONE` when stopped.
#[inline]
pub fn sample_t_maj(
    medium: &Medium,
    ray: &Ray,
    tmax: f32,
    hero: usize,
    lambda: &Wavelengths,
    sampler: &mut Sampler,
    mut collision: impl FnMut(&Collision, &mut Sampler) -> bool,
) -> Spectrum {
    // Collisions are drawn afresh in each stretch (the exponential has no memory); `t_maj`
    // is the majorant transmittance since the last collision, across stretches.
    let mut t_maj = Spectrum::ONE;
    for segment in medium.majorant(ray, tmax, lambda) {
        let sigma_maj = segment.sigma_maj;
        let rate = sigma_maj[hero];
        if rate <= 0.0 {
            // Nothing to collide with (the hero sees no medium): only the other channels'
            // majorant transmittance, which the caller's weights divide out.
            t_maj *= transmittance(sigma_maj, (segment.t1 - segment.t0).max(0.0));
            continue;
        }
        let mut t = segment.t0;
        loop {
            let step = -(1.0 - sampler.next_1d()).ln() / rate;
            let next = t + step;
            if next >= segment.t1 || next.is_nan() {
                t_maj *= transmittance(sigma_maj, (segment.t1 - t).max(0.0));
                break;
            }
            let p = ray.at(next);
            let c = Collision {
                p,
                t: next,
                point: medium.at(p, lambda),
                sigma_maj,
                t_maj: t_maj * transmittance(sigma_maj, next - t),
            };
            if !collision(&c, sampler) {
                return Spectrum::ONE;
            }
            t_maj = Spectrum::ONE;
            t = next;
        }
    }
    t_maj
}

/// `exp(-sigma * d)` per channel; 1 where `sigma` is zero, even over an infinite `d` (a ray
/// that leaves the scene through a medium of no extinction in that channel).
#[inline]
pub fn transmittance(sigma: Spectrum, d: f32) -> Spectrum {
    let one = |s: f32| if s == 0.0 { 1.0 } else { (-s * d).exp() };
    sigma.map(one)
}

/// The transmittance of `medium` along `ray` up to `tmax`: exact through a homogeneous
/// medium, else estimated without bias in every channel by ratio tracking, collisions drawn
/// at the rate of the largest majorant of the channels in each stretch, each multiplying the
/// estimate by `1 - sigma_t / rate` per channel. (At one channel's rate, a stretch where that
/// channel sees no medium would leave the others its majorant transmittance instead of their
/// own.)
pub fn ratio_tracking(
    medium: &Medium,
    ray: &Ray,
    tmax: f32,
    lambda: &Wavelengths,
    sampler: &mut Sampler,
) -> Spectrum {
    if let Medium::Homogeneous(_) = medium {
        let point = medium.at(ray.origin, lambda);
        return transmittance(point.sigma_a + point.sigma_s, tmax);
    }
    let mut tr = Spectrum::ONE;
    for segment in medium.majorant(ray, tmax, lambda) {
        let rate = segment.sigma_maj.max_element();
        if rate.is_nan() || rate <= 0.0 {
            continue;
        }
        let mut t = segment.t0;
        loop {
            t += -(1.0 - sampler.next_1d()).ln() / rate;
            if t >= segment.t1 || t.is_nan() {
                break;
            }
            let point = medium.at(ray.at(t), lambda);
            tr *= (Spectrum::ONE - (point.sigma_a + point.sigma_s) / rate).max(Spectrum::ZERO);
            if tr == Spectrum::ZERO || !tr.is_finite() {
                return Spectrum::ZERO;
            }
        }
    }
    tr
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::medium::{Coefficients, DensityGrid, Heterogeneous, Homogeneous, Phase, Volume};
    use crate::Rgb;
    use glam::Affine3A;
    use std::sync::Arc;

    /// The mean of `n` estimates and its standard error (per channel).
    fn mean_transmittance(medium: &Medium, ray: &Ray, tmax: f32, n: u32) -> (Rgb, Rgb) {
        let mut s = Sampler::new(3, 0, 0);
        let (mut sum, mut sum2) = (glam::DVec3::ZERO, glam::DVec3::ZERO);
        for _ in 0..n {
            let tr = ratio_tracking(medium, ray, tmax, &Wavelengths::Rgb, &mut s)
                .truncate()
                .as_dvec3();
            sum += tr;
            sum2 += tr * tr;
        }
        let mean = sum / n as f64;
        let var = (sum2 / n as f64 - mean * mean).max(glam::DVec3::ZERO);
        (mean.as_vec3a(), (var / n as f64).powf(0.5).as_vec3a())
    }

    #[test]
    fn ratio_tracking_estimates_beers_law_in_a_coloured_fog() {
        let sigma_t = Rgb::new(0.5, 1.0, 2.0);
        let fog = Medium::Homogeneous(Homogeneous::new(
            sigma_t,
            Rgb::splat(0.5),
            Rgb::ZERO,
            Phase::Isotropic,
        ));
        let ray = Ray::new(Vec3A::ZERO, Vec3A::X);
        let (tr, se) = mean_transmittance(&fog, &ray, 1.5, 40_000);
        let exact = transmittance(crate::spectrum::of_rgb(sigma_t), 1.5);
        for c in 0..3 {
            assert!(
                (tr[c] - exact[c]).abs() < 4.0 * se[c],
                "{tr} ± {se}, {exact}"
            );
            assert!(se[c] < 0.03 * exact[c], "{se}");
        }
    }

    #[test]
    fn ratio_tracking_estimates_the_optical_depth_of_a_grid() {
        // A 4 x 1 x 1 grid of densities 0, 1, 2, 3 over [0, 2] x [0, 1] x [0, 1]; a ray
        // along x at y = z = 1/2 sees the trilinear ramp: optical depth integrated exactly
        // by fine midpoints, then Beer's law.
        let grid = Arc::new(DensityGrid::new([4, 1, 1], 1, vec![0.0, 1.0, 2.0, 3.0]).unwrap());
        let to_unit = Affine3A::from_scale(glam::Vec3::new(0.5, 1.0, 1.0));
        let sigma_t = Volume::Grid {
            grid,
            to_local: to_unit,
            scale: Rgb::splat(1.5),
        };
        let medium = Medium::Heterogeneous(Box::new(Heterogeneous::new(
            Coefficients::Albedo {
                sigma_t: sigma_t.clone(),
                albedo: Volume::Constant(Rgb::splat(0.8)),
            },
            Volume::Constant(Rgb::ZERO),
            Phase::Isotropic,
            Some(to_unit),
        )));
        let ray = Ray::new(Vec3A::new(-1.0, 0.5, 0.5), Vec3A::X);
        let n = 100_000;
        let depth: f32 = (0..n)
            .map(|i| {
                let x = 2.0 * (i as f32 + 0.5) / n as f32;
                sigma_t.at(Vec3A::new(x, 0.5, 0.5)).x * 2.0 / n as f32
            })
            .sum();
        let exact = (-depth).exp();
        let (tr, se) = mean_transmittance(&medium, &ray, 10.0, 40_000);
        assert!((tr.x - exact).abs() < 4.0 * se.x, "{tr} ± {se}, {exact}");
        assert!(se.x < 0.05 * exact, "{se}");
        assert_eq!(tr.x, tr.y);
    }

    #[test]
    fn ratio_tracking_estimates_the_optical_depth_of_an_rgb_grid_of_two_coefficients() {
        // pbrt-v4's `rgbgrid`: absorption on a 2 x 1 x 1 RGB grid plus a constant scattering,
        // over [0, 1]^3 with zero past the outermost voxel centres; a ray along x at
        // y = z = 1/2 sees both, summed.
        let grid = DensityGrid::new([2, 1, 1], 3, vec![0.2, 1.0, 3.0, 0.6, 2.0, 1.0])
            .unwrap()
            .with_edge(crate::medium::GridEdge::Zero);
        let to_unit = Affine3A::IDENTITY;
        let sigma_a = Volume::Grid {
            grid: Arc::new(grid),
            to_local: to_unit,
            scale: Rgb::ONE,
        };
        let sigma_s = Volume::Constant(Rgb::new(0.5, 0.25, 0.0));
        let medium = Medium::Heterogeneous(Box::new(Heterogeneous::new(
            Coefficients::Separate {
                sigma_a: sigma_a.clone(),
                sigma_s: sigma_s.clone(),
            },
            Volume::Constant(Rgb::ZERO),
            Phase::Isotropic,
            Some(to_unit),
        )));
        assert!(medium.is_chromatic());
        let ray = Ray::new(Vec3A::new(-1.0, 0.5, 0.5), Vec3A::X);
        let n = 100_000;
        let depth: Rgb = (0..n)
            .map(|i| {
                let p = Vec3A::new((i as f32 + 0.5) / n as f32, 0.5, 0.5);
                (sigma_a.at(p) + sigma_s.at(p)) / n as f32
            })
            .sum();
        let exact = (-depth).exp();
        let (tr, se) = mean_transmittance(&medium, &ray, 10.0, 40_000);
        for c in 0..3 {
            assert!(
                (tr[c] - exact[c]).abs() < 4.0 * se[c],
                "{tr} ± {se}, {exact}"
            );
            assert!(se[c] < 0.05 * exact[c], "{se}");
        }
    }

    /// A grid medium whose extinction lies in the blue channel only (a tint of (0, 0, 1)),
    /// with one majorant over the whole ray: red and green see nothing, and blue's
    /// transmittance through the ramp is its own, not its majorant's.
    #[test]
    fn ratio_tracking_is_unbiased_in_a_channel_the_others_do_not_see() {
        let grid = Arc::new(DensityGrid::new([4, 1, 1], 1, vec![0.0, 1.0, 2.0, 3.0]).unwrap());
        let to_unit = Affine3A::from_scale(glam::Vec3::new(0.5, 1.0, 1.0));
        let sigma_t = Volume::Grid {
            grid,
            to_local: to_unit,
            scale: Rgb::new(0.0, 0.0, 1.5),
        };
        let medium = Medium::Heterogeneous(Box::new(Heterogeneous::new(
            Coefficients::Albedo {
                sigma_t: sigma_t.clone(),
                albedo: Volume::Constant(Rgb::splat(0.5)),
            },
            Volume::Constant(Rgb::ZERO),
            Phase::Isotropic,
            None,
        )));
        // From x = -1 to x = 2 (the grid holds its edge voxels' values past them).
        let (ray, tmax) = (Ray::new(Vec3A::new(-1.0, 0.5, 0.5), Vec3A::X), 3.0);
        let n = 100_000;
        let depth: f32 = (0..n)
            .map(|i| {
                let x = -1.0 + tmax * (i as f32 + 0.5) / n as f32;
                sigma_t.at(Vec3A::new(x, 0.5, 0.5)).z * tmax / n as f32
            })
            .sum();
        let (tr, se) = mean_transmittance(&medium, &ray, tmax, 40_000);
        assert_eq!((tr.x, tr.y), (1.0, 1.0));
        let exact = (-depth).exp();
        assert!((tr.z - exact).abs() < 4.0 * se.z, "{tr} ± {se}, {exact}");
        assert!(se.z < 0.05 * exact, "{se}");
        // Far from the majorant's transmittance, which the blue channel must not take.
        assert!(exact > 100.0 * (-4.5f32 * tmax).exp());
    }
}
