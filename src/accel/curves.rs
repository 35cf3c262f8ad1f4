//! Curves: pbrt-v4's `curve` shape, cubic Bézier segments swept to a width, intersected as
//! pbrt-v4 does (`Curve::IntersectRay` and `RecursiveIntersect` in pbrt-v4's `shapes.cpp`,
//! after Nakamaru and Ohno 2002, "Ray tracing for curves primitive").
//!
//! A segment ([`CurveSegment`]) is split into `2^split_depth` pieces ([`CurvePiece`], pbrt's
//! `splitdepth`, 3 by default), each a primitive of the BVH with its own box, so that rays
//! reach few of them. A ray meets a piece where it passes within half the width of the curve:
//! the piece's control points are moved into a frame where the ray runs along `+z` from the
//! origin, and the curve is halved recursively (to a depth set by how far it departs from a
//! straight line, at most 10) while the halves' boxes still meet the ray; at the bottom each
//! half is taken as the line between its ends, the nearest point to the ray found on it and
//! tested against the width there. The surface is thus a ribbon that always faces the ray
//! (`flat`), the same ribbon with normals that turn across it as a cylinder's would
//! (`cylinder`), or, for `ribbon`, a ribbon oriented by normals given at the ends (its width
//! foreshortened by how it faces the ray).
//!
//! A hit's surface record follows pbrt-v4: `u` runs along the segment (0 to 1 across the
//! whole segment, not the piece), `v` across the width (0 to 1, 1/2 on the curve), `dpdu` is
//! the curve's derivative (the frame's tangent: the hair BSDF's fibre direction), `dpdv` runs
//! across (`flat`: perpendicular to the ray and the curve; `cylinder`: that turned about
//! `dpdu` by `(v - 1/2) 180` degrees; `ribbon`: `n x dpdu`), and the normal is
//! `dpdu x dpdv` (so a `flat` curve's faces away from the ray), turned around when flipped.
//! Rays spawned from a hit start a width away from the curve along the normal
//! ([`Hit::spawn_offset`]: pbrt-v4's error bounds of a curve hit), out of the fibre.
//!
//! With pbrt-v4's `HairBxDF` this record puts a fibre's surface reflection on the mirror
//! image of the side a cylinder would (the BSDF's exit azimuth assumes a normal facing the
//! ray, `h` measured the other way round); raylab keeps pbrt-v4's convention, as pbrt-v4's
//! images show it, and a fibre narrower than a pixel, averaged over `h`, is the same either
//! way (see the test `hair_on_a_curve_reflects_where_pbrt_v4_reflects`).
//!
//! Departures from pbrt-v4: the segments are placed in world space when the scene is loaded
//! (pbrt intersects in the shape's own space), so `v` runs the other way under a mirroring
//! transform; and the intersection runs in single precision as pbrt's does, but with rays of
//! unit direction.

use glam::{Vec2, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::ray::Ray;
use raylab_integrators::{Frame, Hit};

/// How a curve's surface faces rays (pbrt-v4's `CurveType`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CurveKind {
    /// A ribbon facing every ray.
    Flat,
    /// A ribbon facing every ray, shaded as a cylinder.
    Cylinder,
    /// A ribbon oriented by normals at the segment's ends.
    Ribbon,
}

/// Deepest recursion of the intersection (pbrt-v4's clamp).
const MAX_DEPTH: i32 = 10;

/// One cubic Bézier segment of a curve in world space, with its width at each end.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurveSegment {
    /// The control points.
    pub cp: [Vec3A; 4],
    /// The width at `u = 0` and at `u = 1`, linear in between.
    pub width: [f32; 2],
    /// A ribbon's unit normals at its two ends (zero for the other kinds).
    pub normals: [Vec3A; 2],
    /// The angle between the two normals, and one over its sine (pbrt's `normalAngle`,
    /// `invSinNormalAngle`).
    normal_angle: f32,
    inv_sin_normal_angle: f32,
    pub kind: CurveKind,
    /// Its normals turned around (`flip_normals`).
    pub flipped: bool,
}

/// A part `[u0, u1]` of segment `segment` (in the accelerator's array of segments): one
/// primitive of the BVH.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurvePiece {
    pub segment: u32,
    pub u0: f32,
    pub u1: f32,
}

/// The segments of one shape: what [`super::Geometry::Curves`] holds. Each is split into
/// `2^split_depth` pieces.
#[derive(Clone, Copy, Debug)]
pub struct Curves<'a> {
    pub segments: &'a [CurveSegment],
    pub split_depth: u32,
}

impl Curves<'_> {
    /// Pieces (BVH primitives) it makes.
    pub fn pieces(&self) -> usize {
        self.segments.len() << self.split_depth
    }

    /// Piece `i`'s segment within the shape and its `u` range.
    pub fn piece(&self, i: usize) -> (usize, f32, f32) {
        let n = 1usize << self.split_depth;
        let (s, k) = (i / n, i % n);
        (s, k as f32 / n as f32, (k + 1) as f32 / n as f32)
    }
}

#[inline(always)]
fn lerp(t: f32, a: f32, b: f32) -> f32 {
    (1.0 - t) * a + t * b
}

#[inline(always)]
fn lerp3(t: f32, a: Vec3A, b: Vec3A) -> Vec3A {
    a * (1.0 - t) + b * t
}

/// The blossom `p(u0, u1, u2)` of the cubic Bézier curve `cp`.
#[inline(always)]
fn blossom(cp: &[Vec3A; 4], u0: f32, u1: f32, u2: f32) -> Vec3A {
    let a = [
        lerp3(u0, cp[0], cp[1]),
        lerp3(u0, cp[1], cp[2]),
        lerp3(u0, cp[2], cp[3]),
    ];
    let b = [lerp3(u1, a[0], a[1]), lerp3(u1, a[1], a[2])];
    lerp3(u2, b[0], b[1])
}

/// The control points of the part `[u0, u1]` of the curve `cp`.
#[inline(always)]
pub fn control_points(cp: &[Vec3A; 4], u0: f32, u1: f32) -> [Vec3A; 4] {
    if u0 == 0.0 && u1 == 1.0 {
        return *cp;
    }
    [
        blossom(cp, u0, u0, u0),
        blossom(cp, u0, u0, u1),
        blossom(cp, u0, u1, u1),
        blossom(cp, u1, u1, u1),
    ]
}

/// The point of the curve `cp` at `u` and its derivative there (the chord `cp3 - cp0` where
/// the derivative vanishes, as pbrt-v4).
#[inline(always)]
pub fn evaluate(cp: &[Vec3A; 4], u: f32) -> (Vec3A, Vec3A) {
    let a = [
        lerp3(u, cp[0], cp[1]),
        lerp3(u, cp[1], cp[2]),
        lerp3(u, cp[2], cp[3]),
    ];
    let b = [lerp3(u, a[0], a[1]), lerp3(u, a[1], a[2])];
    let d = b[1] - b[0];
    let deriv = if d.length_squared() > 0.0 {
        d * 3.0
    } else {
        cp[3] - cp[0]
    };
    (lerp3(u, b[0], b[1]), deriv)
}

/// The curve `cp` split at its middle: seven points, the halves sharing the fourth.
#[inline(always)]
fn subdivide(cp: &[Vec3A; 4]) -> [Vec3A; 7] {
    [
        cp[0],
        (cp[0] + cp[1]) * 0.5,
        (cp[0] + cp[1] * 2.0 + cp[2]) * 0.25,
        (cp[0] + cp[1] * 3.0 + cp[2] * 3.0 + cp[3]) * 0.125,
        (cp[1] + cp[2] * 2.0 + cp[3]) * 0.25,
        (cp[2] + cp[3]) * 0.5,
        cp[3],
    ]
}

/// pbrt-v4's `Log2Int(float)`: `log2(v)` rounded to the nearest integer in log space.
fn log2_int(v: f32) -> i32 {
    if v.is_nan() || v <= 0.0 {
        return 0;
    }
    if v < 1.0 {
        return -log2_int(1.0 / v);
    }
    // The significand of 2^1.5: values from it up round to the next power.
    const MID_SIGNIFICAND: u32 = 0b0000_0000_0011_0101_0000_0100_1111_0011;
    let bits = v.to_bits();
    let exponent = ((bits >> 23) & 0xff) as i32 - 127;
    exponent + i32::from(bits & ((1 << 23) - 1) >= MID_SIGNIFICAND)
}

/// The box of the points `cp`, grown by `r` on every side.
#[inline(always)]
fn grown_box(cp: &[Vec3A], r: f32) -> (Vec3A, Vec3A) {
    let mut min = cp[0];
    let mut max = cp[0];
    for p in &cp[1..] {
        min = min.min(*p);
        max = max.max(*p);
    }
    (min - Vec3A::splat(r), max + Vec3A::splat(r))
}

/// Whether the box `(min, max)` (in the ray's frame) meets the ray's segment from the
/// origin to `(0, 0, zmax)`.
#[inline(always)]
fn meets_ray((min, max): (Vec3A, Vec3A), zmax: f32) -> bool {
    min.x <= 0.0 && max.x >= 0.0 && min.y <= 0.0 && max.y >= 0.0 && max.z >= 0.0 && min.z <= zmax
}

/// Where a ray meets a curve: the distance and the surface coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Meeting {
    t: f32,
    u: f32,
    v: f32,
    /// The width there (a ribbon's foreshortened by how it faces the ray).
    width: f32,
    /// A ribbon's normal there.
    normal: Vec3A,
}

/// A ray's frame: its origin, and axes with `z` along the ray (pbrt-v4's `LookAt` from the
/// origin along the direction, `up` across the curve).
#[derive(Clone, Copy)]
struct RayFrame {
    origin: Vec3A,
    x: Vec3A,
    y: Vec3A,
    z: Vec3A,
}

impl RayFrame {
    #[inline(always)]
    fn point(&self, p: Vec3A) -> Vec3A {
        let d = p - self.origin;
        Vec3A::new(d.dot(self.x), d.dot(self.y), d.dot(self.z))
    }

    #[inline(always)]
    fn vector(&self, v: Vec3A) -> Vec3A {
        Vec3A::new(v.dot(self.x), v.dot(self.y), v.dot(self.z))
    }

    #[inline(always)]
    fn world(&self, v: Vec3A) -> Vec3A {
        self.x * v.x + self.y * v.y + self.z * v.z
    }
}

/// One intersection's search: the segment, the ray and the best meeting so far.
struct Search<'a> {
    seg: &'a CurveSegment,
    /// The ray's direction and length (1 for raylab's rays, up to rounding).
    dir: Vec3A,
    ray_length: f32,
    /// The ray's interval, as depths in its frame.
    zmin: f32,
    zmax: f32,
    /// Stop at the first meeting (occlusion).
    any: bool,
    best: Option<Meeting>,
}

impl Search<'_> {
    #[inline(always)]
    fn width_at(&self, u: f32) -> f32 {
        lerp(u, self.seg.width[0], self.seg.width[1])
    }

    /// pbrt-v4's `RecursiveIntersect` over the piece `cp` (in the ray's frame) of `u` range
    /// `[u0, u1]`: whether the ray meets it (a nearer meeting kept in `best`).
    fn recurse(&mut self, cp: &[Vec3A; 4], u0: f32, u1: f32, depth: i32) -> bool {
        if depth > 0 {
            let split = subdivide(cp);
            let u = [u0, 0.5 * (u0 + u1), u1];
            for half in 0..2 {
                let max_width = self.width_at(u[half]).max(self.width_at(u[half + 1]));
                let part = [
                    split[3 * half],
                    split[3 * half + 1],
                    split[3 * half + 2],
                    split[3 * half + 3],
                ];
                if !meets_ray(grown_box(&part, 0.5 * max_width), self.zmax) {
                    continue;
                }
                if self.recurse(&part, u[half], u[half + 1], depth - 1) && self.any {
                    return true;
                }
            }
            return self.best.is_some();
        }
        // The ray must pass between the perpendiculars to the curve at its two ends.
        let edge = (cp[1].y - cp[0].y) * -cp[0].y + cp[0].x * (cp[0].x - cp[1].x);
        if edge < 0.0 {
            return false;
        }
        let edge = (cp[2].y - cp[3].y) * -cp[3].y + cp[3].x * (cp[3].x - cp[2].x);
        if edge < 0.0 {
            return false;
        }
        // The nearest point to the ray on the line between the ends, at `w` along it.
        let chord = Vec2::new(cp[3].x - cp[0].x, cp[3].y - cp[0].y);
        let denom = chord.length_squared();
        if denom == 0.0 {
            return false;
        }
        let w = (-Vec2::new(cp[0].x, cp[0].y)).dot(chord) / denom;
        let u = lerp(w, u0, u1).clamp(u0, u1);
        let mut width = self.width_at(u);
        let mut normal = Vec3A::ZERO;
        if self.seg.kind == CurveKind::Ribbon {
            normal = self.seg.ribbon_normal(u);
            width *= normal.dot(self.dir).abs() / self.ray_length;
        }
        let (pc, dpcdw) = evaluate(cp, w.clamp(0.0, 1.0));
        let dist2 = pc.x * pc.x + pc.y * pc.y;
        if dist2 > width * width * 0.25 {
            return false;
        }
        if pc.z < self.zmin || pc.z > self.zmax {
            return false;
        }
        if self.any {
            self.best = Some(Meeting {
                t: pc.z / self.ray_length,
                u,
                v: 0.5,
                width,
                normal,
            });
            return true;
        }
        let t = pc.z / self.ray_length;
        if self.best.is_some_and(|b| t > b.t) {
            return false;
        }
        // Which side of the curve the ray passes.
        let dist = dist2.sqrt();
        let edge = dpcdw.x * -pc.y + pc.x * dpcdw.y;
        let v = if edge > 0.0 {
            0.5 + dist / width
        } else {
            0.5 - dist / width
        };
        self.best = Some(Meeting {
            t,
            u,
            v,
            width,
            normal,
        });
        true
    }
}

impl CurveSegment {
    /// A segment of `kind` with control points `cp`, widths `width` at its ends and, for a
    /// ribbon, unit `normals` at its ends.
    pub fn new(
        cp: [Vec3A; 4],
        width: [f32; 2],
        kind: CurveKind,
        normals: [Vec3A; 2],
        flipped: bool,
    ) -> CurveSegment {
        let (normal_angle, inv_sin_normal_angle) = if kind == CurveKind::Ribbon {
            let [a, b] = normals;
            // pbrt-v4's `AngleBetween`, accurate for nearly equal and opposite vectors.
            let angle = if a.dot(b) < 0.0 {
                std::f32::consts::PI - 2.0 * ((a + b).length() * 0.5).clamp(-1.0, 1.0).asin()
            } else {
                2.0 * ((b - a).length() * 0.5).clamp(-1.0, 1.0).asin()
            };
            (angle, 1.0 / angle.sin())
        } else {
            (0.0, 0.0)
        };
        CurveSegment {
            cp,
            width,
            normals: if kind == CurveKind::Ribbon {
                normals
            } else {
                [Vec3A::ZERO; 2]
            },
            normal_angle,
            inv_sin_normal_angle,
            kind,
            flipped,
        }
    }

    /// The same segment with its normals turned around (`flip_normals`).
    pub fn flipped(self) -> CurveSegment {
        CurveSegment {
            flipped: !self.flipped,
            ..self
        }
    }

    /// A ribbon's normal at `u`: the two ends' normals interpolated along the great circle
    /// (pbrt-v4's), or straight where they are opposite.
    #[inline]
    fn ribbon_normal(&self, u: f32) -> Vec3A {
        let [n0, n1] = self.normals;
        if self.normal_angle == 0.0 {
            return n0;
        }
        if !self.inv_sin_normal_angle.is_finite() {
            return lerp3(u, n0, n1).normalize_or_zero();
        }
        let s0 = ((1.0 - u) * self.normal_angle).sin() * self.inv_sin_normal_angle;
        let s1 = (u * self.normal_angle).sin() * self.inv_sin_normal_angle;
        n0 * s0 + n1 * s1
    }

    /// The box of its part `[u0, u1]`: the part's control points grown by half its widest
    /// width (pbrt-v4's `Curve::Bounds`).
    pub fn bounds(&self, u0: f32, u1: f32) -> Aabb {
        let cp = control_points(&self.cp, u0, u1);
        let w = lerp(u0, self.width[0], self.width[1]).max(lerp(u1, self.width[0], self.width[1]));
        let (min, max) = grown_box(&cp, 0.5 * w);
        Aabb::new(min, max)
    }

    /// An approximation of its area: its control polygon's length times its mean width
    /// (pbrt-v4's `Curve::Area`).
    pub fn area(&self) -> f32 {
        let c = &self.cp;
        let length = (c[1] - c[0]).length() + (c[2] - c[1]).length() + (c[3] - c[2]).length();
        length * 0.5 * (self.width[0] + self.width[1])
    }

    /// The nearest meeting of `ray` with the part `[u0, u1]` in `[ray.tmin, ray.tmax]`, or
    /// with `any` the first found.
    fn meet(&self, u0: f32, u1: f32, ray: &Ray, any: bool) -> Option<(Meeting, RayFrame)> {
        let cp_world = control_points(&self.cp, u0, u1);
        let d = ray.direction;
        let mut up = d.cross(cp_world[3] - cp_world[0]);
        if up.length_squared() == 0.0 {
            up = Frame::from_normal(d.normalize()).s;
        }
        let z = d.normalize();
        let x = up.normalize().cross(z).normalize();
        let frame = RayFrame {
            origin: ray.origin,
            x,
            y: z.cross(x),
            z,
        };
        if !(x.is_finite() && z.is_finite()) {
            return None;
        }
        let cp = cp_world.map(|p| frame.point(p));
        let ray_length = d.length();
        let zmax = ray_length * ray.tmax;
        let max_width =
            lerp(u0, self.width[0], self.width[1]).max(lerp(u1, self.width[0], self.width[1]));
        if !meets_ray(grown_box(&cp, 0.5 * max_width), zmax) {
            return None;
        }
        // Deep enough that the halves at the bottom depart from straight lines by at most a
        // twentieth of the width.
        let mut l0: f32 = 0.0;
        for i in 0..2 {
            let second = cp[i] - cp[i + 1] * 2.0 + cp[i + 2];
            l0 = l0.max(second.abs().max_element());
        }
        let mut depth = 0;
        if l0 > 0.0 {
            let eps = self.width[0].max(self.width[1]) * 0.05;
            depth = (log2_int(std::f32::consts::SQRT_2 * 6.0 * l0 / (8.0 * eps)) / 2)
                .clamp(0, MAX_DEPTH);
        }
        let mut search = Search {
            seg: self,
            dir: d,
            ray_length,
            zmin: ray_length * ray.tmin,
            zmax,
            any,
            best: None,
        };
        search.recurse(&cp, u0, u1, depth);
        search.best.map(|m| (m, frame))
    }

    /// Distance in `[ray.tmin, ray.tmax]` to the nearest point where `ray` meets the part
    /// `[u0, u1]` (with `any`, to the first point found: enough for occlusion), or infinity.
    #[inline(never)]
    pub fn intersect(&self, u0: f32, u1: f32, ray: &Ray, any: bool) -> f32 {
        self.meet(u0, u1, ray, any)
            .map_or(f32::INFINITY, |(m, _)| m.t)
    }

    /// The surface record of the nearest point where the ray `origin + t dir` meets the part
    /// `[u0, u1]` with `t < tmax` (see the module docs), or `None` if it does not.
    #[inline(never)]
    pub fn hit(
        &self,
        (u0, u1): (f32, f32),
        origin: Vec3A,
        dir: Vec3A,
        tmax: f32,
        material: u32,
        light: Option<u32>,
    ) -> Option<Hit> {
        let ray = super::bvh::ray(origin, dir, 0.0, tmax);
        let (m, frame) = self.meet(u0, u1, &ray, false)?;
        let (_, dpdu) = evaluate(&self.cp, m.u);
        let dpdv = match self.kind {
            CurveKind::Ribbon => m.normal.cross(dpdu).normalize_or_zero() * m.width,
            CurveKind::Flat | CurveKind::Cylinder => {
                let dpdu_plane = frame.vector(dpdu);
                let mut dpdv_plane =
                    Vec3A::new(-dpdu_plane.y, dpdu_plane.x, 0.0).normalize_or_zero() * m.width;
                if self.kind == CurveKind::Cylinder {
                    // Turned about the curve by -theta, theta from -90 to 90 degrees across.
                    let theta = lerp(m.v, -90.0f32, 90.0).to_radians();
                    let axis = dpdu_plane.normalize_or_zero();
                    let (sin, cos) = (-theta).sin_cos();
                    dpdv_plane = dpdv_plane * cos
                        + axis.cross(dpdv_plane) * sin
                        + axis * (axis.dot(dpdv_plane) * (1.0 - cos));
                }
                frame.world(dpdv_plane)
            }
        };
        let n = dpdu.cross(dpdv).normalize_or_zero();
        // A curve seen end-on has no normal of its own: it faces away from the ray.
        let n = if n == Vec3A::ZERO { frame.z } else { n };
        let n = if self.flipped { -n } else { n };
        Some(Hit {
            dpdu,
            dpdv,
            uv: Vec2::new(m.u, m.v),
            spawn_offset: m.width * n.abs().element_sum(),
            ..Hit::new(m.t, origin + dir * m.t, n, material, light)
        })
    }
}

impl CurvePiece {
    /// Its box.
    pub fn bounds(&self, segments: &[CurveSegment]) -> Aabb {
        segments[self.segment as usize].bounds(self.u0, self.u1)
    }

    /// [`CurveSegment::intersect`] of its part.
    #[inline(always)]
    pub fn intersect(&self, segments: &[CurveSegment], ray: &Ray, any: bool) -> f32 {
        segments[self.segment as usize].intersect(self.u0, self.u1, ray, any)
    }

    /// The surface record of `ray` meeting its part at distance `t` (as the BVH found it):
    /// [`CurveSegment::hit`] again, for the coordinates the distance does not keep. The same
    /// ray finds the same nearest point; should it not, the point at `t`, facing away from the
    /// ray.
    pub fn hit(
        &self,
        segments: &[CurveSegment],
        ray: &raylab_integrators::Ray,
        t: f32,
        material: u32,
        light: Option<u32>,
    ) -> Hit {
        segments[self.segment as usize]
            .hit(
                (self.u0, self.u1),
                ray.origin,
                ray.dir,
                ray.tmax,
                material,
                light,
            )
            .unwrap_or_else(|| Hit::new(t, ray.at(t), ray.dir, material, light))
    }
}

#[cfg(test)]
mod tests;
