//! Mitsuba 3's `sdfgrid`: a signed distance function sampled on a grid of `nx x ny x nz`
//! values over the unit cube of its own space (value `(i, j, k)` at `(i, j, k) / (n - 1)`),
//! interpolated trilinearly, its zero set the surface; placed in the world by an affine map.
//!
//! Each voxel whose corners change sign (or touch zero) is one primitive, bounded by the tight
//! box of Hansson-Söderlund and Akenine-Möller 2023 (the corners at zero and the edges'
//! crossings). A ray meets a voxel's surface where the trilinear interpolant along it, a cubic
//! in `t`, first crosses zero inside the voxel: the cubic's coefficients and its root are
//! found as in Mitsuba 3 (Hansson-Söderlund, Evans and Akenine-Möller 2022; Marmitt et al.
//! 2004: the derivative's roots bracket the first crossing, then regula falsi). The geometric
//! normal is the interpolant's gradient; the `smooth` shading normal interpolates the
//! gradients of the eight voxels around the nearest grid point (Hansson-Söderlund et al.
//! 2022), as Mitsuba 3's default. There are no texture coordinates (Mitsuba's neither: `uv`
//! stays 0).

use glam::{Affine3A, Mat3A, Vec3A};
use raylab_integrators::Hit;

/// A placed SDF grid.
#[derive(Clone, Debug, PartialEq)]
pub struct SdfGrid {
    /// Values in `x`, `y`, `z`, each at least 2.
    resolution: [usize; 3],
    /// `values[(z * ny + y) * nx + x]`.
    values: std::sync::Arc<[f32]>,
    to_world: Affine3A,
    to_object: Affine3A,
    /// The inverse transpose of `to_world`'s linear part: object normals to world normals.
    normal_to_world: Mat3A,
    /// Mitsuba's `smooth` shading normals (else the geometric normal).
    smooth: bool,
}

impl SdfGrid {
    /// A grid of `resolution` values placed by `to_world`; `None` when it has fewer than 2
    /// values along an axis, not as many values as the resolution says, or a transform that
    /// cannot be inverted.
    pub fn new(
        resolution: [usize; 3],
        values: std::sync::Arc<[f32]>,
        to_world: Affine3A,
        smooth: bool,
    ) -> Option<SdfGrid> {
        let n = resolution.iter().product::<usize>();
        let to_object = to_world.inverse();
        let normal_to_world = to_world.matrix3.inverse().transpose();
        let invertible = to_world.matrix3.determinant() != 0.0
            && to_object.is_finite()
            && normal_to_world.is_finite();
        (resolution.iter().all(|&r| r >= 2) && values.len() == n && invertible).then_some(SdfGrid {
            resolution,
            values,
            to_world,
            to_object,
            normal_to_world,
            smooth,
        })
    }

    /// The corners of the placed unit cube the grid spans.
    pub fn bounds(&self) -> [Vec3A; 8] {
        super::box_corners((Vec3A::ZERO, Vec3A::ONE)).map(|c| self.to_world.transform_point3a(c))
    }

    /// Voxels along each axis.
    fn cells(&self) -> [usize; 3] {
        self.resolution.map(|r| r - 1)
    }

    /// The size of a voxel in the grid's space.
    fn voxel_size(&self) -> Vec3A {
        let c = self.cells();
        Vec3A::new(1.0 / c[0] as f32, 1.0 / c[1] as f32, 1.0 / c[2] as f32)
    }

    fn value(&self, x: usize, y: usize, z: usize) -> f32 {
        let [nx, ny, _] = self.resolution;
        self.values[(z * ny + y) * nx + x]
    }

    /// Voxel `index`'s position (Mitsuba's order: `x` fastest).
    fn voxel(&self, index: u32) -> [usize; 3] {
        let [cx, cy, _] = self.cells();
        let i = index as usize;
        [i % cx, (i / cx) % cy, i / (cx * cy)]
    }

    /// The eight corner values of voxel `v`, corner `i` at `(i & 1, i >> 1 & 1, i >> 2 & 1)`.
    fn corners(&self, v: [usize; 3]) -> [f32; 8] {
        std::array::from_fn(|i| {
            self.value(v[0] + (i & 1), v[1] + ((i >> 1) & 1), v[2] + ((i >> 2) & 1))
        })
    }

    /// The voxels the surface passes through, each with its world bounds (min, max): the
    /// primitives.
    pub fn occupied_voxels(&self) -> Vec<(u32, (Vec3A, Vec3A))> {
        let [cx, cy, cz] = self.cells();
        let size = self.voxel_size();
        let mut out = Vec::new();
        for z in 0..cz {
            for y in 0..cy {
                for x in 0..cx {
                    let f = self.corners([x, y, z]);
                    if f.iter().all(|&v| v > 0.0) || f.iter().all(|&v| v < 0.0) {
                        continue;
                    }
                    let (lo, hi) = tight_box(&f);
                    let origin = Vec3A::new(x as f32, y as f32, z as f32);
                    let (lo, hi) = ((origin + lo) * size, (origin + hi) * size);
                    let mut b = (Vec3A::splat(f32::INFINITY), Vec3A::splat(f32::NEG_INFINITY));
                    for c in super::box_corners((lo, hi)) {
                        let w = self.to_world.transform_point3a(c);
                        b = (b.0.min(w), b.1.max(w));
                    }
                    out.push((((z * cy + y) * cx + x) as u32, b));
                }
            }
        }
        out
    }

    /// The distance along the world ray `origin + t dir` (`0 <= t <= tmax`) to the surface in
    /// voxel `index`, if the ray meets it there.
    pub fn intersect(&self, index: u32, origin: Vec3A, dir: Vec3A, tmax: f32) -> Option<f32> {
        let v = self.voxel(index);
        let (o, d) = (
            self.to_object.transform_point3a(origin),
            self.to_object.transform_vector3a(dir),
        );
        let size = self.voxel_size();
        let pos = Vec3A::new(v[0] as f32, v[1] as f32, v[2] as f32);
        let (lo, hi) = (pos * size, (pos + Vec3A::ONE) * size);
        // The ray's span in the voxel's box (a ray along a face's plane is inside it when
        // its origin is).
        let (mut t_beg, mut t_end) = (0.0f32, f32::INFINITY);
        for a in 0..3 {
            if d[a] == 0.0 {
                if o[a] < lo[a] || o[a] > hi[a] {
                    return None;
                }
                continue;
            }
            let (t0, t1) = ((lo[a] - o[a]) / d[a], (hi[a] - o[a]) / d[a]);
            t_beg = t_beg.max(t0.min(t1));
            t_end = t_end.min(t0.max(t1));
        }
        if t_beg.is_nan() || t_end.is_nan() || t_beg >= t_end {
            return None;
        }
        // In the voxel's space, [0, 1]^3.
        let cells = self.cells();
        let scale = Vec3A::new(cells[0] as f32, cells[1] as f32, cells[2] as f32);
        let (o, d) = (o * scale - pos, d * scale);
        let p = o + d * t_beg;
        let s = self.corners(v);
        // The trilinear interpolant along the ray: -(c3 t^3 + c2 t^2 + c1 t + c0).
        let a = s[5] - s[4];
        let (k0, k1, k2) = (s[0], s[1] - s[0], s[2] - s[0]);
        let k3 = s[3] - s[2] - k1;
        let k4 = k0 - s[4];
        let k5 = k1 - a;
        let k6 = k2 - (s[6] - s[4]);
        let k7 = k3 - (s[7] - s[6] - a);
        let (m0, m1, m2) = (p.x * p.y, d.x * d.y, p.x * d.y + p.y * d.x);
        let (m3, m4, m5) = (k5 * p.z - k1, k6 * p.z - k2, k7 * p.z - k3);
        let c0 = (k4 * p.z - k0) + (p.x * m3 + (p.y * m4 + m0 * m5));
        let c1 = (d.x * m3 + d.y * m4) + m2 * m5 + d.z * (k4 + (k5 * p.x + (k6 * p.y + k7 * m0)));
        let c2 = m1 * m5 + d.z * (k5 * d.x + (k6 * d.y + k7 * m2));
        let c3 = k7 * m1 * d.z;
        let t = solve_cubic(0.0, t_end - t_beg, [c3, c2, c1, c0])?;
        let t = t_beg + t;
        (t >= 0.0 && t <= tmax).then_some(t)
    }

    /// The interpolant at grid-space point `p` (the unit cube), clamped to the grid.
    fn eval(&self, p: Vec3A) -> f32 {
        let cells = self.cells();
        let q = [
            p.x * cells[0] as f32,
            p.y * cells[1] as f32,
            p.z * cells[2] as f32,
        ];
        let mut i = [0usize; 3];
        let mut f = [0f32; 3];
        for a in 0..3 {
            let x = q[a].clamp(0.0, cells[a] as f32);
            let base = (x.floor() as usize).min(cells[a] - 1);
            i[a] = base;
            f[a] = x - base as f32;
        }
        let c = self.corners(i);
        let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
        let x00 = lerp(c[0], c[1], f[0]);
        let x10 = lerp(c[2], c[3], f[0]);
        let x01 = lerp(c[4], c[5], f[0]);
        let x11 = lerp(c[6], c[7], f[0]);
        lerp(lerp(x00, x10, f[1]), lerp(x01, x11, f[1]), f[2])
    }

    /// The gradient at `p` of the interpolant across voxel `v`'s faces (Mitsuba's
    /// `voxel_grad`): differences between its planes through `p`, over the voxel's size.
    fn voxel_gradient(&self, p: Vec3A, v: [i64; 3]) -> Vec3A {
        let size = self.voxel_size();
        let p0 = Vec3A::new(v[0] as f32, v[1] as f32, v[2] as f32) * size;
        let at = |x: f32, y: f32, z: f32| self.eval(Vec3A::new(x, y, z));
        Vec3A::new(
            (at(p0.x + size.x, p.y, p.z) - at(p0.x, p.y, p.z)) / size.x,
            (at(p.x, p0.y + size.y, p.z) - at(p.x, p0.y, p.z)) / size.y,
            (at(p.x, p.y, p0.z + size.z) - at(p.x, p.y, p0.z)) / size.z,
        )
    }

    /// The smooth normal at grid-space `p`: the gradients of the eight voxels around the
    /// grid point nearest `p`, normalised and interpolated trilinearly; voxels before the
    /// grid's start are left out (Mitsuba's `smooth_sh`).
    fn smooth_normal(&self, p: Vec3A) -> Vec3A {
        let cells = self.cells();
        let scaled = p * Vec3A::new(cells[0] as f32, cells[1] as f32, cells[2] as f32);
        let base = [
            scaled.x.round() as i64 - 1,
            scaled.y.round() as i64 - 1,
            scaled.z.round() as i64 - 1,
        ];
        let voxel = |i: usize| {
            [
                base[0] + (i & 1) as i64,
                base[1] + ((i >> 1) & 1) as i64,
                base[2] + ((i >> 2) & 1) as i64,
            ]
        };
        let valid: [bool; 8] = std::array::from_fn(|i| voxel(i).iter().all(|&c| c >= 0));
        let n: [Vec3A; 8] = std::array::from_fn(|i| {
            if valid[i] {
                self.voxel_gradient(p, voxel(i)).normalize_or_zero()
            } else {
                Vec3A::ZERO
            }
        });
        let last = voxel(7);
        let mut w = [
            scaled.x - last[0] as f32 + 0.5,
            scaled.y - last[1] as f32 + 0.5,
            scaled.z - last[2] as f32 + 0.5,
        ];
        // An axis whose lower (upper) four voxels are all left out weighs only the others.
        for (axis, bit) in [(0, 1), (1, 2), (2, 4)] {
            let lower_out = (0..8).filter(|i| i & bit == 0).all(|i| !valid[i]);
            let upper_out = (0..8).filter(|i| i & bit != 0).all(|i| !valid[i]);
            if lower_out {
                w[axis] = 1.0;
            }
            if upper_out {
                w[axis] = 0.0;
            }
        }
        let [u, v, t] = w;
        let lerp = |a: Vec3A, b: Vec3A, s: f32| a * (1.0 - s) + b * s;
        lerp(
            lerp(lerp(n[0], n[1], u), lerp(n[2], n[3], u), v),
            lerp(lerp(n[4], n[5], u), lerp(n[6], n[7], u), v),
            t,
        )
    }

    /// The surface record of the world ray `origin + t dir` meeting the surface at `t`.
    pub fn hit(&self, origin: Vec3A, dir: Vec3A, t: f32, material: u32, light: Option<u32>) -> Hit {
        let p = origin + dir * t;
        let local = self.to_object.transform_point3a(p);
        let cells = self.cells();
        let voxel = std::array::from_fn(|a| {
            let c = (local[a] * cells[a] as f32).floor() as i64;
            c.clamp(0, cells[a] as i64 - 1)
        });
        let world = |n: Vec3A| (self.normal_to_world * n).normalize_or_zero();
        let ng = world(self.voxel_gradient(local, voxel));
        let ng = if ng == Vec3A::ZERO { Vec3A::Z } else { ng };
        let ns = if self.smooth {
            let s = world(self.smooth_normal(local));
            if s == Vec3A::ZERO {
                ng
            } else if s.dot(ng) < 0.0 {
                -s
            } else {
                s
            }
        } else {
            ng
        };
        Hit {
            ns,
            ..Hit::new(t, p, ng, material, light)
        }
    }
}

/// The tight box, in the voxel's unit cube, around the surface through a voxel of corner
/// values `f`: the corners at zero and the crossings on its twelve edges.
fn tight_box(f: &[f32; 8]) -> (Vec3A, Vec3A) {
    let corner =
        |i: usize| Vec3A::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32);
    let (mut lo, mut hi) = (Vec3A::ONE, Vec3A::ZERO);
    for (i, v) in f.iter().enumerate() {
        if *v == 0.0 {
            lo = lo.min(corner(i));
            hi = hi.max(corner(i));
        }
    }
    for a in 0..8 {
        for bit in [1, 2, 4] {
            if a & bit != 0 {
                continue;
            }
            let b = a | bit;
            if f[a] * f[b] <= 0.0 && f[a] != f[b] {
                let p = corner(a) + (corner(b) - corner(a)) * (f[a] / (f[a] - f[b]));
                lo = lo.min(p);
                hi = hi.max(p);
            }
        }
    }
    (lo.min(hi), hi.max(lo))
}

/// The first `t` in `[t_beg, t_end]` where `-(c3 t^3 + c2 t^2 + c1 t + c0)` crosses zero:
/// the roots of its derivative split the span where it turns, the part where the sign first
/// changes is kept, then regula falsi (50 steps at most, to 1e-5). As Mitsuba 3's
/// `sdf_solve_cubic`.
fn solve_cubic(t_beg: f32, t_end: f32, [c3, c2, c1, c0]: [f32; 4]) -> Option<f32> {
    let f = |t: f32| -(((c3 * t + c2) * t + c1) * t + c0);
    let (mut near, mut far) = (t_beg, t_end);
    if let Some((r0, r1)) = solve_quadratic(3.0 * c3, 2.0 * c2, c1) {
        if near <= r0 && r0 <= far {
            if f(t_beg) * f(r0) <= 0.0 {
                far = r0;
            } else {
                near = r0;
            }
        }
        if near <= r1 && r1 <= far {
            if f(near) * f(r1) <= 0.0 {
                far = r1;
            } else {
                near = r1;
            }
        }
    }
    let (mut f_near, mut f_far) = (f(near), f(far));
    if f_near * f_far > 0.0 {
        return None;
    }
    let mut t = near;
    for _ in 0..=50 {
        t = near + (far - near) * (-f_near / (f_far - f_near));
        let ft = f(t);
        if ft * f_near <= 0.0 {
            (far, f_far) = (t, ft);
        } else {
            (near, f_near) = (t, ft);
        }
        if (near - far).abs() < 1e-5 {
            break;
        }
    }
    t.is_finite().then_some(t)
}

/// The real roots `(r0 <= r1)` of `a x^2 + b x + c` (a linear equation's one root twice),
/// as Mitsuba's `math::solve_quadratic`.
fn solve_quadratic(a: f32, b: f32, c: f32) -> Option<(f32, f32)> {
    if a == 0.0 {
        if b == 0.0 {
            return None;
        }
        let x = -c / b;
        return Some((x, x));
    }
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        return None;
    }
    let s = disc.sqrt();
    let q = if b < 0.0 {
        -0.5 * (b - s)
    } else {
        -0.5 * (b + s)
    };
    let (x0, x1) = (q / a, c / q);
    Some((x0.min(x1), x0.max(x1)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sphere of radius 0.3 around the cube's centre, sampled on an `n^3` grid.
    fn sphere(n: usize, to_world: Affine3A) -> SdfGrid {
        let mut values = Vec::new();
        for z in 0..n {
            for y in 0..n {
                for x in 0..n {
                    let p = Vec3A::new(x as f32, y as f32, z as f32) / (n - 1) as f32;
                    values.push((p - Vec3A::splat(0.5)).length() - 0.3);
                }
            }
        }
        SdfGrid::new([n; 3], values.into(), to_world, true).unwrap()
    }

    /// The closest hit over every occupied voxel, by brute force.
    fn closest(g: &SdfGrid, o: Vec3A, d: Vec3A) -> Option<f32> {
        g.occupied_voxels()
            .iter()
            .filter_map(|&(i, _)| g.intersect(i, o, d, f32::INFINITY))
            .min_by(f32::total_cmp)
    }

    #[test]
    fn rays_meet_the_interpolated_surface_where_it_is_zero() {
        let m = Affine3A::from_scale_rotation_translation(
            glam::Vec3::new(2.0, 3.0, 1.5),
            glam::Quat::from_rotation_y(0.4),
            glam::Vec3::new(1.0, -2.0, 0.5),
        );
        let g = sphere(17, m);
        let centre = m.transform_point3a(Vec3A::splat(0.5));
        let mut hits = 0;
        for i in 0..200 {
            let a = i as f32 * 0.731;
            let from = centre + Vec3A::new(a.cos() * 6.0, (a * 1.3).sin() * 4.0, a.sin() * 6.0);
            let to = centre + Vec3A::new((a * 2.1).sin(), (a * 0.7).cos(), (a * 1.7).sin()) * 0.5;
            let d = (to - from).normalize();
            let Some(t) = closest(&g, from, d) else {
                continue;
            };
            hits += 1;
            let p = g.to_object.transform_point3a(from + d * t);
            assert!(
                g.eval(p).abs() < 1e-3,
                "interpolant {} at the hit",
                g.eval(p)
            );
            // Nothing nearer along the ray is inside.
            for k in 1..50 {
                let q = g
                    .to_object
                    .transform_point3a(from + d * (t * k as f32 / 50.0));
                assert!(g.eval(q) > -1e-3, "the ray passed inside before its hit");
            }
            let hit = g.hit(from, d, t, 0, None);
            assert!(
                hit.ng.dot(d) < 0.0,
                "the normal faces the ray that arrives from outside"
            );
            assert!(hit.ns.dot(hit.ng) > 0.0);
            assert!(hit.ng.is_normalized() && hit.ns.is_normalized());
            // Near the placed sphere's normal (the grid's interpolant is not quite a sphere):
            // the object-space gradient mapped by the inverse transpose.
            let local = g.to_object.transform_point3a(hit.p) - Vec3A::splat(0.5);
            let want = (g.normal_to_world * local).normalize();
            assert!(hit.ng.dot(want) > 0.99, "{} vs {want}", hit.ng);
        }
        assert!(hits > 100, "{hits} of 200 rays aimed at the sphere hit it");
    }

    #[test]
    fn smooth_normals_are_continuous_across_voxels() {
        let g = sphere(9, Affine3A::IDENTITY);
        // Walk along the surface's equator; neighbouring hits' shading normals turn smoothly
        // while the geometric normals jump at voxel faces.
        let mut last: Option<Vec3A> = None;
        for i in 0..400 {
            let a = i as f32 / 400.0 * std::f32::consts::FRAC_PI_2;
            let d = Vec3A::new(-a.cos(), -a.sin(), 0.0);
            let o = Vec3A::new(0.5, 0.5, 0.5) - d * 2.0;
            let t = closest(&g, o, d).expect("the sphere is hit from every side");
            let n = g.hit(o, d, t, 0, None).ns;
            if let Some(l) = last {
                assert!(n.dot(l) > 0.999, "{n} after {l}");
            }
            last = Some(n);
        }
    }

    #[test]
    fn the_cubic_solver_finds_the_first_crossing() {
        // (t - 0.2)(t - 0.5)(t - 0.9) = t^3 - 1.6 t^2 + 0.73 t - 0.09, negated.
        let t = solve_cubic(0.0, 1.0, [-1.0, 1.6, -0.73, 0.09]).unwrap();
        assert!((t - 0.2).abs() < 1e-4, "{t}");
        let t = solve_cubic(0.3, 1.0, [-1.0, 1.6, -0.73, 0.09]).unwrap();
        assert!((t - 0.5).abs() < 1e-4, "{t}");
        assert!(solve_cubic(0.55, 0.85, [-1.0, 1.6, -0.73, 0.09]).is_none());
    }
}
