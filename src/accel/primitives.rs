//! Ray–primitive intersection: triangles (Möller–Trumbore), analytic spheres, and disks and
//! cylinders ([`Quadric`]).

use glam::{Affine3A, Vec2, Vec3A};
use obvhs::ray::Ray;
use raylab_integrators::Hit;
use std::f32::consts::TAU;

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

/// Which unit shape a [`Quadric`] places.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum QuadricKind {
    /// Mitsuba 3's `disk`: the unit disk of the local `xy` plane, its front facing `+z`.
    Disk,
    /// Mitsuba 3's `cylinder` without end caps: radius 1 around the local `z` axis, from
    /// `z = 0` to `z = 1`, its front facing outwards.
    Cylinder,
}

/// A disk or an open cylinder: a unit shape placed in the world by an affine map. Rays are
/// intersected in the unit shape's space (the map keeps the distance `t` along them), as
/// Mitsuba 3 does; the surface records follow Mitsuba 3's parametrisations.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quadric {
    pub kind: QuadricKind,
    /// Unit shape to world.
    pub to_world: Affine3A,
    /// World to unit shape.
    pub to_local: Affine3A,
    /// The normals point the other way (`flip_normals`): inwards on a cylinder, `-z` on a
    /// disk.
    pub flipped: bool,
}

impl Quadric {
    /// The unit shape `kind` placed by `to_world` (invertible).
    pub fn new(kind: QuadricKind, to_world: Affine3A, flipped: bool) -> Quadric {
        Quadric {
            kind,
            to_world,
            to_local: to_world.inverse(),
            flipped,
        }
    }

    /// The tight bounds (min, max): an ellipse's extent along each axis `i` is
    /// `sqrt(a_i^2 + b_i^2)` for its half-axes `a` and `b`; a cylinder's box is that of its
    /// two end circles.
    pub fn bounds(&self) -> (Vec3A, Vec3A) {
        let m = &self.to_world.matrix3;
        let (a, b) = (m.x_axis, m.y_axis);
        let extent = (a * a + b * b).sqrt();
        let base = self.to_world.translation;
        match self.kind {
            QuadricKind::Disk => (base - extent, base + extent),
            QuadricKind::Cylinder => {
                let top = base + m.z_axis;
                (base.min(top) - extent, base.max(top) + extent)
            }
        }
    }

    /// Surface area.
    pub fn area(&self) -> f32 {
        let m = &self.to_world.matrix3;
        match self.kind {
            QuadricKind::Disk => std::f32::consts::PI * m.x_axis.cross(m.y_axis).length(),
            // A circular cross-section (the scene checks it): 2 pi r L.
            QuadricKind::Cylinder => TAU * m.x_axis.length() * m.z_axis.length(),
        }
    }

    /// Nearest distance in `[ray.tmin, ray.tmax]` at which `ray` meets the surface, or
    /// infinity.
    // Out of line: inlined into the packet test, it slowed traversal of scenes without any.
    #[inline(never)]
    pub fn intersect(&self, ray: &Ray) -> f32 {
        let o = self.to_local.transform_point3a(ray.origin);
        let d = self.to_local.transform_vector3a(ray.direction);
        let within = |t: f32| t >= ray.tmin && t <= ray.tmax;
        match self.kind {
            QuadricKind::Disk => {
                // Grazing rays give an infinite or NaN t, which the tests reject.
                let t = -o.z / d.z;
                let (x, y) = (o.x + d.x * t, o.y + d.y * t);
                if within(t) && x * x + y * y <= 1.0 {
                    t
                } else {
                    f32::INFINITY
                }
            }
            QuadricKind::Cylinder => {
                // x^2 + y^2 = 1 in double precision (as Mitsuba 3), the roots in the stable
                // form: q = -(b + sign(b) sqrt(disc)) / 2, roots q / a and c / q.
                let (ox, oy, dx, dy) = (o.x as f64, o.y as f64, d.x as f64, d.y as f64);
                let a = dx * dx + dy * dy;
                let b = 2.0 * (ox * dx + oy * dy);
                let c = ox * ox + oy * oy - 1.0;
                let disc = b * b - 4.0 * a * c;
                if !(a > 0.0 && disc >= 0.0) {
                    return f32::INFINITY;
                }
                let q = -0.5 * (b + disc.sqrt().copysign(b));
                let (t0, t1) = (q / a, c / q);
                let (near, far) = if t0 <= t1 { (t0, t1) } else { (t1, t0) };
                for t in [near, far] {
                    let t = t as f32;
                    let z = o.z + d.z * t;
                    if within(t) && (0.0..=1.0).contains(&z) {
                        return t;
                    }
                }
                f32::INFINITY
            }
        }
    }

    /// The surface record of `ray` (`origin + t dir`) meeting the shape at distance `t`,
    /// with Mitsuba 3's parametrisation: on a disk `uv = (r, phi / 2 pi)` and tangents along
    /// the radius and around it; on a cylinder `uv = (phi / 2 pi, z)`, `dpdu` around the axis
    /// (length `2 pi r`) and `dpdv` along it. The point is put back onto the surface (the
    /// ray's point carries the rounding of `t`).
    #[inline(never)]
    pub fn hit(&self, origin: Vec3A, dir: Vec3A, t: f32, material: u32, light: Option<u32>) -> Hit {
        let m = &self.to_world.matrix3;
        let local = self.to_local.transform_point3a(origin + dir * t);
        let mut phi = local.y.atan2(local.x);
        if phi < 0.0 {
            phi += TAU;
        }
        let (p, n, uv, dpdu, dpdv) = match self.kind {
            QuadricKind::Disk => {
                let r = (local.x * local.x + local.y * local.y).sqrt();
                let (sin, cos) = if r > 0.0 {
                    (local.y / r, local.x / r)
                } else {
                    (0.0, 1.0)
                };
                let on = Vec3A::new(local.x, local.y, 0.0);
                (
                    on,
                    Vec3A::Z,
                    Vec2::new(r, phi / TAU),
                    *m * Vec3A::new(cos, sin, 0.0),
                    *m * Vec3A::new(-sin, cos, 0.0),
                )
            }
            QuadricKind::Cylinder => {
                let radial = Vec3A::new(local.x, local.y, 0.0).normalize_or_zero();
                let z = local.z.clamp(0.0, 1.0);
                (
                    Vec3A::new(radial.x, radial.y, z),
                    radial,
                    Vec2::new(phi / TAU, z),
                    *m * (Vec3A::new(-radial.y, radial.x, 0.0) * TAU),
                    m.z_axis,
                )
            }
        };
        // Normals map by the inverse transpose.
        let ng = (self.to_local.matrix3.transpose() * n).normalize_or_zero();
        let ng = if self.flipped { -ng } else { ng };
        Hit {
            dpdu,
            dpdv,
            uv,
            ..Hit::new(t, self.to_world.transform_point3a(p), ng, material, light)
        }
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

    /// Random disks (ellipses) and cylinders under random rays: the distance agrees with a
    /// world-space f64 computation that does not use the unit shape, and the surface record's
    /// point, normal, uv and tangents agree with the shape's own description.
    #[test]
    fn disks_and_cylinders_against_world_space_geometry() {
        use glam::{DVec3, Quat, Vec3};
        use rand::rngs::StdRng;
        use rand::{Rng, SeedableRng};
        let dv = |v: Vec3A| DVec3::new(v.x as f64, v.y as f64, v.z as f64);
        let mut rng = StdRng::seed_from_u64(17);
        let (mut hits, mut rays) = (0, 0);
        for round in 0..400 {
            let mut u = || rng.random::<f32>();
            let rotation = Quat::from_euler(glam::EulerRot::XYZ, u() * 6.0, u() * 6.0, u() * 6.0);
            let at = Vec3::new(u(), u(), u()) * 4.0 - 2.0;
            let (kind, scale) = if round % 2 == 0 {
                (QuadricKind::Disk, Vec3::new(0.3 + u(), 0.3 + u(), 1.0))
            } else {
                let r = 0.2 + u();
                (QuadricKind::Cylinder, Vec3::new(r, r, 0.5 + 2.0 * u()))
            };
            let m = Affine3A::from_scale_rotation_translation(scale, rotation, at);
            let flipped = round % 3 == 0;
            let q = Quadric::new(kind, m, flipped);
            let (x, y, z) = (m.matrix3.x_axis, m.matrix3.y_axis, m.matrix3.z_axis);
            let c = m.translation;
            for k in 0..50 {
                let mut u = || rng.random::<f32>();
                let target = c + x * (2.0 * u() - 1.0) + y * (2.0 * u() - 1.0) + z * u();
                let origin = Vec3A::new(u(), u(), u()) * 10.0 - 5.0;
                let dir = (target - origin).normalize();
                let tmax = if k % 4 == 0 { 2.0 } else { f32::INFINITY };
                let ray = Ray::new(origin, dir, 0.0, tmax);
                let t = q.intersect(&ray);
                // The independent answer, in f64 and world space.
                let (o, d) = (dv(origin), dv(dir));
                let expected = match kind {
                    QuadricKind::Disk => {
                        let n = dv(x).cross(dv(y));
                        let t = (dv(c) - o).dot(n) / d.dot(n);
                        let p = o + d * t - dv(c);
                        // p = a x + b y: solve in the plane.
                        let g = glam::DMat2::from_cols_array(&[
                            dv(x).dot(dv(x)),
                            dv(x).dot(dv(y)),
                            dv(x).dot(dv(y)),
                            dv(y).dot(dv(y)),
                        ]);
                        let ab = g.inverse() * glam::DVec2::new(p.dot(dv(x)), p.dot(dv(y)));
                        (t >= 0.0 && t <= tmax as f64 && ab.length_squared() <= 1.0).then_some(t)
                    }
                    QuadricKind::Cylinder => {
                        let (axis, r) = (dv(z), x.length() as f64);
                        let a_hat = axis.normalize();
                        let perp = |v: DVec3| v - a_hat * v.dot(a_hat);
                        let (po, pd) = (perp(o - dv(c)), perp(d));
                        let (qa, qb) = (pd.dot(pd), 2.0 * po.dot(pd));
                        let qc = po.dot(po) - r * r;
                        let disc = qb * qb - 4.0 * qa * qc;
                        (disc >= 0.0)
                            .then(|| {
                                [-1.0, 1.0]
                                    .map(|s| (-qb + s * disc.sqrt()) / (2.0 * qa))
                                    .into_iter()
                                    .find(|&t| {
                                        let h = (o + d * t - dv(c)).dot(a_hat) / axis.length();
                                        t >= 0.0 && t <= tmax as f64 && (0.0..=1.0).contains(&h)
                                    })
                            })
                            .flatten()
                    }
                };
                rays += 1;
                match expected {
                    // Rays within rounding of an edge may go either way.
                    None => assert!(
                        t.is_infinite() || {
                            let p = q.to_local.transform_point3a(origin + dir * t);
                            let r2 = p.x * p.x + p.y * p.y;
                            (r2 - 1.0).abs() < 1e-3 || p.z.abs() < 1e-3 || (p.z - 1.0).abs() < 1e-3
                        },
                        "{kind:?}: hit at {t}, none expected"
                    ),
                    Some(e) => {
                        assert!(
                            (t as f64 - e).abs() <= 1e-4 * e.max(1.0),
                            "{kind:?}: {t} vs {e}"
                        );
                        hits += 1;
                        let hit = q.hit(origin, dir, t, 3, Some(1));
                        assert_eq!((hit.material, hit.light), (3, Some(1)));
                        // The point from the parametrisation is the hit's point.
                        let (sin, cos) = (TAU
                            * if kind == QuadricKind::Disk {
                                hit.uv.y
                            } else {
                                hit.uv.x
                            })
                        .sin_cos();
                        let from_uv = match kind {
                            QuadricKind::Disk => c + (x * cos + y * sin) * hit.uv.x,
                            QuadricKind::Cylinder => c + x * cos + y * sin + z * hit.uv.y,
                        };
                        assert!((from_uv - hit.p).length() < 1e-3, "{from_uv} vs {}", hit.p);
                        assert!((hit.p - (origin + dir * t)).length() < 1e-3);
                        // The normal is perpendicular to both tangents, outwards unless flipped.
                        let n = hit.ng;
                        assert!((n.length() - 1.0).abs() < 1e-5);
                        let across = |v: Vec3A| v.dot(n).abs() <= 1e-4 * v.length();
                        assert!(across(hit.dpdu) && across(hit.dpdv), "{kind:?}");
                        let outward = match kind {
                            QuadricKind::Disk => x.cross(y),
                            QuadricKind::Cylinder => {
                                let rel = hit.p - c;
                                rel - z * (rel.dot(z) / z.length_squared())
                            }
                        };
                        assert_eq!(outward.dot(n) > 0.0, !flipped, "{kind:?}");
                        // dpdu and dpdv are the derivatives of the point along u and v.
                        let p_at = |uv: Vec2| match kind {
                            QuadricKind::Disk => {
                                let (s, c2) = (TAU * uv.y).sin_cos();
                                c + (x * c2 + y * s) * uv.x
                            }
                            QuadricKind::Cylinder => {
                                let (s, c2) = (TAU * uv.x).sin_cos();
                                c + x * c2 + y * s + z * uv.y
                            }
                        };
                        let h = 1e-3;
                        let du = (p_at(hit.uv + Vec2::new(h, 0.0)) - p_at(hit.uv)) / h;
                        let dv_ = (p_at(hit.uv + Vec2::new(0.0, h)) - p_at(hit.uv)) / h;
                        match kind {
                            QuadricKind::Cylinder => {
                                assert!(
                                    (du - hit.dpdu).length() < 2e-2 * hit.dpdu.length().max(1.0)
                                );
                                assert!(
                                    (dv_ - hit.dpdv).length() < 2e-2 * hit.dpdv.length().max(1.0)
                                );
                            }
                            // Mitsuba's disk: dpdu the unit radial direction (its derivative
                            // along r), dpdv the tangent around, of the placed unit length.
                            QuadricKind::Disk => {
                                assert!(
                                    (du - hit.dpdu).length() < 2e-2 * hit.dpdu.length().max(1.0)
                                );
                                let around = dv_ / (TAU * hit.uv.x.max(1e-3));
                                if hit.uv.x > 0.05 {
                                    assert!(
                                        (around - hit.dpdv).length() < 5e-2 * hit.dpdv.length()
                                    );
                                }
                            }
                        }
                    }
                }
            }
        }
        assert!(hits > rays / 5, "{hits} of {rays}");
    }

    #[test]
    fn precise_for_a_small_sphere_far_away() {
        let c = Vec3A::new(0.0, 0.0, 1000.0);
        let r = Ray::new_inf(Vec3A::ZERO, Vec3A::Z);
        let t = intersect_sphere(c, 0.01, &r);
        assert!((t - 999.99).abs() < 1e-3, "{t}");
    }
}
