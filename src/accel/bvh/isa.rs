//! The node test, the innermost loop of traversal, in two builds: [`Portable`] tests a node's
//! eight boxes as two four-lane halves (SSE2 on any x86-64, NEON on ARM, through glam), and
//! [`Avx2`] as one eight-lane AVX vector. Both compute each lane with the same operations in
//! the same order, so both give the same masks and distances, bit for bit, and images do not
//! depend on the processor.
//!
//! Traversal is generic over [`Isa`] and takes an instruction set as a value. [`Avx2`] is a
//! capability token: the only way to make one is [`Avx2::detect`], which returns one only
//! where the processor has AVX2, so no safe code can run AVX instructions on a processor
//! without them. The accelerator calls it from functions compiled with AVX2 enabled, so that
//! the node test inlines into one AVX instruction stream (`WideBvh::closest`).

use super::{Node, Plane, LANES};
use glam::Vec4;
use obvhs::ray::Ray;

/// Slab test margin: each box's exit distance is scaled by 1 + 2 gamma(3) (Ize, "Robust BVH
/// Ray Traversal", 2013), so that rounding in the distances never loses a box the ray grazes.
pub const EXIT_SCALE: f32 =
    1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// An instruction set to test a node's boxes with.
pub trait Isa: Copy {
    /// A ray prepared for box tests.
    type BoxRay;

    fn prepare(self, ray: &Ray) -> Self::BoxRay;

    /// Which of the node's boxes the ray meets within `[tmin, tmax]` (bit per child), and
    /// each box's entry distance.
    fn hits(self, r: &Self::BoxRay, n: &Node, tmin: f32, tmax: f32) -> (u32, Plane);
}

/// For each axis, which plane set (minima 0 or maxima 1) a ray meets first.
#[inline(always)]
fn near_planes(ray: &Ray) -> [usize; 3] {
    ray.inv_direction.to_array().map(|i| usize::from(i < 0.0))
}

/// Two four-lane halves of glam vectors.
#[derive(Clone, Copy)]
pub struct Portable;

pub struct PortableRay {
    origin: [Vec4; 3],
    inv_dir: [Vec4; 3],
    near: [usize; 3],
}

/// The distances to the near and far planes of four boxes (`half` of the node's) along `axis`.
#[inline(always)]
fn portable_slab(r: &PortableRay, n: &Node, axis: usize, half: usize) -> (Vec4, Vec4) {
    let lanes = half * 4..half * 4 + 4;
    let near = Vec4::from_slice(&n.planes[r.near[axis]][axis][lanes.clone()]);
    let far = Vec4::from_slice(&n.planes[1 - r.near[axis]][axis][lanes]);
    (
        (near - r.origin[axis]) * r.inv_dir[axis],
        (far - r.origin[axis]) * r.inv_dir[axis],
    )
}

impl Isa for Portable {
    type BoxRay = PortableRay;

    #[inline(always)]
    fn prepare(self, ray: &Ray) -> PortableRay {
        // obvhs's rays carry a finite inverse direction (a zero component's is huge), so
        // (plane - origin) * inverse is never 0 * inf = NaN.
        PortableRay {
            origin: ray.origin.to_array().map(Vec4::splat),
            inv_dir: ray.inv_direction.to_array().map(Vec4::splat),
            near: near_planes(ray),
        }
    }

    #[inline(always)]
    fn hits(self, r: &PortableRay, n: &Node, tmin: f32, tmax: f32) -> (u32, Plane) {
        let mut mask = 0;
        let mut entries = [0.0; LANES];
        for half in 0..LANES / 4 {
            let (nx, fx) = portable_slab(r, n, 0, half);
            let (ny, fy) = portable_slab(r, n, 1, half);
            let (nz, fz) = portable_slab(r, n, 2, half);
            let entry = nx.max(ny).max(nz.max(Vec4::splat(tmin)));
            let exit = (fx.min(fy).min(fz) * EXIT_SCALE).min(Vec4::splat(tmax));
            mask |= entry.cmple(exit).bitmask() << (4 * half);
            entries[half * 4..half * 4 + 4].copy_from_slice(&entry.to_array());
        }
        (mask, entries)
    }
}

#[cfg(target_arch = "x86_64")]
pub use avx2::Avx2;

/// No AVX2 off x86-64: the token cannot exist.
#[cfg(not(target_arch = "x86_64"))]
#[derive(Clone, Copy, Debug)]
pub enum Avx2 {}

#[cfg(not(target_arch = "x86_64"))]
impl Avx2 {
    pub fn detect() -> Option<Avx2> {
        None
    }
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::*;
    use std::arch::x86_64::*;

    /// The capability to run AVX2 instructions, and the instruction set that tests a node's
    /// boxes as one eight-lane AVX vector per plane. Only [`Avx2::detect`] makes one.
    #[derive(Clone, Copy, Debug)]
    pub struct Avx2 {
        _private: (),
    }

    impl Avx2 {
        /// The token, where the processor has AVX2.
        pub fn detect() -> Option<Avx2> {
            std::arch::is_x86_feature_detected!("avx2").then_some(Avx2 { _private: () })
        }
    }

    pub struct Avx2Ray {
        origin: [__m256; 3],
        inv_dir: [__m256; 3],
        near: [usize; 3],
    }

    /// A plane's eight floats as one vector.
    #[inline(always)]
    fn load(p: &Plane) -> __m256 {
        // SAFETY: `p` is eight readable floats; the load has no alignment requirement. The
        // instruction needs AVX: only methods of an `Avx2` token, which exists only where the
        // processor has AVX2, reach this function.
        unsafe { _mm256_loadu_ps(p.as_ptr()) }
    }

    /// The distances to the near and far planes of the eight boxes along `axis`.
    #[inline(always)]
    fn slab(r: &Avx2Ray, n: &Node, axis: usize) -> (__m256, __m256) {
        let near = load(&n.planes[r.near[axis]][axis]);
        let far = load(&n.planes[1 - r.near[axis]][axis]);
        // SAFETY: as in `load`.
        unsafe {
            (
                _mm256_mul_ps(_mm256_sub_ps(near, r.origin[axis]), r.inv_dir[axis]),
                _mm256_mul_ps(_mm256_sub_ps(far, r.origin[axis]), r.inv_dir[axis]),
            )
        }
    }

    impl Isa for Avx2 {
        type BoxRay = Avx2Ray;

        #[inline(always)]
        fn prepare(self, ray: &Ray) -> Avx2Ray {
            // SAFETY: splatting needs AVX; `self` is the token that proves the processor has it.
            let splat = |v: f32| unsafe { _mm256_set1_ps(v) };
            Avx2Ray {
                origin: ray.origin.to_array().map(splat),
                inv_dir: ray.inv_direction.to_array().map(splat),
                near: near_planes(ray),
            }
        }

        #[inline(always)]
        fn hits(self, r: &Avx2Ray, n: &Node, tmin: f32, tmax: f32) -> (u32, Plane) {
            // SAFETY: AVX arithmetic on values held in registers; `self` is the token that
            // proves the processor has AVX2.
            unsafe {
                let (nx, fx) = slab(r, n, 0);
                let (ny, fy) = slab(r, n, 1);
                let (nz, fz) = slab(r, n, 2);
                // The same operations, operands and order as `Portable::hits` (glam's `max`
                // and `min` are SSE's `max` and `min`).
                let entry = _mm256_max_ps(
                    _mm256_max_ps(nx, ny),
                    _mm256_max_ps(nz, _mm256_set1_ps(tmin)),
                );
                let exit = _mm256_min_ps(
                    _mm256_mul_ps(
                        _mm256_min_ps(_mm256_min_ps(fx, fy), fz),
                        _mm256_set1_ps(EXIT_SCALE),
                    ),
                    _mm256_set1_ps(tmax),
                );
                let mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(entry, exit)) as u32;
                let mut entries = [0.0f32; LANES];
                _mm256_storeu_ps(entries.as_mut_ptr(), entry);
                (mask, entries)
            }
        }
    }
}
