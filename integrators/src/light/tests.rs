use super::sphere::sphere_sample;
use super::*;
use crate::spectrum::rgb_of;
use crate::testing::chi2::{assert_chi2, assert_chi2_discrete, Grid, SAMPLES};
use crate::Sampler;
use glam::DVec3;
use std::f32::consts::{PI, TAU};

fn d(v: Vec3A) -> DVec3 {
    DVec3::new(v.x as f64, v.y as f64, v.z as f64)
}

fn f(v: DVec3) -> Vec3A {
    Vec3A::new(v.x as f32, v.y as f32, v.z as f32)
}

/// Where the ray `p + t w` first reaches the light (f64 ray casting, independent of the
/// sampling code): the point and the light's geometric normal there.
fn hit_light(light: &Light, p: Vec3A, w: Vec3A) -> Option<(Vec3A, Vec3A)> {
    let (o, w) = (d(p), d(w).normalize());
    match *light {
        Light::Planar(Planar { p0, e1, e2, n, .. }) => {
            // Moller-Trumbore.
            let (e1, e2) = (d(e1), d(e2));
            let pv = w.cross(e2);
            let det = e1.dot(pv);
            if det.abs() < 1e-15 {
                return None;
            }
            let tv = o - d(p0);
            let b1 = tv.dot(pv) / det;
            let qv = tv.cross(e1);
            let b2 = w.dot(qv) / det;
            let t = e2.dot(qv) / det;
            let inside = match light {
                Light::Planar(Planar {
                    shape: PlanarShape::Triangle,
                    ..
                }) => b1 >= 0.0 && b2 >= 0.0 && b1 + b2 <= 1.0,
                // The disk's point p0 + b1 e1 + b2 e2 is in the ellipse where (b1, b2) is in
                // the unit disk.
                Light::Planar(Planar {
                    shape: PlanarShape::Disk,
                    ..
                }) => b1 * b1 + b2 * b2 <= 1.0,
                _ => (0.0..=1.0).contains(&b1) && (0.0..=1.0).contains(&b2),
            };
            (inside && t > 0.0).then(|| (f(o + w * t), n))
        }
        Light::Cylinder(CylinderLight {
            base,
            axis,
            u,
            v,
            radius,
            inward,
            ..
        }) => {
            // In the frame (u, v, axis): x^2 + y^2 = r^2, 0 <= z <= 1 along the axis.
            let (u, v, a) = (d(u), d(v), d(axis));
            let rel = o - d(base);
            let (ox, oy, oz) = (rel.dot(u), rel.dot(v), rel.dot(a) / a.length_squared());
            let (dx, dy, dz) = (w.dot(u), w.dot(v), w.dot(a) / a.length_squared());
            let qa = dx * dx + dy * dy;
            let qb = 2.0 * (ox * dx + oy * dy);
            let qc = ox * ox + oy * oy - (radius as f64).powi(2);
            let disc = qb * qb - 4.0 * qa * qc;
            if qa == 0.0 || disc < 0.0 {
                return None;
            }
            let roots = [
                (-qb - disc.sqrt()) / (2.0 * qa),
                (-qb + disc.sqrt()) / (2.0 * qa),
            ];
            let t = roots
                .into_iter()
                .find(|&t| t > 0.0 && (0.0..=1.0).contains(&(oz + dz * t)))?;
            let q = o + w * t;
            let radial = (q - d(base)) - a * ((q - d(base)).dot(a) / a.length_squared());
            let n = f(radial.normalize());
            Some((f(q), if inward { -n } else { n }))
        }
        Light::Sphere(SphereLight { center, radius, .. }) => {
            let oc = o - d(center);
            let b = oc.dot(w);
            let c = oc.length_squared() - (radius as f64).powi(2);
            let disc = b * b - c;
            if disc < 0.0 {
                return None;
            }
            let (t0, t1) = (-b - disc.sqrt(), -b + disc.sqrt());
            let t = if t0 > 0.0 { t0 } else { t1 };
            (t > 0.0).then(|| {
                let q = o + w * t;
                (f(q), f((q - d(center)).normalize()))
            })
        }
        Light::Environment(_) | Light::EnvMap(_) => Some((p + f(w), -f(w))),
        Light::Point(_) | Light::Spot(_) | Light::Projector(_) | Light::Directional(_) => None,
    }
}

/// The density `pdf_li` claims for direction `w` from `p`, found by ray casting.
fn pdf_by_ray(light: &Light, p: Vec3A) -> impl Fn(Vec3A) -> f32 + '_ {
    move |w| match hit_light(light, p, w) {
        Some((q, _)) => light.pdf_li(p, w, q),
        None => 0.0,
    }
}

/// A histogram window around the light as seen from `p` (from 10^4 points on it).
fn polygon_grid(p: Vec3A, light: &Light) -> Grid {
    let n = 100;
    let (p0, e1, e2, tri) = match *light {
        Light::Planar(Planar {
            shape: PlanarShape::Triangle,
            p0,
            e1,
            e2,
            ..
        }) => (p0, e1, e2, true),
        Light::Planar(Planar {
            shape: PlanarShape::Parallelogram,
            p0,
            e1,
            e2,
            ..
        }) => (p0, e1, e2, false),
        Light::Planar(Planar {
            shape: PlanarShape::Disk,
            p0,
            e1,
            e2,
            ..
        }) => {
            // The disk is inside the parallelogram of its bounding square.
            return polygon_grid(
                p,
                &Light::parallelogram(p0 - e1 - e2, e1 * 2.0, e2 * 2.0, L, true),
            );
        }
        _ => unreachable!(),
    };
    let mut points = Vec::new();
    for i in 0..=n {
        for j in 0..=n {
            if !tri || i + j <= n {
                points.push(p0 + e1 * (i as f32 / n as f32) + e2 * (j as f32 / n as f32));
            }
        }
    }
    let centroid = points.iter().copied().sum::<Vec3A>() / points.len() as f32;
    Grid::around_points(p, centroid - p, &points, 30, 30)
}

fn vertices(light: &Light) -> Vec<Vec3A> {
    match *light {
        Light::Planar(Planar {
            shape: PlanarShape::Triangle,
            p0,
            e1,
            e2,
            ..
        }) => vec![p0, p0 + e1, p0 + e2],
        Light::Planar(Planar {
            shape: PlanarShape::Parallelogram,
            p0,
            e1,
            e2,
            ..
        }) => vec![p0, p0 + e1, p0 + e2, p0 + e1 + e2],
        _ => unreachable!(),
    }
}

/// Every sample agrees with `pdf_li`, `emitted` and the ray-cast hit point.
fn check_samples(light: &Light, p: Vec3A, n: usize, seed: u64) -> usize {
    let mut s = Sampler::new(seed, 0, 0);
    let mut accepted = 0;
    for _ in 0..n {
        let Some(ls) = light.sample_li(p, s.next_2d(), &Wavelengths::Rgb) else {
            continue;
        };
        accepted += 1;
        assert!((ls.wi.length() - 1.0).abs() < 1e-5 && ls.pdf > 0.0 && ls.pdf.is_finite());
        let (q, nq) = hit_light(light, p, ls.wi).expect("the sampled direction hits the light");
        // The density at the sampled point (the ray-cast point is the same up to rounding,
        // checked below, but a curved light's normal there is ill-conditioned at grazing
        // angles: a tangential error of dist * 1e-7 / cos turns it).
        let at = if ls.dist.is_finite() { ls.point } else { q };
        let pdf = light.pdf_li(p, ls.wi, at);
        assert!(
            (pdf - ls.pdf).abs() <= 1e-3 * pdf,
            "pdf_li {pdf} vs sampled {}",
            ls.pdf
        );
        assert_eq!(light.emitted(nq, -ls.wi, &Wavelengths::Rgb), ls.radiance);
        if ls.dist.is_finite() {
            let hit_dist = (q - p).length();
            assert!(
                (hit_dist - ls.dist).abs() <= 1e-3 * ls.dist,
                "closest hit at {hit_dist}, sample at {}",
                ls.dist
            );
            assert!((ls.point - p - ls.wi * ls.dist).length() <= 1e-4 * ls.dist.max(1.0));
        }
    }
    accepted
}

fn chi2_light(name: &str, light: &Light, p: Vec3A, grid: &Grid, seed: u64) {
    assert!(check_samples(light, p, 20_000, seed + 1000) > 0);
    assert_chi2(
        name,
        grid,
        SAMPLES,
        seed,
        |s| {
            light
                .sample_li(p, s.next_2d(), &Wavelengths::Rgb)
                .map(|ls| ls.wi)
        },
        pdf_by_ray(light, p),
    );
}

const L: Rgb = Rgb::new(1.0, 2.0, 3.0);

fn triangle(two_sided: bool) -> Light {
    Light::triangle(
        Vec3A::ZERO,
        Vec3A::new(1.0, 0.0, 0.0),
        Vec3A::new(0.2, 1.0, 0.1),
        L,
        two_sided,
    )
}

fn quad(two_sided: bool) -> Light {
    // Faces down (-z, tilted): e1 x e2 = (0.3, 0, -1).
    Light::parallelogram(
        Vec3A::new(-0.5, -0.5, 1.0),
        Vec3A::new(0.0, 1.0, 0.0),
        Vec3A::new(1.0, 0.0, 0.3),
        L,
        two_sided,
    )
}

#[test]
fn chi2_triangle_one_sided() {
    let (light, p) = (triangle(false), Vec3A::new(0.9, -0.3, 0.4));
    chi2_light(
        "triangle one-sided",
        &light,
        p,
        &polygon_grid(p, &light),
        701,
    );
}

#[test]
fn chi2_triangle_two_sided_from_behind() {
    let (light, p) = (triangle(true), Vec3A::new(0.2, 0.6, -0.5));
    chi2_light(
        "triangle two-sided, back",
        &light,
        p,
        &polygon_grid(p, &light),
        702,
    );
}

#[test]
fn chi2_parallelogram_one_sided() {
    let (light, p) = (quad(false), Vec3A::new(0.3, 0.2, 0.0));
    chi2_light(
        "parallelogram one-sided",
        &light,
        p,
        &polygon_grid(p, &light),
        703,
    );
}

#[test]
fn chi2_parallelogram_two_sided_from_behind_near_grazing() {
    let (light, p) = (quad(true), Vec3A::new(2.5, 0.3, 2.0));
    assert!(
        p.dot(Vec3A::new(0.3, 0.0, -1.0)) < 0.0,
        "p is behind the light"
    );
    chi2_light(
        "parallelogram two-sided, back, grazing",
        &light,
        p,
        &polygon_grid(p, &light),
        704,
    );
}

fn sphere_grid(light: &Light, p: Vec3A) -> Grid {
    let Light::Sphere(SphereLight { center, radius, .. }) = *light else {
        unreachable!()
    };
    let (dc, r) = (d(center - p), radius as f64);
    let sin2 = r * r / dc.length_squared();
    let t_edge = sin2 / (1.0 + (1.0 - sin2).sqrt());
    Grid::cap_with_edge(f(dc.normalize()), t_edge, 20, 40)
}

#[test]
fn chi2_sphere_near() {
    let light = Light::Sphere(SphereLight {
        center: Vec3A::new(0.2, -0.1, 2.0),
        radius: 1.2,
        radiance: L,
        inward: false,
    });
    let p = Vec3A::new(0.0, 0.3, 0.1);
    chi2_light("sphere near", &light, p, &sphere_grid(&light, p), 705);
}

#[test]
fn chi2_sphere_far() {
    // sin^2(theta_max) = 4e-4: pbrt's small-angle regime.
    let light = Light::Sphere(SphereLight {
        center: Vec3A::new(30.0, -40.0, 0.0),
        radius: 1.0,
        radiance: L,
        inward: false,
    });
    let p = Vec3A::new(0.0, 0.0, 0.0);
    chi2_light("sphere far", &light, p, &sphere_grid(&light, p), 706);
}

#[test]
fn chi2_sphere_inside_area_sampling() {
    // From inside nothing is emitted towards p (sample_li is None), so this tests the
    // geometric area sampling against an independent density: dist^2 / (|cos| 4 pi r^2).
    let (center, radius) = (Vec3A::new(1.0, 0.0, 0.0), 2.0f32);
    let light = Light::Sphere(SphereLight {
        center,
        radius,
        radiance: L,
        inward: false,
    });
    let p = Vec3A::new(2.2, 0.5, -0.3);
    // The same sphere with its normals flipped emits into its inside only, sampled by the
    // same area sampling, with the density pdf_li reports.
    let inward = Light::sphere_inward(center, radius, L);
    let mut s = Sampler::new(709, 0, 0);
    for _ in 0..1000 {
        let ls = inward
            .sample_li(p, s.next_2d(), &Wavelengths::Rgb)
            .expect("inside an inward sphere");
        let (q, n) = hit_light(&inward, p, ls.wi).expect("inside");
        let pdf = inward.pdf_li(p, ls.wi, q);
        assert!((pdf - ls.pdf).abs() <= 1e-3 * pdf, "{pdf} vs {}", ls.pdf);
        assert_eq!(rgb_of(inward.emitted(n, -ls.wi, &Wavelengths::Rgb)), L);
        assert!(inward
            .sample_li(
                center + Vec3A::new(0.0, 3.0, 0.0),
                s.next_2d(),
                &Wavelengths::Rgb
            )
            .is_none());
    }
    let mut s = Sampler::new(707, 0, 0);
    for _ in 0..1000 {
        assert!(light.sample_li(p, s.next_2d(), &Wavelengths::Rgb).is_none());
        let w = crate::sampling::uniform_sphere(s.next_2d());
        let (q, n) = hit_light(&light, p, w).expect("inside");
        assert_eq!(light.pdf_li(p, w, q), 0.0);
        assert_eq!(rgb_of(light.emitted(n, -w, &Wavelengths::Rgb)), Rgb::ZERO);
    }
    let pdf = |w: Vec3A| {
        let (q, n) = hit_light(&light, p, w).expect("inside");
        let dist2 = (q - p).length_squared();
        dist2 / (n.dot(w).abs() * 4.0 * PI * radius * radius)
    };
    assert_chi2(
        "sphere inside (area sampling)",
        &Grid::sphere(20, 40),
        SAMPLES,
        708,
        |s| {
            let (q, _, _) = sphere_sample(center, radius, p, s.next_2d())?;
            Some((q - p).normalize())
        },
        pdf,
    );
    // And the density sphere_sample reports is that one.
    for _ in 0..1000 {
        let (q, n, pdf_s) = sphere_sample(center, radius, p, s.next_2d()).expect("sample");
        assert!(((q - center).length() - radius).abs() < 1e-5 && (n.length() - 1.0).abs() < 1e-5);
        let expected = pdf((q - p).normalize());
        assert!(
            (pdf_s - expected).abs() <= 1e-3 * expected,
            "{pdf_s} vs {expected}"
        );
    }
}

/// A tilted ellipse (axes of 0.8 and 0.5) beside and above `p`.
fn disk(two_sided: bool) -> Light {
    let e1 = Vec3A::new(0.8, 0.0, 0.1);
    let e2 = Vec3A::new(0.0, 0.5, 0.2);
    Light::disk(Vec3A::new(0.3, -0.2, 1.5), e1, e2, L, two_sided)
}

#[test]
fn chi2_disk_one_sided() {
    let light = disk(false);
    let p = Vec3A::new(0.0, 0.1, 3.0);
    chi2_light("disk one-sided", &light, p, &polygon_grid(p, &light), 721);
}

#[test]
fn chi2_disk_two_sided_from_behind_near_grazing() {
    let light = disk(true);
    // Almost in the disk's plane, behind it.
    let p = Vec3A::new(2.51, -0.163, 1.683);
    chi2_light("disk two-sided", &light, p, &polygon_grid(p, &light), 722);
}

/// A cylinder of radius 0.4 around a tilted axis of length 1.5.
fn cylinder(inward: bool) -> Light {
    let axis = Vec3A::new(0.3, 0.2, 1.5);
    let frame = crate::Frame::from_normal(axis.normalize());
    Light::Cylinder(CylinderLight {
        base: Vec3A::new(0.5, 0.0, -0.5),
        axis,
        u: frame.s,
        v: frame.t,
        radius: 0.4,
        radiance: L,
        inward,
    })
}

/// A histogram window around points of the cylinder seen from `p`.
fn cylinder_grid(light: &Light, p: Vec3A) -> Grid {
    let Light::Cylinder(c) = light else {
        unreachable!()
    };
    let mut points = Vec::new();
    for i in 0..=60 {
        for j in 0..60 {
            let (sin, cos) = (TAU * j as f32 / 60.0).sin_cos();
            let radial = c.u * cos + c.v * sin;
            points.push(c.base + c.axis * (i as f32 / 60.0) + radial * c.radius);
        }
    }
    let centroid = c.base + c.axis * 0.5;
    Grid::around_points(p, centroid - p, &points, 30, 30)
}

#[test]
fn chi2_cylinder_from_outside() {
    let light = cylinder(false);
    let p = Vec3A::new(-1.0, 0.6, 0.4);
    chi2_light(
        "cylinder outside",
        &light,
        p,
        &cylinder_grid(&light, p),
        723,
    );
}

#[test]
fn chi2_cylinder_inward_from_inside() {
    // Inside, near one end: the inner wall all around, seen under every angle.
    let light = cylinder(true);
    let Light::Cylinder(c) = &light else {
        unreachable!()
    };
    let p = c.base + c.axis * 0.2 + c.u * 0.1;
    assert!(light.lights_itself() && !cylinder(false).lights_itself());
    chi2_light("cylinder inside", &light, p, &Grid::sphere(20, 40), 724);
    // Nothing reaches the inside from an outward cylinder, nor the outside from an inward
    // one (but through its open ends: a point on the axis beyond them sees its inside).
    let mut s = Sampler::new(725, 0, 0);
    for _ in 0..1000 {
        assert!(cylinder(false)
            .sample_li(p, s.next_2d(), &Wavelengths::Rgb)
            .is_none());
        let beside = c.base + c.axis * 0.5 + c.u * 2.0;
        if let Some(ls) = light.sample_li(beside, s.next_2d(), &Wavelengths::Rgb) {
            // Only points of the far wall, whose inside faces `beside`: occluded by the near
            // wall, which the integrators' shadow rays find.
            let (q, _) = hit_light(&cylinder(false), beside, ls.wi).expect("hits the wall");
            assert!((q - beside).length() < ls.dist * 0.999);
        }
    }
}

#[test]
fn chi2_environment() {
    let light = Light::environment(L);
    let p = Vec3A::new(3.0, 1.0, -2.0);
    chi2_light("environment", &light, p, &Grid::sphere(20, 40), 709);
}

#[test]
fn one_sided_emitters_are_dark_from_behind() {
    let mut s = Sampler::new(710, 0, 0);
    for (light, p) in [
        (triangle(false), Vec3A::new(0.2, 0.6, -0.5)),
        (quad(false), Vec3A::new(2.5, 0.3, 2.0)),
    ] {
        for _ in 0..1000 {
            assert!(light.sample_li(p, s.next_2d(), &Wavelengths::Rgb).is_none());
        }
        let verts = vertices(&light);
        let q = verts.iter().copied().sum::<Vec3A>() / verts.len() as f32;
        let (wi, n) = ((q - p).normalize(), light_normal(&light));
        assert_eq!(light.pdf_li(p, wi, q), 0.0);
        assert_eq!(rgb_of(light.emitted(n, -wi, &Wavelengths::Rgb)), Rgb::ZERO);
        assert_eq!(
            rgb_of(light.emitted(n, wi, &Wavelengths::Rgb)),
            L,
            "front side"
        );
        // On the light's plane: no sample, no density.
        let on_plane = verts[0] + (verts[1] - verts[0]) * 2.0;
        assert!(light
            .sample_li(on_plane, Vec2::splat(0.3), &Wavelengths::Rgb)
            .is_none());
    }
}

fn light_normal(light: &Light) -> Vec3A {
    match *light {
        Light::Planar(Planar { n, .. }) => n,
        _ => unreachable!(),
    }
}

#[test]
fn sphere_samples_are_on_the_visible_cap_and_far_densities_are_accurate() {
    for dist in [1.5f32, 10.0, 1e3, 1e5] {
        let light = Light::Sphere(SphereLight {
            center: Vec3A::new(0.0, dist, 0.0),
            radius: 1.0,
            radiance: L,
            inward: false,
        });
        let p = Vec3A::ZERO;
        check_samples(&light, p, 2000, 711);
        let ls = light
            .sample_li(p, Vec2::new(0.999, 0.3), &Wavelengths::Rgb)
            .expect("visible");
        // Density against the f64 formula 1 / (2 pi (1 - cos_max)).
        let sin2 = 1.0 / (dist as f64 * dist as f64);
        let expected = 1.0 / (2.0 * std::f64::consts::PI * (sin2 / (1.0 + (1.0 - sin2).sqrt())));
        assert!(
            (ls.pdf as f64 - expected).abs() < 1e-5 * expected,
            "d {dist}: {} vs {expected}",
            ls.pdf
        );
        // The sample is on the sphere, on the side facing p.
        let Light::Sphere(SphereLight { center, .. }) = light else {
            unreachable!()
        };
        assert!(((ls.point - center).length() - 1.0).abs() < 1e-4 * dist.max(1.0));
        assert!((ls.point - center).dot(p - ls.point) >= 0.0);
    }
}

#[test]
fn point_light_is_a_delta_with_inverse_square_falloff() {
    let light = Light::Point(PointLight {
        position: Vec3A::new(0.0, 0.0, 2.0),
        intensity: Rgb::splat(8.0),
    });
    let ls = light
        .sample_li(Vec3A::ZERO, Vec2::ZERO, &Wavelengths::Rgb)
        .expect("sample");
    assert!(ls.delta && light.is_delta() && ls.pdf == 1.0 && ls.dist == 2.0);
    assert_eq!(ls.wi, Vec3A::Z);
    assert_eq!(rgb_of(ls.radiance), Rgb::splat(2.0));
    assert_eq!(light.pdf_li(Vec3A::ZERO, Vec3A::Z, ls.point), 0.0);
    assert_eq!(
        rgb_of(light.emitted(Vec3A::Z, Vec3A::Z, &Wavelengths::Rgb)),
        Rgb::ZERO
    );
    assert!(
        light
            .sample_li(Vec3A::new(0.0, 0.0, 2.0), Vec2::ZERO, &Wavelengths::Rgb)
            .is_none(),
        "at the light"
    );
}

#[test]
fn emitted_radiance_by_side() {
    let sphere = Light::sphere(Vec3A::ZERO, 1.0, L);
    assert_eq!(
        rgb_of(sphere.emitted(Vec3A::Z, Vec3A::new(0.0, 0.6, 0.8), &Wavelengths::Rgb)),
        L
    );
    assert_eq!(
        rgb_of(sphere.emitted(Vec3A::Z, -Vec3A::Z, &Wavelengths::Rgb)),
        Rgb::ZERO
    );
    assert_eq!(
        rgb_of(triangle(true).emitted(Vec3A::Z, -Vec3A::Z, &Wavelengths::Rgb)),
        L
    );
    let env = Light::environment(L);
    assert_eq!(
        rgb_of(env.emitted(Vec3A::ZERO, Vec3A::X, &Wavelengths::Rgb)),
        L
    );
    let ls = env
        .sample_li(Vec3A::ONE, Vec2::new(0.3, 0.7), &Wavelengths::Rgb)
        .expect("sample");
    assert!(
        ls.dist.is_infinite()
            && !ls.delta
            && (ls.pdf - 0.25 / PI).abs() < 1e-9
            && rgb_of(ls.radiance) == L
    );
}

#[test]
fn power_formulas() {
    let lum = crate::luminance(L) as f64;
    let pi = std::f64::consts::PI;
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-5 * b.abs();
    let tri = triangle(false);
    let Light::Planar(Planar { area, .. }) = tri else {
        unreachable!()
    };
    assert!(close(tri.power(1.0), lum * area as f64 * pi));
    assert!(close(
        triangle(true).power(1.0),
        2.0 * lum * area as f64 * pi
    ));
    let q = quad(false);
    assert!(close(q.power(1.0), lum * (1.0f64 + 0.09).sqrt() * pi));
    let s = Light::sphere(Vec3A::ZERO, 2.0, L);
    assert!(close(s.power(1.0), lum * 16.0 * pi * pi));
    let p = Light::point(Vec3A::ZERO, L);
    assert!(close(p.power(1.0), 4.0 * pi * lum));
    let e = Light::environment(L);
    assert!(close(e.power(3.0), lum * 36.0 * pi * pi));
    let black = Light::point(Vec3A::ZERO, Rgb::new(-1.0, f32::NAN, 0.0));
    assert_eq!(black.power(1.0), 0.0);
}

/// A light whose power passes f32's range is still chosen (in proportion to its power),
/// not dropped as infinite.
#[test]
fn a_light_beyond_f32_power_is_still_sampled() {
    let huge = Light::sphere(Vec3A::ZERO, 1e15, Rgb::splat(1e10));
    assert!(huge.power(1.0) > f32::MAX as f64 && huge.power(1.0).is_finite());
    let table = LightTable::new(vec![point(1.0), huge], 1.0);
    assert!(table.pmf(1) > 0.999, "{}", table.pmf(1));
}

fn point(intensity: f32) -> Light {
    Light::point(Vec3A::ZERO, Rgb::splat(intensity))
}

#[test]
fn chi2_light_table_selection_follows_power() {
    let intensities = [1.0f32, 0.0, 3.0, 0.5, 0.0, 2.5, 0.0];
    let table = LightTable::new(intensities.iter().map(|&i| point(i)).collect(), 1.0);
    let total: f32 = intensities.iter().sum();
    for (i, &x) in intensities.iter().enumerate() {
        assert!((table.pmf(i as u32) - x / total).abs() < 1e-6);
    }
    let mut counts = vec![0u64; intensities.len()];
    let mut s = Sampler::new(712, 0, 0);
    for _ in 0..SAMPLES {
        let (i, pmf) = table.sample(s.next_1d()).expect("non-empty");
        assert_eq!(pmf, table.pmf(i));
        counts[i as usize] += 1;
    }
    for (i, &x) in intensities.iter().enumerate() {
        if x == 0.0 {
            assert_eq!(counts[i], 0, "zero-power light {i} chosen");
        }
    }
    let expected: Vec<f64> = intensities
        .iter()
        .map(|&x| (x / total) as f64 * SAMPLES as f64)
        .collect();
    assert_chi2_discrete("light table selection", &counts, &expected, SAMPLES);
}

#[test]
fn light_table_edge_cases() {
    let empty = LightTable::new(Vec::new(), 1.0);
    assert!(empty.is_empty() && empty.sample(0.5).is_none() && empty.environment().is_none());
    assert!(LightTable::default().sample(0.3).is_none());

    // All black: uniform.
    let black = LightTable::new(vec![point(0.0), point(0.0), point(0.0), point(0.0)], 1.0);
    for i in 0..4 {
        assert_eq!(black.pmf(i), 0.25);
    }
    assert_eq!(black.sample(0.0).map(|x| x.0), Some(0));
    assert_eq!(black.sample(0.6).map(|x| x.0), Some(2));
    assert_eq!(black.sample(0.999_999_9).map(|x| x.0), Some(3));

    // Zero-power lights at both ends and in the middle are never returned, whatever u.
    let table = LightTable::new(
        vec![point(0.0), point(1.0), point(0.0), point(3.0), point(0.0)],
        1.0,
    );
    let us = (0..=10_000).map(|i| i as f32 / 10_000.0).chain([
        -1.0,
        1.0,
        2.0,
        f32::NAN,
        f32::INFINITY,
        1.0 - f32::EPSILON / 2.0,
    ]);
    for u in us {
        let (i, pmf) = table.sample(u).expect("non-empty");
        assert!(pmf > 0.0 && (i == 1 || i == 3), "u {u} -> {i}");
    }
    assert_eq!(table.sample(0.0).map(|x| x.0), Some(1));
    assert_eq!(table.sample(0.2499).map(|x| x.0), Some(1));
    assert_eq!(table.sample(0.2501).map(|x| x.0), Some(3));

    // The environment light is found (the first, if several).
    let env = Light::environment(L);
    let t = LightTable::new(vec![point(1.0), env.clone(), triangle(false), env], 10.0);
    assert_eq!(t.environment(), Some(1));
    assert_eq!(t.len(), 4);
    assert_eq!(t.get(1).light, &Light::environment(L));
}

#[test]
fn emitted_rays_report_the_densities_pdf_le_gives_and_a_consistent_weight() {
    // For every kind: pdf_le of the sampled ray is the (pdf_pos, pdf_dir) the sample
    // reports, and the weight is Le |cos| / (pdf_pos pdf_dir) (pbrt-v4's SampleLe / PDF_Le).
    let (center, radius) = (Vec3A::new(0.5, 0.2, -0.3), 4.0);
    let lights = [
        triangle(false),
        triangle(true),
        quad(false),
        quad(true),
        disk(false),
        disk(true),
        cylinder(false),
        cylinder(true),
        Light::sphere(Vec3A::new(0.2, -0.1, 2.0), 1.2, L),
        Light::point(Vec3A::new(1.0, 2.0, 3.0), L),
        Light::environment(L),
        Light::Projector(Box::new(
            super::ProjectorLight::new(
                Vec3A::new(1.0, 0.0, 2.0),
                Frame::from_normal(Vec3A::new(0.3, 0.2, -1.0).normalize()),
                crate::texture::Texture::Constant(L),
                2.0,
                70.0,
                1.5,
            )
            .unwrap(),
        )),
    ];
    let mut s = Sampler::new(5, 0, 0);
    for light in &lights {
        let mut back = 0;
        for _ in 0..2000 {
            let le = light
                .sample_le(
                    s.next_2d(),
                    s.next_2d(),
                    s.next_1d(),
                    center,
                    radius,
                    &Wavelengths::Rgb,
                )
                .expect("a ray");
            let (pos, dir) = light.pdf_le(le.normal, le.ray.dir, radius);
            let close = |a: f32, b: f32| (a - b).abs() <= 1e-5 * b.abs().max(1e-6);
            if light.is_delta() {
                assert!(pos == 0.0 && le.pdf_pos == 1.0, "{light:?}");
            } else {
                assert!(close(pos, le.pdf_pos), "{light:?}: {pos} vs {}", le.pdf_pos);
            }
            assert!(close(dir, le.pdf_dir), "{light:?}: {dir} vs {}", le.pdf_dir);
            let cos = match light {
                Light::Point(_) | Light::Spot(_) | Light::Projector(_) => 1.0,
                _ => le.normal.dot(le.ray.dir),
            };
            assert!(cos > 0.0, "{light:?}: the ray leaves the emitting side");
            let expected = le.radiance * (cos / (le.pdf_pos * le.pdf_dir));
            assert!(
                (le.weight - expected).abs().max_element() <= 1e-3 * expected.max_element(),
                "{light:?}: weight {} vs {expected}",
                le.weight
            );
            // The origin lies on the light (the environment's outside the scene's sphere).
            match light {
                Light::Planar(p) => {
                    assert!((le.ray.origin - p.p0).dot(p.n).abs() < 1e-3);
                    back += usize::from(le.normal.dot(p.n) < 0.0);
                }
                Light::Sphere(sph) => {
                    assert!(((le.ray.origin - sph.center).length() - sph.radius).abs() < 1e-3)
                }
                Light::Cylinder(c) => {
                    let n = c.normal_at(le.ray.origin);
                    assert!((n - le.normal).length() < 1e-3, "{n} vs {}", le.normal);
                }
                Light::Point(pt) => assert_eq!(le.ray.origin, pt.position),
                Light::Spot(sp) => assert_eq!(le.ray.origin, sp.position),
                Light::Projector(pr) => assert_eq!(le.ray.origin, pr.position),
                Light::Environment(_) | Light::EnvMap(_) | Light::Directional(_) => {
                    assert!((le.ray.origin - center).length() >= radius * 0.999)
                }
            }
        }
        // Two-sided lights emit from both sides, about equally.
        if let Light::Planar(p) = light {
            if p.two_sided {
                assert!((800..1200).contains(&back), "{back}");
            } else {
                assert_eq!(back, 0);
            }
        }
    }
    // The back of a one-sided light emits nothing.
    let Light::Planar(p) = triangle(false) else {
        unreachable!()
    };
    assert_eq!(triangle(false).pdf_le(p.n, -p.n, radius).1, 0.0);
}

/// A textured emitter's radiance at a point is its texture at the point's interpolated texture
/// coordinates, the same whether the point is sampled, hit or emits a ray.
#[test]
fn a_textured_planar_light_reads_its_texture_where_it_emits() {
    // u picks the column: 1 on the left half, 3 on the right.
    let texture = crate::texture::two_columns();
    // A unit square in z = 0 facing +z, u along x.
    let Light::Planar(p) = Light::parallelogram(Vec3A::ZERO, Vec3A::X, Vec3A::Y, L, false) else {
        unreachable!()
    };
    let uvs = [Vec2::ZERO, Vec2::X, Vec2::Y];
    let light = Light::Planar(p.with_texture(texture, uvs));
    for (x, want) in [(0.2f32, 1.0f32), (0.8, 3.0)] {
        let q = Vec3A::new(x, 0.5, 0.0);
        assert_eq!(
            rgb_of(light.emitted_at(q, Vec3A::Z, Vec3A::Z, &Wavelengths::Rgb)),
            L * want
        );
        assert_eq!(
            rgb_of(light.emitted_at(q, Vec3A::Z, -Vec3A::Z, &Wavelengths::Rgb)),
            Rgb::ZERO
        );
    }
    let mut s = Sampler::new(3, 0, 0);
    for _ in 0..200 {
        let ls = light
            .sample_li(Vec3A::new(0.5, 0.5, 2.0), s.next_2d(), &Wavelengths::Rgb)
            .unwrap();
        let want = if ls.point.x < 0.5 { 1.0 } else { 3.0 };
        assert_eq!(rgb_of(ls.radiance), L * want, "at {}", ls.point);
        let le = light
            .sample_le(
                s.next_2d(),
                s.next_2d(),
                0.0,
                Vec3A::ZERO,
                10.0,
                &Wavelengths::Rgb,
            )
            .unwrap();
        let want = if le.ray.origin.x < 0.5 { 1.0 } else { 3.0 };
        assert!((rgb_of(le.radiance) - L * want).abs().max_element() < 1e-6);
    }
}

/// Every light of a scene takes the room of the largest kind, and a light sample reads one from
/// the table: the rare parts (a spot's or an emitter's texture, a projector) are boxed so that
/// the common ones stay as small as a planar light. (Textures grew the table by 70% before.)
#[test]
fn lights_stay_as_small_as_a_planar_light() {
    assert!(
        std::mem::size_of::<Light>() <= 112,
        "{}",
        std::mem::size_of::<Light>()
    );
    assert!(std::mem::size_of::<Planar>() <= 96);
}
