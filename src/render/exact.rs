//! Exact sums of floating-point values, so that a render's per-pixel sums do not depend on
//! the order in which its passes are added: a render split into shards by pass range
//! (`render --shard`) merges into bit for bit the image of the single run.
//!
//! A value is held in fixed point, in units of 2^-96, as a 192-bit two's-complement integer.
//! Each pass's f64 value is rounded once onto that grid (to nearest, ties away from zero),
//! and from there on additions are integer additions: exact, associative and commutative.
//! The grid is finer than any radiance a renderer shows (2^-96 is 1.3e-29) and the range
//! holds any sum of up to 2^32 passes of values below [`LIMIT`] (2^62, 4.6e18) in magnitude;
//! a pass whose value is beyond it is refused by [`Exact::from_f64`] (the render loop drops
//! it like a non-finite sample). The value is read back as the nearest f64 up to one
//! rounding of the low word, the same way every time.

/// Largest magnitude a single added value may have.
pub const LIMIT: f64 = 4_611_686_018_427_387_904.0; // 2^62

/// Fractional bits of the fixed-point grid.
const FRACTION_BITS: i32 = 96;

/// A fixed-point number in units of 2^-96: three little-endian 64-bit limbs, two's complement.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Exact(pub [u64; 3]);

impl Exact {
    pub const ZERO: Exact = Exact([0; 3]);

    /// `v` on the grid, or `None` when it is not finite or not below [`LIMIT`] in magnitude.
    #[inline]
    pub fn from_f64(v: f64) -> Option<Exact> {
        if v == 0.0 {
            return Some(Exact::ZERO);
        }
        let bits = v.to_bits();
        let exponent = ((bits >> 52) & 0x7ff) as i32;
        let mantissa = (bits & ((1u64 << 52) - 1)) | (1u64 << 52);
        // |v| = mantissa * 2^(exponent - 1075), so on the grid mantissa * 2^shift.
        let shift = exponent - 1075 + FRACTION_BITS;
        let magnitude = if shift < 0 {
            // Below 2^-43: bits below the grid are rounded to nearest, ties away from zero
            // (the mantissa is below 2^53: no overflow); subnormals are far below it.
            let right = (-shift) as u32;
            if right >= 64 || exponent == 0 {
                return Some(Exact::ZERO);
            }
            Exact([(mantissa + (1u64 << (right - 1))) >> right, 0, 0])
        } else if shift <= 128 - 53 {
            // Below 2^32 (nearly every value a render adds): in the low 128 bits.
            let m = (mantissa as u128) << shift;
            Exact([m as u64, (m >> 64) as u64, 0])
        } else {
            if !v.is_finite() || v.abs() >= LIMIT {
                return None;
            }
            // |v| < 2^62 keeps shift <= 61 + 96 - 52 = 105: limbs 1 and 2.
            let m = (mantissa as u128) << (shift - 64);
            Exact([0, m as u64, (m >> 64) as u64])
        };
        Some(if v < 0.0 {
            magnitude.negated()
        } else {
            magnitude
        })
    }

    /// Adds `other` exactly.
    #[inline]
    pub fn add(&mut self, other: &Exact) {
        let (l0, c0) = self.0[0].overflowing_add(other.0[0]);
        let (l1, c1a) = self.0[1].overflowing_add(other.0[1]);
        let (l1, c1b) = l1.overflowing_add(c0 as u64);
        let l2 = self.0[2]
            .wrapping_add(other.0[2])
            .wrapping_add((c1a | c1b) as u64);
        self.0 = [l0, l1, l2];
    }

    /// Whether it is below zero.
    pub fn is_negative(&self) -> bool {
        (self.0[2] as i64) < 0
    }

    #[inline]
    fn negated(&self) -> Exact {
        let mut out = Exact([!self.0[0], !self.0[1], !self.0[2]]);
        out.add(&Exact([1, 0, 0]));
        out
    }

    /// The value as an f64 (the high 128 bits rounded to nearest, then the low limb added and
    /// rounded again: within an ulp, and the same for the same sum).
    pub fn to_f64(&self) -> f64 {
        let (sign, magnitude) = if self.is_negative() {
            (-1.0, self.negated())
        } else {
            (1.0, *self)
        };
        let [l0, l1, l2] = magnitude.0;
        let high = (((l2 as u128) << 64) | l1 as u128) as f64;
        let value = high * 18_446_744_073_709_551_616.0 + l0 as f64; // 2^64
        sign * value * (2.0f64).powi(-FRACTION_BITS)
    }

    /// Little-endian bytes, for files.
    pub fn to_le_bytes(&self) -> [u8; 24] {
        let mut out = [0u8; 24];
        for (chunk, limb) in out.chunks_exact_mut(8).zip(self.0) {
            chunk.copy_from_slice(&limb.to_le_bytes());
        }
        out
    }

    /// The inverse of [`Exact::to_le_bytes`].
    pub fn from_le_bytes(bytes: [u8; 24]) -> Exact {
        let mut limbs = [0u64; 3];
        for (limb, chunk) in limbs.iter_mut().zip(bytes.chunks_exact(8)) {
            let mut word = [0u8; 8];
            word.copy_from_slice(chunk);
            *limb = u64::from_le_bytes(word);
        }
        Exact(limbs)
    }
}

/// Three exact sums: an RGB value.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Exact3(pub [Exact; 3]);

impl Exact3 {
    /// `v` on the grid, or `None` when a component is not finite or too large.
    #[inline]
    pub fn from_dvec3(v: glam::DVec3) -> Option<Exact3> {
        Some(Exact3([
            Exact::from_f64(v.x)?,
            Exact::from_f64(v.y)?,
            Exact::from_f64(v.z)?,
        ]))
    }

    #[inline]
    pub fn add(&mut self, other: &Exact3) {
        for (a, b) in self.0.iter_mut().zip(&other.0) {
            a.add(b);
        }
    }

    pub fn to_dvec3(&self) -> glam::DVec3 {
        glam::DVec3::new(self.0[0].to_f64(), self.0[1].to_f64(), self.0[2].to_f64())
    }

    pub fn is_zero(&self) -> bool {
        *self == Exact3::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    #[test]
    fn values_on_the_grid_read_back_exactly() {
        for v in [
            0.0,
            1.0,
            -1.0,
            0.5,
            3.25,
            -1234.5678,
            3.0 * 2f64.powi(-70),
            1e18,
            -4.0e18,
            f32::MAX as f64 / 1e21,
            2f64.powi(-96),
        ] {
            let e = Exact::from_f64(v).unwrap();
            let back = e.to_f64();
            // Values with no bits below 2^-96 are held exactly.
            assert_eq!(back, v, "{v}");
        }
        // Below the grid: rounded to its nearest point.
        assert_eq!(Exact::from_f64(2f64.powi(-98)).unwrap(), Exact::ZERO);
        assert_eq!(
            Exact::from_f64(0.75 * 2f64.powi(-96)).unwrap().to_f64(),
            2f64.powi(-96)
        );
        assert_eq!(
            Exact::from_f64(f64::MIN_POSITIVE / 2.0).unwrap(),
            Exact::ZERO
        );
    }

    #[test]
    fn refuses_what_it_cannot_hold() {
        for v in [
            f64::NAN,
            f64::INFINITY,
            -f64::INFINITY,
            LIMIT,
            -LIMIT,
            1e300,
        ] {
            assert!(Exact::from_f64(v).is_none(), "{v}");
        }
        assert!(Exact::from_f64(LIMIT * 0.999).is_some());
    }

    #[test]
    fn sums_do_not_depend_on_order_or_grouping() {
        // Values spanning 30 orders of magnitude, both signs: float sums differ by order,
        // exact sums never.
        let mut rng = rand::rngs::StdRng::seed_from_u64(5);
        let values: Vec<f64> = (0..5000)
            .map(|_| {
                let m: f64 = rng.random_range(-1.0..1.0);
                m * 10f64.powi(rng.random_range(-12..18))
            })
            .collect();
        let exact = |vs: &[f64]| {
            let mut s = Exact::ZERO;
            for v in vs {
                s.add(&Exact::from_f64(*v).unwrap());
            }
            s
        };
        let forward = exact(&values);
        let mut reversed = values.clone();
        reversed.reverse();
        assert_eq!(exact(&reversed), forward);
        // In seven uneven parts, each summed on its own and then added: the same bits.
        let mut parts = Exact::ZERO;
        for chunk in values.chunks(731) {
            parts.add(&exact(chunk));
        }
        assert_eq!(parts, forward);
        let float_forward: f64 = values.iter().sum();
        let float_reversed: f64 = reversed.iter().sum();
        assert_ne!(
            float_forward, float_reversed,
            "the test needs values floats add badly"
        );
        // And the exact sum is the true one, within the grid's rounding of each value.
        let mut hi = 0.0f64;
        let mut lo = 0.0f64;
        for v in &values {
            // Two-sum compensated summation as an independent estimate.
            let s = hi + v;
            let bp = s - hi;
            lo += (hi - (s - bp)) + (v - bp);
            hi = s;
        }
        let truth = hi + lo;
        assert!((forward.to_f64() - truth).abs() <= truth.abs() * 1e-15 + 1e-20);
    }

    #[test]
    fn negative_sums_and_bytes_round_trip() {
        let mut s = Exact::from_f64(2.5).unwrap();
        s.add(&Exact::from_f64(-7.25).unwrap());
        assert!(s.is_negative());
        assert_eq!(s.to_f64(), -4.75);
        assert_eq!(Exact::from_le_bytes(s.to_le_bytes()), s);
    }
}
