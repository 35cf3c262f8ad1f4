//! One BVH primitive slot of the flat scene: what traversal tests and what a hit record reads,
//! in 48 bytes and one place.
//!
//! A triangle's three corners are stored as `Vec4`s, whose fourth lanes would otherwise be
//! padding (`Vec3A` is 16 bytes): they carry the material, the light and the smooth-normal
//! index as raw bits. A closest hit then reads no other array, where it used to read four
//! (four more cache misses per ray into a large mesh), and a triangle costs 48 bytes instead
//! of 64. A sphere's slot has a NaN first corner and its index in the sphere arrays.

use glam::{BVec4A, Vec3A, Vec4};

/// "No light" / "no smooth normals".
pub const NONE: u32 = u32::MAX;

#[derive(Clone, Copy, Debug)]
pub struct Slot([Vec4; 3]);

impl Slot {
    /// A triangle with its material, light (or [`NONE`]) and smooth-normal index (or [`NONE`]).
    pub fn triangle(v: &[Vec3A; 3], material: u32, light: u32, smooth: u32) -> Slot {
        let corner = |p: Vec3A, bits: u32| p.extend(f32::from_bits(bits));
        Slot([
            corner(v[0], material),
            corner(v[1], light),
            corner(v[2], smooth),
        ])
    }

    /// The slot of sphere `index` in the sphere arrays.
    pub fn sphere(index: u32) -> Slot {
        Slot([
            Vec4::new(f32::NAN, f32::NAN, f32::NAN, f32::from_bits(index)),
            Vec4::NAN,
            Vec4::NAN,
        ])
    }

    /// The sphere's index, or `None` for a triangle.
    #[inline(always)]
    pub fn sphere_index(&self) -> Option<usize> {
        self.0[0].x.is_nan().then(|| self.0[0].w.to_bits() as usize)
    }

    /// A triangle's corners (meaningless for a sphere).
    #[inline(always)]
    pub fn corners(&self) -> [Vec3A; 3] {
        // Dropping the fourth lane is free on SSE2 and NEON (glam keeps it in the register).
        self.0.map(|v| Vec3A::from_vec4(zero_w(v)))
    }

    pub fn material(&self) -> u32 {
        self.0[0].w.to_bits()
    }

    pub fn light(&self) -> Option<u32> {
        Some(self.0[1].w.to_bits()).filter(|&l| l != NONE)
    }

    pub fn smooth(&self) -> Option<usize> {
        Some(self.0[2].w.to_bits())
            .filter(|&s| s != NONE)
            .map(|s| s as usize)
    }

    /// Every lane's bits, for comparing slots (a sphere's slot holds NaNs).
    #[cfg(test)]
    pub fn to_bits(self) -> [u32; 12] {
        let lanes = self.0.map(|v| v.to_array().map(f32::to_bits));
        std::array::from_fn(|i| lanes[i / 4][i % 4])
    }
}

/// `v` with its fourth lane zeroed, not just ignored: glam's `Vec3A` arithmetic computes that
/// lane too, and an index read as a float is a denormal, which costs the processor a slow
/// microcode assist in every operation that meets it (40% of the report room's coherent
/// closest-hit rate before this).
#[inline(always)]
fn zero_w(v: Vec4) -> Vec4 {
    Vec4::select(BVec4A::new(true, true, true, false), v, Vec4::ZERO)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fourth_lanes_keep_every_bit_pattern() {
        let v = [Vec3A::X, Vec3A::Y, Vec3A::Z];
        // Patterns that are NaNs (quiet and signalling) and denormals as f32, each lane its
        // own so that swapped lanes would show.
        let patterns = [0, 1, 7, 0x7f80_0001, 0x7fc0_0000, 0xffff_fffe, NONE];
        for (i, &material) in patterns.iter().enumerate() {
            let light = patterns[(i + 1) % patterns.len()];
            let smooth = patterns[(i + 2) % patterns.len()];
            let s = Slot::triangle(&v, material, light, smooth);
            assert_eq!(s.material(), material);
            assert_eq!(s.light(), (light != NONE).then_some(light));
            assert_eq!(s.smooth(), (smooth != NONE).then_some(smooth as usize));
            assert_eq!(s.corners(), v);
            assert_eq!(s.sphere_index(), None);
            // What the corners are made from carries none of those bits.
            for lane in s.0 {
                let zeroed = zero_w(lane);
                assert_eq!(zeroed.w.to_bits(), 0);
                assert_eq!(zeroed.truncate(), lane.truncate());
            }
        }
        assert_eq!(Slot::sphere(41).sphere_index(), Some(41));
        assert_eq!(std::mem::size_of::<Slot>(), 48);
    }
}
