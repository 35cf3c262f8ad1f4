//! A run of up to four primitives of a BVH leaf, stored lane by lane, so that one ray is
//! tested against four triangles at once with SSE.
//!
//! A BVH leaf is one or two packets ([`super::bvh::Bvh::number_leaves`]). A [`Packet`] holds
//! what the intersection test reads, in 192 bytes (three cache lines): each lane's first
//! corner `v0`, its edges `e1 = v0 - v1` and `e2 = v2 - v0` and their cross product
//! `n = e1 x e2`, so the test computes neither. What only a hit needs (material, light, vertex
//! normals) is in a [`LaneData`] of 48 bytes stored right after it ([`Stored`], four cache
//! lines): the test never reads that line, a hit does. (An array of its own beside the
//! packets cost the 1.3 M-triangle mesh's incoherent closest hits 10%: one more cache miss.)
//!
//! The triangle test is [`super::primitives::intersect_triangle`]'s Möller–Trumbore with the
//! same operations in the same order, lane by lane (the stored edges and normal are the values
//! it computes), so a packet finds the same distances, to the bit, as testing its triangles one
//! at a time. An analytic shape's lane (a sphere, a disk, a cylinder, a piece of a curve) has
//! NaN corners, which no triangle test passes, and is tested on its own; an unused lane is all zeros (a degenerate
//! triangle, which no ray hits) and has the material [`NONE`].

use super::curves::{CurvePiece, CurveSegment};
use super::primitives::{intersect_sphere, Quadric};
use glam::{BVec4A, Vec3A, Vec4};
use obvhs::ray::Ray;

/// Primitives per packet.
pub const WIDTH: usize = 4;

/// Packets that hold a BVH leaf of `count` primitives.
#[inline(always)]
pub fn packets_for(count: u32) -> u32 {
    count.div_ceil(WIDTH as u32)
}

/// A leaf's primitives `first..first + count` in the BVH's order, split into the runs that
/// its packets hold, as (first, count).
pub fn runs(first: u32, count: u32) -> impl Iterator<Item = (u32, u32)> {
    (0..packets_for(count)).map(move |k| {
        let start = first + k * WIDTH as u32;
        (start, (first + count - start).min(WIDTH as u32))
    })
}

/// "No light" / "no vertex data".
pub const NONE: u32 = u32::MAX;

/// Set in an analytic lane's index when it is a disk or cylinder (an index into the
/// quadrics), clear for a sphere.
const QUADRIC: u32 = 1 << 31;

/// Set (without [`QUADRIC`]) in an analytic lane's index when it is a curve's piece (an index
/// into the curve pieces).
const CURVE: u32 = 1 << 30;

/// Three coordinates, a lane per primitive.
type Lanes3 = [Vec4; 3];

/// One primitive of a packet, as given to [`Packet::new`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Lane {
    Triangle {
        corners: [Vec3A; 3],
        material: u32,
        light: u32,
        vertex_data: u32,
    },
    Sphere {
        index: u32,
        material: u32,
        light: u32,
    },
    /// A disk or cylinder, by its index among the quadrics.
    Quadric {
        index: u32,
        material: u32,
        light: u32,
    },
    /// A curve's piece, by its index among the curve pieces.
    Curve {
        index: u32,
        material: u32,
        light: u32,
    },
}

/// An analytic lane's shape, by its index in the [`Analytic`] arrays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AnalyticIndex {
    Sphere(usize),
    Quadric(usize),
    Curve(usize),
}

/// What the intersection test reads of up to four primitives.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct Packet {
    v0: Lanes3,
    e1: Lanes3,
    e2: Lanes3,
    n: Lanes3,
}

/// What a hit reads of a packet's primitives: each lane's material, light and an index: the
/// triangle's vertex data, or the analytic shape's place in the [`Analytic`] arrays.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LaneData {
    material: [u32; WIDTH],
    light: [u32; WIDTH],
    aux: [u32; WIDTH],
}

/// A packet with its lane data after it: 240 bytes, padded to 256 (four cache lines).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct Stored {
    pub packet: Packet,
    pub data: LaneData,
}

/// A ray's origin and direction splatted across lanes, made once per ray.
pub struct PacketRay {
    origin: Lanes3,
    dir: Lanes3,
}

impl PacketRay {
    #[inline(always)]
    pub fn new(ray: &Ray) -> PacketRay {
        let splat = |v: Vec3A| [Vec4::splat(v.x), Vec4::splat(v.y), Vec4::splat(v.z)];
        PacketRay {
            origin: splat(ray.origin),
            dir: splat(ray.direction),
        }
    }
}

#[inline(always)]
fn sub(a: &Lanes3, b: &Lanes3) -> Lanes3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// As glam's `Vec3A::cross`: the same products, subtracted the same way.
#[inline(always)]
fn cross(a: &Lanes3, b: &Lanes3) -> Lanes3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// As glam's `Vec3A::dot`: (x + y) + z.
#[inline(always)]
fn dot(a: &Lanes3, b: &Lanes3) -> Vec4 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Lane `lane` of three lane vectors, as a point.
#[inline(always)]
fn lane3(v: &Lanes3, lane: usize) -> Vec3A {
    Vec3A::new(v[0][lane], v[1][lane], v[2][lane])
}

impl Packet {
    /// The packet of one to [`WIDTH`] primitives, with their lane data.
    pub fn new(lanes: &[Lane]) -> (Packet, LaneData) {
        assert!(
            !lanes.is_empty() && lanes.len() <= WIDTH,
            "{} lanes",
            lanes.len()
        );
        let mut corners = [[Vec3A::ZERO; 3]; WIDTH];
        let mut data = LaneData {
            material: [NONE; WIDTH],
            light: [NONE; WIDTH],
            aux: [NONE; WIDTH],
        };
        for (i, lane) in lanes.iter().enumerate() {
            let (c, material, light, aux) = match *lane {
                Lane::Triangle {
                    corners,
                    material,
                    light,
                    vertex_data,
                } => (corners, material, light, vertex_data),
                Lane::Sphere {
                    index,
                    material,
                    light,
                } => ([Vec3A::NAN; 3], material, light, index),
                Lane::Quadric {
                    index,
                    material,
                    light,
                } => {
                    assert!(index < QUADRIC, "{index} quadrics");
                    ([Vec3A::NAN; 3], material, light, index | QUADRIC)
                }
                Lane::Curve {
                    index,
                    material,
                    light,
                } => {
                    assert!(index < CURVE, "{index} curve pieces");
                    ([Vec3A::NAN; 3], material, light, index | CURVE)
                }
            };
            corners[i] = c;
            (data.material[i], data.light[i], data.aux[i]) = (material, light, aux);
        }
        let lanes3 = |f: &dyn Fn(&[Vec3A; 3]) -> Vec3A| -> Lanes3 {
            std::array::from_fn(|axis| {
                Vec4::from_array(std::array::from_fn(|i| f(&corners[i])[axis]))
            })
        };
        let v0 = lanes3(&|c| c[0]);
        let e1 = sub(&v0, &lanes3(&|c| c[1]));
        let e2 = sub(&lanes3(&|c| c[2]), &v0);
        let n = cross(&e1, &e2);
        (Packet { v0, e1, e2, n }, data)
    }

    /// Lanes holding analytic shapes, a bit each.
    #[inline(always)]
    fn analytic_lanes(&self) -> u32 {
        let x = self.v0[0];
        x.cmpne(x).bitmask()
    }

    /// Each lane's distance along `ray` in `[tmin, tmax]`, or infinity; analytic lanes are
    /// tested on their own against `shapes`, found through `data` (read only for them). With
    /// `ANY` a curve's lane has the distance of the first point found, not the nearest.
    #[inline(always)]
    fn distances<const ANY: bool>(
        &self,
        r: &PacketRay,
        ray: &Ray,
        tmax: f32,
        shapes: &Analytic,
        data: &LaneData,
    ) -> Vec4 {
        let c = sub(&self.v0, &r.origin);
        let q = cross(&r.dir, &c);
        let inv_det = Vec4::ONE / dot(&self.n, &r.dir);
        let u = dot(&q, &self.e2) * inv_det;
        let v = dot(&q, &self.e1) * inv_det;
        let w = Vec4::ONE - u - v;
        let t = dot(&self.n, &c) * inv_det;
        // Each barycentric compared on its own (a NaN fails), -0.0 inside: see
        // `primitives::intersect_triangle`.
        let zero = Vec4::ZERO;
        let inside: BVec4A = u.cmpge(zero) & v.cmpge(zero) & w.cmpge(zero) & inv_det.cmpne(zero);
        let within = t.cmpge(Vec4::splat(ray.tmin)) & t.cmple(Vec4::splat(tmax));
        let mut t = Vec4::select(inside & within, t, Vec4::INFINITY);
        let mut s = self.analytic_lanes();
        while s != 0 {
            let lane = s.trailing_zeros() as usize;
            s &= s - 1;
            let mut r = *ray;
            r.tmax = tmax;
            t[lane] = match data.analytic(lane) {
                AnalyticIndex::Sphere(i) => {
                    intersect_sphere(shapes.center[i], shapes.radius[i], &r)
                }
                AnalyticIndex::Quadric(i) => shapes.quadrics[i].intersect(&r),
                AnalyticIndex::Curve(i) => shapes.curves[i].intersect(shapes.segments, &r, ANY),
            };
        }
        t
    }

    /// The nearest lane whose primitive `ray` meets before `tmax` (strictly), with its
    /// distance; the lowest such lane on a tie, as testing the lanes in order would.
    #[inline(always)]
    pub fn closest(
        &self,
        r: &PacketRay,
        ray: &Ray,
        tmax: f32,
        shapes: &Analytic,
        data: &LaneData,
    ) -> Option<(usize, f32)> {
        let t = self.distances::<false>(r, ray, tmax, shapes, data);
        let hit = t.cmplt(Vec4::splat(tmax)).bitmask();
        if hit == 0 {
            return None;
        }
        let best = t.min_element();
        let lane = (t.cmpeq(Vec4::splat(best)).bitmask() & hit).trailing_zeros() as usize;
        Some((lane, best))
    }

    /// Whether `ray` meets any of the packet's primitives within `[ray.tmin, ray.tmax]`.
    #[inline(always)]
    pub fn any(&self, r: &PacketRay, ray: &Ray, shapes: &Analytic, data: &LaneData) -> bool {
        self.distances::<true>(r, ray, ray.tmax, shapes, data)
            .cmplt(Vec4::INFINITY)
            .any()
    }

    /// Lane `lane`'s triangle as (`v0`, `v1 - v0`, `v2 - v0`), exactly as the triangle's
    /// corners give them (meaningless for a sphere).
    #[inline(always)]
    pub fn edges(&self, lane: usize) -> (Vec3A, Vec3A, Vec3A) {
        (
            lane3(&self.v0, lane),
            -lane3(&self.e1, lane),
            lane3(&self.e2, lane),
        )
    }

    /// Lane `lane`'s unit normal, `(v1 - v0) x (v2 - v0)` normalised (zero if degenerate).
    #[inline(always)]
    pub fn normal(&self, lane: usize) -> Vec3A {
        // n = e1 x e2 = (v0 - v1) x e2 = -((v1 - v0) x e2), exactly.
        (-lane3(&self.n, lane)).normalize_or_zero()
    }

    /// Lane `lane`'s analytic shape, or `None` for a triangle.
    #[inline(always)]
    pub fn analytic_index(&self, lane: usize, data: &LaneData) -> Option<AnalyticIndex> {
        (self.analytic_lanes() >> lane & 1 == 1).then(|| data.analytic(lane))
    }

    /// Every lane's bits, for comparing packets (sphere lanes hold NaNs).
    #[cfg(test)]
    pub fn to_bits(self) -> Vec<u32> {
        [self.v0, self.e1, self.e2, self.n]
            .iter()
            .flatten()
            .flat_map(|v| v.to_array().map(f32::to_bits))
            .collect()
    }
}

impl LaneData {
    /// Whether lane `lane` holds a primitive.
    #[cfg(test)]
    pub fn used(&self, lane: usize) -> bool {
        self.material[lane] != NONE
    }

    pub fn material(&self, lane: usize) -> u32 {
        self.material[lane]
    }

    pub fn light(&self, lane: usize) -> Option<u32> {
        Some(self.light[lane]).filter(|&l| l != NONE)
    }

    /// An analytic lane's shape (meaningless for a triangle's lane).
    #[inline(always)]
    fn analytic(&self, lane: usize) -> AnalyticIndex {
        let i = self.aux[lane];
        if i & QUADRIC != 0 {
            AnalyticIndex::Quadric((i & !QUADRIC) as usize)
        } else if i & CURVE != 0 {
            AnalyticIndex::Curve((i & !CURVE) as usize)
        } else {
            AnalyticIndex::Sphere(i as usize)
        }
    }

    /// A triangle's index into the vertex data, if it has any.
    pub fn vertex_data(&self, lane: usize) -> Option<usize> {
        Some(self.aux[lane])
            .filter(|&s| s != NONE)
            .map(|s| s as usize)
    }
}

/// How a leaf's packets are tested: one after the other, or (with AVX2) a leaf of two
/// packets as one test of eight lanes. Either way the hit found is the one testing the lanes
/// in order would find, to the bit.
pub trait LeafTest {
    /// The nearest hit before `tmax` among `leaf`'s packets, as (packet within the leaf times
    /// [`WIDTH`] plus lane, distance).
    fn closest(
        self,
        leaf: &[Stored],
        r: &PacketRay,
        ray: &Ray,
        tmax: f32,
        shapes: &Analytic,
    ) -> Option<(usize, f32)>;

    /// Whether `ray` meets any primitive of `leaf` within `[ray.tmin, ray.tmax]`.
    fn any(self, leaf: &[Stored], r: &PacketRay, ray: &Ray, shapes: &Analytic) -> bool;
}

/// One packet after the other.
#[inline(always)]
fn closest_in_turn(
    leaf: &[Stored],
    r: &PacketRay,
    ray: &Ray,
    mut tmax: f32,
    shapes: &Analytic,
) -> Option<(usize, f32)> {
    let mut best = None;
    for (k, Stored { packet, data }) in leaf.iter().enumerate() {
        if let Some((lane, t)) = packet.closest(r, ray, tmax, shapes, data) {
            (best, tmax) = (Some((k * WIDTH + lane, t)), t);
        }
    }
    best
}

#[inline(always)]
fn any_in_turn(leaf: &[Stored], r: &PacketRay, ray: &Ray, shapes: &Analytic) -> bool {
    // A plain loop: `Iterator::any` was not inlined into the AVX2 build of the traversal.
    for Stored { packet, data } in leaf {
        if packet.any(r, ray, shapes, data) {
            return true;
        }
    }
    false
}

impl LeafTest for super::bvh::isa::Portable {
    #[inline(always)]
    fn closest(
        self,
        leaf: &[Stored],
        r: &PacketRay,
        ray: &Ray,
        tmax: f32,
        shapes: &Analytic,
    ) -> Option<(usize, f32)> {
        closest_in_turn(leaf, r, ray, tmax, shapes)
    }

    #[inline(always)]
    fn any(self, leaf: &[Stored], r: &PacketRay, ray: &Ray, shapes: &Analytic) -> bool {
        any_in_turn(leaf, r, ray, shapes)
    }
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::*;
    use crate::accel::bvh::isa::Avx2;
    use std::arch::x86_64::*;

    /// Eight lanes: four of packet `a`, then four of `b`.
    type Lanes8 = [__m256; 3];

    /// `a`'s and `b`'s lane vectors side by side.
    #[inline(always)]
    fn join(a: &Lanes3, b: &Lanes3) -> Lanes8 {
        // SAFETY: register operations; the functions of this module run only inside the methods of an `Avx2` token, which exists only where the processor has AVX2.
        std::array::from_fn(|axis| unsafe { _mm256_set_m128(b[axis].into(), a[axis].into()) })
    }

    #[inline(always)]
    fn sub(a: &Lanes8, b: &Lanes8) -> Lanes8 {
        // SAFETY: register arithmetic, as in `join`.
        std::array::from_fn(|i| unsafe { _mm256_sub_ps(a[i], b[i]) })
    }

    #[inline(always)]
    fn mul(a: __m256, b: __m256) -> __m256 {
        // SAFETY: register arithmetic, as in `join`.
        unsafe { _mm256_mul_ps(a, b) }
    }

    #[inline(always)]
    fn msub(a: __m256, b: __m256, c: __m256, d: __m256) -> __m256 {
        // SAFETY: register arithmetic, as in `join`.
        unsafe { _mm256_sub_ps(_mm256_mul_ps(a, b), _mm256_mul_ps(c, d)) }
    }

    /// As `packet::cross`, lane by lane.
    #[inline(always)]
    fn cross(a: &Lanes8, b: &Lanes8) -> Lanes8 {
        [
            msub(a[1], b[2], a[2], b[1]),
            msub(a[2], b[0], a[0], b[2]),
            msub(a[0], b[1], a[1], b[0]),
        ]
    }

    /// As `packet::dot`: (x + y) + z.
    #[inline(always)]
    fn dot(a: &Lanes8, b: &Lanes8) -> __m256 {
        // SAFETY: register arithmetic, as in `join`.
        unsafe {
            _mm256_add_ps(
                _mm256_add_ps(mul(a[0], b[0]), mul(a[1], b[1])),
                mul(a[2], b[2]),
            )
        }
    }

    #[inline(always)]
    fn splat3(v: Vec3A) -> Lanes8 {
        // SAFETY: register operations, as in `join`.
        [v.x, v.y, v.z].map(|x| unsafe { _mm256_set1_ps(x) })
    }

    /// The two packets' eight distances, as `Packet::distances` computes each lane (the two
    /// packets hold no analytic shapes).
    #[inline(always)]
    fn distances(a: &Packet, b: &Packet, ray: &Ray, tmax: f32) -> __m256 {
        let (origin, dir) = (splat3(ray.origin), splat3(ray.direction));
        let v0 = join(&a.v0, &b.v0);
        let c = sub(&v0, &origin);
        let q = cross(&dir, &c);
        let n = join(&a.n, &b.n);
        // SAFETY: register arithmetic, as in `join`.
        unsafe {
            let one = _mm256_set1_ps(1.0);
            let zero = _mm256_setzero_ps();
            let inv_det = _mm256_div_ps(one, dot(&n, &dir));
            let u = mul(dot(&q, &join(&a.e2, &b.e2)), inv_det);
            let v = mul(dot(&q, &join(&a.e1, &b.e1)), inv_det);
            let w = _mm256_sub_ps(_mm256_sub_ps(one, u), v);
            let t = mul(dot(&n, &c), inv_det);
            let inside = _mm256_and_ps(
                _mm256_and_ps(
                    _mm256_cmp_ps::<_CMP_GE_OQ>(u, zero),
                    _mm256_cmp_ps::<_CMP_GE_OQ>(v, zero),
                ),
                _mm256_and_ps(
                    _mm256_cmp_ps::<_CMP_GE_OQ>(w, zero),
                    _mm256_cmp_ps::<_CMP_NEQ_UQ>(inv_det, zero),
                ),
            );
            let within = _mm256_and_ps(
                _mm256_cmp_ps::<_CMP_GE_OQ>(t, _mm256_set1_ps(ray.tmin)),
                _mm256_cmp_ps::<_CMP_LE_OQ>(t, _mm256_set1_ps(tmax)),
            );
            _mm256_blendv_ps(
                _mm256_set1_ps(f32::INFINITY),
                t,
                _mm256_and_ps(inside, within),
            )
        }
    }

    /// Whether neither packet holds an analytic shape (those are tested one by one).
    #[inline(always)]
    fn triangles_only(a: &Packet, b: &Packet) -> bool {
        a.analytic_lanes() | b.analytic_lanes() == 0
    }

    impl LeafTest for Avx2 {
        #[inline(always)]
        fn closest(
            self,
            leaf: &[Stored],
            r: &PacketRay,
            ray: &Ray,
            tmax: f32,
            shapes: &Analytic,
        ) -> Option<(usize, f32)> {
            let [a, b] = leaf else {
                return closest_in_turn(leaf, r, ray, tmax, shapes);
            };
            if !triangles_only(&a.packet, &b.packet) {
                return closest_in_turn(leaf, r, ray, tmax, shapes);
            }
            let t = distances(&a.packet, &b.packet, ray, tmax);
            // SAFETY: register arithmetic; `self` is the token that proves AVX2.
            unsafe {
                let hit = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(t, _mm256_set1_ps(tmax)));
                if hit == 0 {
                    return None;
                }
                // The nearest distance over the eight lanes, then its lowest lane.
                let m = _mm256_min_ps(t, _mm256_permute2f128_ps::<1>(t, t));
                let m = _mm256_min_ps(m, _mm256_permute_ps::<0b01_00_11_10>(m));
                let m = _mm256_min_ps(m, _mm256_permute_ps::<0b10_11_00_01>(m));
                let best = _mm256_cvtss_f32(m);
                let at = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_EQ_OQ>(t, m)) & hit;
                Some((at.trailing_zeros() as usize, best))
            }
        }

        #[inline(always)]
        fn any(self, leaf: &[Stored], r: &PacketRay, ray: &Ray, shapes: &Analytic) -> bool {
            match leaf {
                [a, b] if triangles_only(&a.packet, &b.packet) => {
                    let t = distances(&a.packet, &b.packet, ray, ray.tmax);
                    // SAFETY: register arithmetic; `self` is the token that proves AVX2.
                    unsafe {
                        let inf = _mm256_set1_ps(f32::INFINITY);
                        _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(t, inf)) != 0
                    }
                }
                _ => any_in_turn(leaf, r, ray, shapes),
            }
        }
    }
}

/// The analytic shapes that packets refer to by index: spheres' centres and radii, the
/// disks and cylinders, and the curves' pieces (with the segments they are parts of).
#[derive(Clone, Copy)]
pub struct Analytic<'a> {
    pub center: &'a [Vec3A],
    pub radius: &'a [f32],
    pub quadrics: &'a [Quadric],
    pub curves: &'a [CurvePiece],
    pub segments: &'a [CurveSegment],
}

/// No analytic shapes (instanced meshes have none).
pub const NO_ANALYTIC: Analytic = Analytic {
    center: &[],
    radius: &[],
    quadrics: &[],
    curves: &[],
    segments: &[],
};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::primitives::intersect_triangle;
    use rand::rngs::StdRng;
    use rand::{Rng, SeedableRng};

    fn triangle(corners: [Vec3A; 3], material: u32) -> Lane {
        Lane::Triangle {
            corners,
            material,
            light: NONE,
            vertex_data: NONE,
        }
    }

    /// Each lane's distance is the one-triangle test's, bit for bit, on random rays through
    /// random triangles, rays along the axes and rays exactly through shared corners.
    #[test]
    fn lanes_find_the_single_triangle_distances_exactly() {
        let mut rng = StdRng::seed_from_u64(5);
        let mut p3 = |s: f32| Vec3A::new(rng.random(), rng.random(), rng.random()) * s;
        let (mut rays, mut hits) = (0, 0);
        for round in 0..2000 {
            let base = p3(2.0);
            let tris: Vec<[Vec3A; 3]> = (0..1 + round % WIDTH)
                .map(|_| [base + p3(1.0), base + p3(1.0), base + p3(1.0)])
                .collect();
            let lanes: Vec<Lane> = tris.iter().map(|&t| triangle(t, 0)).collect();
            let (packet, data) = Packet::new(&lanes);
            for k in 0..8 {
                let target = match k {
                    0 => tris[0][1],
                    1 => (tris[0][0] + tris[0][2]) * 0.5,
                    _ => base + p3(1.0),
                };
                let origin = if k == 3 {
                    target - Vec3A::Z * 3.0
                } else {
                    p3(6.0) - 2.0
                };
                let ray = Ray::new(origin, target - origin, 0.0, [f32::INFINITY, 1.5][k % 2]);
                let pr = PacketRay::new(&ray);
                let t = packet.distances::<false>(&pr, &ray, ray.tmax, &NO_ANALYTIC, &data);
                for (i, tri) in tris.iter().enumerate() {
                    assert_eq!(t[i].to_bits(), intersect_triangle(tri, &ray).to_bits());
                    hits += usize::from(t[i].is_finite());
                    rays += 1;
                }
                for i in tris.len()..WIDTH {
                    assert!(t[i].is_infinite(), "unused lane {i} hit at {}", t[i]);
                }
                let expected = tris
                    .iter()
                    .map(|tri| intersect_triangle(tri, &ray))
                    .enumerate()
                    .filter(|(_, t)| *t < ray.tmax)
                    .fold(None, |b: Option<(usize, f32)>, (i, t)| match b {
                        Some((_, bt)) if bt <= t => b,
                        _ => Some((i, t)),
                    });
                let found = packet.closest(&pr, &ray, ray.tmax, &NO_ANALYTIC, &data);
                assert_eq!(found, expected);
                assert_eq!(
                    packet.any(&pr, &ray, &NO_ANALYTIC, &data),
                    expected.is_some()
                );
            }
            // The stored edges and normal are those of the corners, exactly.
            for (i, tri) in tris.iter().enumerate() {
                let (v0, a, b) = packet.edges(i);
                assert_eq!((v0, a, b), (tri[0], tri[1] - tri[0], tri[2] - tri[0]));
                let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalize_or_zero();
                assert_eq!(packet.normal(i), n);
            }
        }
        assert!(hits > rays / 10, "{hits} hits of {rays}");
    }

    #[test]
    fn analytic_lanes_are_tested_as_their_shapes_and_keep_their_data() {
        use crate::accel::primitives::QuadricKind;
        use glam::Affine3A;
        let centers = [Vec3A::new(0.0, 0.0, 5.0), Vec3A::new(0.0, 0.0, 9.0)];
        let radii = [1.0, 2.0];
        // A disk of radius 0.5 at z = 8, and one off the axis.
        let disk = |x: f32| {
            let m = Affine3A::from_scale_rotation_translation(
                glam::Vec3::splat(0.5),
                glam::Quat::IDENTITY,
                glam::Vec3::new(x, 0.0, 8.0),
            );
            Quadric::new(QuadricKind::Disk, m, false)
        };
        let quadrics = [disk(3.0), disk(0.0)];
        let shapes = Analytic {
            center: &centers,
            radius: &radii,
            quadrics: &quadrics,
            curves: &[],
            segments: &[],
        };
        let tri = [
            Vec3A::new(-1.0, -1.0, 7.0),
            Vec3A::new(1.0, -1.0, 7.0),
            Vec3A::new(0.0, 1.0, 7.0),
        ];
        let (packet, data) = Packet::new(&[
            Lane::Sphere {
                index: 1,
                material: 3,
                light: 8,
            },
            Lane::Triangle {
                corners: tri,
                material: 2,
                light: NONE,
                vertex_data: 6,
            },
            Lane::Sphere {
                index: 0,
                material: 1,
                light: NONE,
            },
            Lane::Quadric {
                index: 1,
                material: 4,
                light: 2,
            },
        ]);
        let closest_from = |tmin: f32| {
            let ray = Ray::new(Vec3A::ZERO, Vec3A::Z, tmin, f32::INFINITY);
            packet.closest(&PacketRay::new(&ray), &ray, f32::INFINITY, &shapes, &data)
        };
        assert_eq!(closest_from(0.0), Some((2, 4.0)));
        // Beyond the near sphere the far one and the triangle tie at 7: the lower lane wins.
        assert_eq!(closest_from(6.5), Some((0, 7.0)));
        // Beyond those, the disk.
        assert_eq!(closest_from(7.5), Some((3, 8.0)));
        assert_eq!(
            packet.analytic_index(0, &data),
            Some(AnalyticIndex::Sphere(1))
        );
        assert_eq!(packet.analytic_index(1, &data), None);
        assert_eq!(
            packet.analytic_index(2, &data),
            Some(AnalyticIndex::Sphere(0))
        );
        assert_eq!(
            packet.analytic_index(3, &data),
            Some(AnalyticIndex::Quadric(1))
        );
        assert_eq!((data.material(0), data.light(0)), (3, Some(8)));
        assert_eq!((data.material(3), data.light(3)), (4, Some(2)));
        assert_eq!(
            (data.material(1), data.light(1), data.vertex_data(1)),
            (2, None, Some(6))
        );
        assert!(data.used(2) && data.used(3));
        assert_eq!(packet.edges(1).0, tri[0]);
        let short = Ray::new(Vec3A::ZERO, Vec3A::Z, 0.0, 3.0);
        assert!(!packet.any(&PacketRay::new(&short), &short, &shapes, &data));
        assert_eq!(std::mem::size_of::<Packet>(), 192);
        assert_eq!(std::mem::size_of::<LaneData>(), 48);
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn avx2_leaf(
        avx2: crate::accel::bvh::isa::Avx2,
        leaf: &[Stored],
        r: &PacketRay,
        ray: &Ray,
        shapes: &Analytic,
    ) -> (Option<(usize, f32)>, bool) {
        (
            avx2.closest(leaf, r, ray, ray.tmax, shapes),
            avx2.any(leaf, r, ray, shapes),
        )
    }

    /// The AVX2 test of a two-packet leaf (one eight-lane test) finds what testing the packets
    /// in turn finds: leaves of 5 to 8 triangles (unused lanes), the same triangle in both
    /// packets (a tie: the lower index wins), and a sphere lane (tested in turn).
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx2_two_packet_leaves_match_the_packets_in_turn() {
        let Some(avx2) = crate::accel::bvh::isa::Avx2::detect() else {
            return;
        };
        let centers = [Vec3A::new(1.5, 1.5, 1.5)];
        let radii = [0.4];
        let spheres = Analytic {
            center: &centers,
            radius: &radii,
            quadrics: &[],
            curves: &[],
            segments: &[],
        };
        let mut rng = StdRng::seed_from_u64(9);
        let mut p3 = |s: f32| Vec3A::new(rng.random(), rng.random(), rng.random()) * s;
        let (mut hits, mut ties, mut rays) = (0, 0, 0);
        for round in 0..3000 {
            let n = 5 + round % 4;
            let mut lanes: Vec<Lane> = (0..n)
                .map(|_| {
                    let base = p3(3.0);
                    triangle([base, base + p3(1.5) - 0.5, base + p3(1.5) - 0.5], 0)
                })
                .collect();
            match round % 3 {
                // The first packet's second triangle again in the second packet.
                0 => lanes[WIDTH] = lanes[1],
                1 => {
                    lanes[WIDTH] = Lane::Sphere {
                        index: 0,
                        material: 0,
                        light: NONE,
                    }
                }
                _ => {}
            }
            let leaf: Vec<Stored> = lanes
                .chunks(WIDTH)
                .map(|c| {
                    let (packet, data) = Packet::new(c);
                    Stored { packet, data }
                })
                .collect();
            for k in 0..8 {
                let origin = p3(5.0) - 1.0;
                let target = match (round % 3, k % 2) {
                    (0, 0) => match lanes[1] {
                        Lane::Triangle { corners, .. } => {
                            (corners[0] + corners[1] + corners[2]) / 3.0
                        }
                        Lane::Sphere { .. } | Lane::Quadric { .. } | Lane::Curve { .. } => {
                            unreachable!()
                        }
                    },
                    _ => p3(3.0),
                };
                let tmax = [f32::INFINITY, 4.0][k % 2];
                let ray = crate::accel::bvh::ray(origin, target - origin, 0.0, tmax);
                let pr = PacketRay::new(&ray);
                let expected = closest_in_turn(&leaf, &pr, &ray, ray.tmax, &spheres);
                let expected_any = any_in_turn(&leaf, &pr, &ray, &spheres);
                // SAFETY: the token exists only where the processor has AVX2.
                let (found, found_any) = unsafe { avx2_leaf(avx2, &leaf, &pr, &ray, &spheres) };
                assert_eq!(found, expected, "round {round}, ray {k}");
                assert_eq!(found_any, expected_any, "round {round}, ray {k}");
                hits += usize::from(expected.is_some());
                ties += usize::from(round % 3 == 0 && expected.is_some_and(|(i, _)| i == 1));
                rays += 1;
            }
        }
        assert!(
            hits > rays / 10 && ties > 100,
            "{hits} hits, {ties} ties of {rays}"
        );
    }
}
