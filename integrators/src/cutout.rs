//! Surfaces cut out by pbrt-v4's `alpha`: where a surface's alpha `a` is below 1, a ray
//! passes through it with probability `1 - a`, as if it were not there: no scattering event, no
//! bounce counted, shadow rays alike. As in pbrt-v4, whether a given ray passes is a hash of
//! its origin and direction (so the same ray decides the same way, at any thread count), and
//! `a <= 0` always passes.
//!
//! [`closest_through_cutouts`] is the closest hit a scene with cut-outs reports: the closest
//! surface hit that does not pass, found by going on past the ones that do.

use crate::{Hit, Ray, SurfaceMaterial};

/// How many cut-out surfaces a ray passes before the scene calls it stopped: a bound on the
/// work one ray can cause (foliage has tens of layers, not thousands).
pub const MAX_LAYERS: usize = 1024;

/// Whether `ray` passes a surface of alpha `a` (see the module docs).
#[inline]
pub fn passes(a: f32, ray: &Ray) -> bool {
    if a >= 1.0 {
        return false;
    }
    if a <= 0.0 {
        return true;
    }
    let bits = |v: glam::Vec3A| {
        (v.x.to_bits() as u64) ^ ((v.y.to_bits() as u64) << 21) ^ ((v.z.to_bits() as u64) << 42)
    };
    let h = crate::random::mix64(bits(ray.origin) ^ crate::random::mix64(bits(ray.dir)));
    let u = (h >> 40) as f32 * (1.0 / (1u64 << 24) as f32);
    u > a
}

/// The closest hit along `ray` that a cut-out does not let it pass, with `t` measured along
/// `ray`; `closest` answers a ray against the geometry, `parametrise` computes a hit's
/// texture coordinates, `material` names a hit's material. `None` when nothing stops the ray
/// (or it passed [`MAX_LAYERS`] cut-outs).
pub fn closest_through_cutouts<'m>(
    ray: &Ray,
    closest: impl Fn(&Ray) -> Option<Hit>,
    parametrise: impl Fn(&mut Hit),
    material: impl Fn(u32) -> &'m SurfaceMaterial,
) -> Option<Hit> {
    let mut r = *ray;
    for _ in 0..MAX_LAYERS {
        let mut hit = closest(&r)?;
        let Some(alpha) = material(hit.material).cutout() else {
            return Some(along(ray, hit));
        };
        parametrise(&mut hit);
        if !passes(
            alpha.at_scalar(&crate::texture::TextureLookup::at(&hit)),
            &r,
        ) {
            return Some(along(ray, hit));
        }
        let next = hit.spawn_ray(r.dir);
        let travelled = (next.origin - ray.origin).dot(ray.dir) / ray.dir.length_squared();
        r = Ray {
            tmax: ray.tmax - travelled,
            ..next
        };
        if r.tmax.is_nan() || r.tmax <= 0.0 {
            return None;
        }
    }
    None
}

/// `hit` with its distance measured from `ray`'s origin.
#[inline]
fn along(ray: &Ray, hit: Hit) -> Hit {
    Hit {
        t: (hit.p - ray.origin).dot(ray.dir) / ray.dir.length_squared(),
        ..hit
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3A;

    #[test]
    fn a_share_alpha_of_rays_stops() {
        let mut stopped = 0;
        let n = 100_000;
        for i in 0..n {
            let d = Vec3A::new((i as f32 * 0.001).sin(), (i as f32 * 0.0007).cos(), 1.0);
            let ray = Ray::new(Vec3A::new(i as f32 * 1e-3, 0.5, -2.0), d.normalize());
            if !passes(0.3, &ray) {
                stopped += 1;
            }
            assert!(passes(0.0, &ray) && !passes(1.0, &ray));
        }
        let share = stopped as f64 / n as f64;
        // Binomial standard error at n = 1e5: 0.0014.
        assert!((share - 0.3).abs() < 0.007, "{share}");
    }
}
