//! Ray–primitive intersection: triangles (Möller–Trumbore) and analytic spheres.

use glam::Vec3A;
use obvhs::ray::Ray;

/// Distance in `[ray.tmin, ray.tmax]` at which `ray` meets the triangle, or infinity: the
/// reference that the packet test ([`super::packet`]) reproduces lane by lane, bit for bit,
/// and that the tests compare the BVH against.
///
/// Möller–Trumbore in the form obvhs uses (Fast Minimum Storage Ray Triangle Intersection),
/// with one difference: a barycentric coordinate of -0.0 counts as inside. obvhs tests the
/// three sign bits at once, so a ray exactly on an edge shared by two triangles (a camera ray
/// along the diagonal of a quad, an axis-aligned ray along a box's seam) missed both and
/// leaked through; here it hits one of them, as in Embree. The obvhs backend tests triangles
/// with it.
pub fn intersect_triangle(tri: &[Vec3A; 3], ray: &Ray) -> f32 {
    moller_trumbore::<false>(tri, ray)
}

/// The same distance with the inside test as one check of three sign bits (after turning
/// -0.0 into +0.0), without branches: what raylab's occlusion queries used before packets.
/// It accepts and rejects the same points as [`intersect_triangle`].
pub fn occludes_triangle(tri: &[Vec3A; 3], ray: &Ray) -> f32 {
    moller_trumbore::<true>(tri, ray)
}

#[inline(always)]
fn moller_trumbore<const BRANCH_FREE: bool>(tri: &[Vec3A; 3], ray: &Ray) -> f32 {
    let [v0, v1, v2] = *tri;
    let e1 = v0 - v1;
    let e2 = v2 - v0;
    let n = e1.cross(e2);
    let c = v0 - ray.origin;
    let r = ray.direction.cross(c);
    let inv_det = 1.0 / n.dot(ray.direction);
    let u = r.dot(e2) * inv_det;
    let v = r.dot(e1) * inv_det;
    let w = 1.0 - u - v;
    let inside = if BRANCH_FREE {
        // x + 0.0 is +0.0 for x = -0.0. A NaN may pass with its sign bit clear, but then t is
        // NaN or infinite and the interval test below, or traversal's `t < tmax`, rejects it.
        let signs = (u + 0.0).to_bits() | (v + 0.0).to_bits() | (w + 0.0).to_bits();
        signs & 0x8000_0000 == 0
    } else {
        // Each compared on its own: a NaN (a ray parallel to the plane makes inv_det
        // infinite) fails its comparison, where f32::min would pass over it.
        u >= 0.0 && v >= 0.0 && w >= 0.0
    };
    if inside && inv_det != 0.0 {
        let t = n.dot(c) * inv_det;
        if t >= ray.tmin && t <= ray.tmax {
            return t;
        }
    }
    f32::INFINITY
}

/// Nearest distance in `[ray.tmin, ray.tmax]` at which `ray` meets the sphere, or infinity.
/// Uses the numerically stable form of the quadratic (Hearn & Baker / Ray Tracing Gems ch. 7):
/// the discriminant is computed from the distance of the centre to the ray's line.
#[inline(always)]
pub fn intersect_sphere(center: Vec3A, radius: f32, ray: &Ray) -> f32 {
    let oc = ray.origin - center;
    let b = oc.dot(ray.direction);
    let closest = oc - ray.direction * b;
    let h = radius * radius - closest.length_squared();
    if h < 0.0 {
        return f32::INFINITY;
    }
    let h = h.sqrt();
    let c = oc.length_squared() - radius * radius;
    // q has the sign of -b; the two roots are c / q and q.
    let q = if b > 0.0 { -b - h } else { -b + h };
    let (mut t0, mut t1) = (c / q, q);
    if q == 0.0 {
        t0 = 0.0;
        t1 = 0.0;
    }
    if t0 > t1 {
        std::mem::swap(&mut t0, &mut t1);
    }
    if t0 >= ray.tmin && t0 <= ray.tmax {
        t0
    } else if t1 >= ray.tmin && t1 <= ray.tmax {
        t1
    } else {
        f32::INFINITY
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hits_from_outside_and_inside_and_misses() {
        let c = Vec3A::new(0.0, 0.0, 5.0);
        let r = Ray::new_inf(Vec3A::ZERO, Vec3A::Z);
        assert!((intersect_sphere(c, 1.0, &r) - 4.0).abs() < 1e-5);
        let inside = Ray::new_inf(c, Vec3A::Z);
        assert!((intersect_sphere(c, 1.0, &inside) - 1.0).abs() < 1e-5);
        let miss = Ray::new_inf(Vec3A::new(2.0, 0.0, 0.0), Vec3A::Z);
        assert!(intersect_sphere(c, 1.0, &miss).is_infinite());
        let behind = Ray::new_inf(Vec3A::new(0.0, 0.0, 10.0), Vec3A::Z);
        assert!(intersect_sphere(c, 1.0, &behind).is_infinite());
        let short = Ray::new(Vec3A::ZERO, Vec3A::Z, 0.0, 3.0);
        assert!(intersect_sphere(c, 1.0, &short).is_infinite());
    }

    /// Rays exactly on the diagonal shared by a square's two triangles, straight down and
    /// slanted within the diagonal's vertical plane: each hits one triangle. (obvhs's sign-bit
    /// test misses every one of them coming from below.)
    #[test]
    fn rays_on_a_shared_edge_hit_one_of_its_triangles() {
        let v = |x: f32, y: f32| Vec3A::new(x, y, 0.0);
        let a = [v(0.0, 0.0), v(1.0, 0.0), v(1.0, 1.0)];
        let b = [v(0.0, 0.0), v(1.0, 1.0), v(0.0, 1.0)];
        let (mut rays, mut misses) = (0, 0);
        for i in 1..1000 {
            let x = i as f32 / 1000.0;
            for (slant, down) in [-0.5f32, -0.1, 0.0, 0.3]
                .into_iter()
                .flat_map(|s| [(s, 1.0), (s, -1.0)])
            {
                // From above and from below: the signs of the barycentrics' zeros differ.
                let dir = Vec3A::new(slant, slant, -down).normalize();
                let ray = Ray::new_inf(Vec3A::new(x, x, 0.0) - dir * 2.0, dir);
                for test in [intersect_triangle, occludes_triangle] {
                    let hit = test(&a, &ray).min(test(&b, &ray));
                    rays += 1;
                    misses += usize::from(!hit.is_finite());
                }
            }
        }
        assert_eq!(
            misses, 0,
            "{misses} of {rays} rays on the shared edge missed both triangles"
        );
    }

    #[test]
    fn triangle_hits_inside_misses_outside_and_respects_the_interval() {
        for test in [intersect_triangle, occludes_triangle] {
            let tri = [
                Vec3A::new(0.0, 0.0, 5.0),
                Vec3A::new(1.0, 0.0, 5.0),
                Vec3A::new(0.0, 1.0, 5.0),
            ];
            let at = |x: f32, y: f32| Ray::new_inf(Vec3A::new(x, y, 0.0), Vec3A::Z);
            assert!((test(&tri, &at(0.2, 0.2)) - 5.0).abs() < 1e-6);
            assert!(test(&tri, &at(0.6, 0.6)).is_infinite());
            assert!(test(&tri, &at(-0.01, 0.5)).is_infinite());
            let short = Ray::new(Vec3A::new(0.2, 0.2, 0.0), Vec3A::Z, 0.0, 4.0);
            assert!(test(&tri, &short).is_infinite());
            // A ray in the triangle's plane, or parallel to it beside it, never hits it.
            let grazing = Ray::new_inf(Vec3A::new(-1.0, 0.2, 5.0), Vec3A::X);
            assert!(test(&tri, &grazing).is_infinite());
            for (origin, dir) in [
                (Vec3A::new(-1.0, 0.2, 4.0), Vec3A::X),
                (Vec3A::new(0.2, -1.0, 6.0), Vec3A::Y),
                (
                    Vec3A::new(0.0, 0.0, 4.5),
                    Vec3A::new(1.0, 1.0, 0.0).normalize(),
                ),
            ] {
                let t = test(&tri, &Ray::new_inf(origin, dir));
                assert!(t.is_infinite(), "{origin} {dir}: {t}");
            }
        }
    }

    #[test]
    fn precise_for_a_small_sphere_far_away() {
        let c = Vec3A::new(0.0, 0.0, 1000.0);
        let r = Ray::new_inf(Vec3A::ZERO, Vec3A::Z);
        let t = intersect_sphere(c, 0.01, &r);
        assert!((t - 999.99).abs() < 1e-3, "{t}");
    }
}
