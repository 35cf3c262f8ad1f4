//! Ray–primitive intersection for analytic shapes (triangles use obvhs's Möller–Trumbore).

use glam::Vec3A;
use obvhs::ray::Ray;

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

    #[test]
    fn precise_for_a_small_sphere_far_away() {
        let c = Vec3A::new(0.0, 0.0, 1000.0);
        let r = Ray::new_inf(Vec3A::ZERO, Vec3A::Z);
        let t = intersect_sphere(c, 0.01, &r);
        assert!((t - 999.99).abs() < 1e-3, "{t}");
    }
}
