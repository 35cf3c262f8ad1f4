//! Owen-scrambled Sobol points: the padded sampler (`sobol`, pairs of one table's first two
//! dimensions, each pair scrambled for the pixel) and pbrt-v4's `zsobol` (Ahmed & Wonka
//! 2020: one sequence over the whole image, pixels along a Morton curve, so that neighbouring
//! pixels' errors are blue noise).

use crate::random::mix64;

/// A `u32` of fixed-point fraction as an `f32` in `[0, 1)`: its top 24 bits, exactly.
#[inline]
fn to_unit(bits: u32) -> f32 {
    (bits >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}

/// Point `index` of the first two Sobol dimensions, as 32-bit fractions: the van der Corput
/// sequence, and the one whose direction numbers come from `x + 1` (`v_k = v_{k-1} ^
/// (v_{k-1} >> 1)`). Index bits past the 32nd fall below the fractions' resolution.
#[inline]
fn sobol_2d(index: u64) -> (u32, u32) {
    let x = (index.reverse_bits() >> 32) as u32;
    let (mut y, mut v, mut a) = (0u32, 1u32 << 31, index as u32);
    while a != 0 {
        if a & 1 == 1 {
            y ^= v;
        }
        v ^= v >> 1;
        a >>= 1;
    }
    (x, y)
}

/// Burley's hash-based Owen scrambling (2020) with Vegdahl's improved Laine-Karras hash: a
/// random nested uniform permutation of the binary digits of `x`, picked by `seed`.
#[inline]
fn owen_scramble(x: u32, seed: u32) -> u32 {
    let mut x = x.reverse_bits();
    x ^= x.wrapping_mul(0x3d20_adea);
    x = x.wrapping_add(seed);
    x = x.wrapping_mul((seed >> 16) | 1);
    x ^= x.wrapping_mul(0x0552_6c56);
    x ^= x.wrapping_mul(0x53a2_2864);
    x.reverse_bits()
}

/// One sample's numbers under `sobol`: its coordinates in pairs, each pair the first two
/// dimensions of a Sobol sequence scrambled for the pixel and the pair (Owen scrambling of
/// the points and of their order, as pbrt-v4's padded Sobol sampler pairs its dimensions).
/// Every pair is then a (0, 2)-sequence over the pixel's samples, which the higher dimensions
/// of one Sobol table are not.
pub(super) struct PaddedSobol {
    index: u64,
    /// The pixel's scramble.
    seed: u32,
    /// The scramble of the pair in progress (set at its first coordinate).
    pair_seed: u32,
    dimension: u32,
}

impl PaddedSobol {
    pub(super) fn new(seed: u64, pixel: u64, sample: u64) -> Self {
        PaddedSobol {
            index: sample,
            seed: mix64(seed ^ mix64(pixel.wrapping_add(0x632b_e59b_d9b4_e019))) as u32,
            pair_seed: 0,
            dimension: 0,
        }
    }

    /// The next coordinate. The crate's points number 2^16; each further block of 2^16
    /// samples continues in a scramble of its own (as uniform, no longer stratified against
    /// the blocks before).
    #[inline]
    pub(super) fn next(&mut self) -> f32 {
        let d = self.dimension;
        self.dimension = d.wrapping_add(1);
        if d.is_multiple_of(2) {
            let (pair, block) = (d / 2, self.index >> 16);
            self.pair_seed = if pair == 0 && block == 0 {
                self.seed
            } else {
                self.seed ^ (mix64((u64::from(pair) << 32) | block) as u32)
            };
        }
        sobol_burley::sample((self.index & 0xffff) as u32, d % 2, self.pair_seed)
    }

    /// Starts the next pair, so that a 2-D point's coordinates are one pair's.
    #[inline]
    pub(super) fn align_pair(&mut self) {
        self.dimension += self.dimension & 1;
    }
}

/// One sample's numbers under `zsobol`, as pbrt-v4's `ZSobolSampler`: the image's pixels in
/// Morton order, each owning `2^log2_spp` consecutive indices of one Sobol sequence, whose
/// base-4 digits every draw shuffles by permutations hashed from the digits above them (so
/// that a pixel's samples stay a (0, m, 2)-net while neighbouring pixels' nets interleave).
/// Each draw is the sequence's first one or two dimensions under a scramble of its own.
pub(super) struct ZSobol {
    /// The pixel's Morton code, shifted up past its samples, with the sample's index.
    morton_index: u64,
    log2_spp: u32,
    base4_digits: u32,
    /// The render's seed, and the block of `2^log2_spp` samples this one falls in.
    seed: u64,
    dimension: u32,
}

/// The 24 permutations of four digits.
const PERMUTATIONS: [[u8; 4]; 24] = [
    [0, 1, 2, 3],
    [0, 1, 3, 2],
    [0, 2, 1, 3],
    [0, 2, 3, 1],
    [0, 3, 2, 1],
    [0, 3, 1, 2],
    [1, 0, 2, 3],
    [1, 0, 3, 2],
    [1, 2, 0, 3],
    [1, 2, 3, 0],
    [1, 3, 2, 0],
    [1, 3, 0, 2],
    [2, 1, 0, 3],
    [2, 1, 3, 0],
    [2, 0, 1, 3],
    [2, 0, 3, 1],
    [2, 3, 0, 1],
    [2, 3, 1, 0],
    [3, 1, 2, 0],
    [3, 1, 0, 2],
    [3, 2, 1, 0],
    [3, 2, 0, 1],
    [3, 0, 2, 1],
    [3, 0, 1, 2],
];

/// The bits of `v` (16 used) spread to the even positions.
#[inline]
fn spread_bits(v: u32) -> u64 {
    let mut x = u64::from(v) & 0xffff_ffff;
    x = (x | (x << 16)) & 0x0000_ffff_0000_ffff;
    x = (x | (x << 8)) & 0x00ff_00ff_00ff_00ff;
    x = (x | (x << 4)) & 0x0f0f_0f0f_0f0f_0f0f;
    x = (x | (x << 2)) & 0x3333_3333_3333_3333;
    (x | (x << 1)) & 0x5555_5555_5555_5555
}

impl ZSobol {
    /// Sample `sample` of pixel `(x, y)` of a `width x height` image rendered with `spp`
    /// samples per pixel (rounded up to a power of two; 1024 when open-ended). Samples past
    /// that count continue in blocks of their own, each under its own scramble.
    pub(super) fn new(
        seed: u64,
        (x, y): (u32, u32),
        (width, height): (u32, u32),
        sample: u64,
        spp: Option<u32>,
    ) -> Self {
        let per_pixel = spp.unwrap_or(1024).max(1);
        let log2_spp = per_pixel
            .checked_next_power_of_two()
            .map_or(32, u32::trailing_zeros);
        // The Morton code holds 16 bits of each coordinate (images up to 65536 on a side).
        let resolution_bits = width
            .max(height)
            .max(1)
            .checked_next_power_of_two()
            .map_or(32, u32::trailing_zeros)
            .min(16);
        let log4_spp = log2_spp.div_ceil(2);
        let base4_digits = resolution_bits + log4_spp;
        let block = sample >> log2_spp;
        let within = sample & ((1u64 << log2_spp) - 1);
        let morton = spread_bits(x) | (spread_bits(y) << 1);
        ZSobol {
            morton_index: (morton << log2_spp) | within,
            log2_spp,
            base4_digits,
            seed: if block == 0 {
                seed
            } else {
                mix64(seed ^ block)
            },
            dimension: 0,
        }
    }

    /// The sequence index of this sample for the current draw: the Morton index with each
    /// base-4 digit permuted by a hash of the digits above it and the draw's dimension.
    #[inline]
    fn sample_index(&self) -> u64 {
        let odd = self.log2_spp & 1 == 1;
        let last_digit = u32::from(odd);
        let dim_key = 0x5555_5555u64.wrapping_mul(u64::from(self.dimension));
        let mut index = 0u64;
        let mut i = self.base4_digits;
        while i > last_digit {
            i -= 1;
            let shift = 2 * i - u32::from(odd);
            let digit = (self.morton_index >> shift) & 3;
            let higher = self.morton_index.checked_shr(shift + 2).unwrap_or(0);
            let p = ((mix64(higher ^ dim_key) >> 24) % 24) as usize;
            index |= u64::from(PERMUTATIONS[p][digit as usize]) << shift;
        }
        if odd {
            let digit = self.morton_index & 1;
            index |= digit ^ (mix64((self.morton_index >> 1) ^ dim_key) & 1);
        }
        index
    }

    /// The scramble of the draw at the current dimension.
    #[inline]
    fn scramble(&self) -> u64 {
        mix64(self.seed ^ mix64(u64::from(self.dimension).wrapping_add(0xa076_1d64_78bd_642f)))
    }

    pub(super) fn next_1d(&mut self) -> f32 {
        let index = self.sample_index();
        let hash = self.scramble() as u32;
        self.dimension += 1;
        to_unit(owen_scramble(sobol_2d(index).0, hash))
    }

    pub(super) fn next_2d(&mut self) -> (f32, f32) {
        let index = self.sample_index();
        let hash = self.scramble();
        self.dimension += 2;
        let (x, y) = sobol_2d(index);
        (
            to_unit(owen_scramble(x, hash as u32)),
            to_unit(owen_scramble(y, (hash >> 32) as u32)),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The first 2^m points of the two dimensions are a (0, m, 2)-net, and Owen scrambling
    /// keeps them one.
    #[test]
    fn sobol_2d_is_a_net_before_and_after_scrambling() {
        for m in [3u32, 6, 9] {
            let n = 1usize << m;
            for seed in [None, Some(7u32), Some(0xdead_beef)] {
                for a in 0..=m {
                    let (cols, rows) = (1u64 << a, 1u64 << (m - a));
                    let mut hit = vec![0; n];
                    for i in 0..n as u64 {
                        let (mut x, mut y) = sobol_2d(i);
                        if let Some(s) = seed {
                            x = owen_scramble(x, s);
                            y = owen_scramble(y, s.rotate_left(7));
                        }
                        let cx = (u64::from(x) * cols) >> 32;
                        let cy = (u64::from(y) * rows) >> 32;
                        hit[(cy * cols + cx) as usize] += 1;
                    }
                    assert!(
                        hit.iter().all(|h| *h == 1),
                        "m {m}, seed {seed:?}, split {a}"
                    );
                }
            }
        }
    }

    #[test]
    fn morton_codes_interleave_x_and_y() {
        assert_eq!(spread_bits(0b11), 0b101);
        let code = |x, y| spread_bits(x) | (spread_bits(y) << 1);
        assert_eq!(code(1, 0), 1);
        assert_eq!(code(0, 1), 2);
        assert_eq!(code(3, 3), 15);
        assert_eq!(code(0xffff, 0xffff), 0xffff_ffff);
    }
}
