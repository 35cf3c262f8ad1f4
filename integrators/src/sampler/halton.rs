//! The Halton sequence with random digit permutations: dimension `d` is the radical inverse
//! of the sample's index in the `d`-th prime base, each digit position passed through a
//! permutation of its own, picked by the pixel and the dimension (as pbrt-v4's
//! `PermuteDigits` randomisation, here one sequence per pixel).

use crate::random::{mix64, permute};

/// How many dimensions have a prime base; further ones are independent numbers.
pub(super) const DIMENSIONS: usize = 256;

/// The first [`DIMENSIONS`] primes.
const PRIMES: [u32; DIMENSIONS] = primes();

const fn primes() -> [u32; DIMENSIONS] {
    let mut out = [0u32; DIMENSIONS];
    let (mut count, mut n) = (0, 2u32);
    while count < DIMENSIONS {
        let mut d = 2;
        let mut prime = true;
        while d * d <= n {
            if n % d == 0 {
                prime = false;
                break;
            }
            d += 1;
        }
        if prime {
            out[count] = n;
            count += 1;
        }
        n += 1;
    }
    out
}

/// The radical inverse of `index` in base `PRIMES[dimension]`, its digits permuted by
/// permutations keyed by `key` and their position. Digits are taken until their weight
/// falls below an `f32`'s resolution, the zeros above the index's highest digit included,
/// so that every digit of the result is randomised.
pub(super) fn permuted_radical_inverse(dimension: usize, mut index: u64, key: u64) -> f32 {
    let base = PRIMES[dimension];
    let inv_base = 1.0 / f64::from(base);
    let (mut weight, mut value, mut position) = (inv_base, 0.0f64, 0u64);
    while weight > 1.0 / (1u64 << 25) as f64 {
        let digit = (index % u64::from(base)) as u32;
        index /= u64::from(base);
        let digit_key = mix64(key ^ position.wrapping_mul(0x9e37_79b9_7f4a_7c15)) as u32;
        value += f64::from(permute(digit, base, digit_key)) * weight;
        weight *= inv_base;
        position += 1;
    }
    (value as f32).min(1.0 - f32::EPSILON / 2.0)
}

/// The permutation key of a pixel's dimension `dimension`.
pub(super) fn dimension_key(pixel_key: u64, dimension: usize) -> u64 {
    mix64(pixel_key ^ mix64(dimension as u64 + 0x3c6e_f372_fe94_f82b))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_holds_the_first_primes() {
        assert_eq!(&PRIMES[..8], &[2, 3, 5, 7, 11, 13, 17, 19]);
        assert_eq!(PRIMES[DIMENSIONS - 1], 1619);
    }

    /// Without permutations (every digit kept), the first values are the plain radical
    /// inverse; with them, the first `b^k` points of dimension `d` still fall one in each
    /// interval of width `b^-k`.
    #[test]
    fn permuted_digits_keep_each_dimension_stratified() {
        for (dimension, k) in [(0usize, 8u32), (1, 5), (4, 3), (100, 1)] {
            let base = PRIMES[dimension];
            let n = base.pow(k) as u64;
            for key in [1u64, 99, 0xfeed] {
                let mut hit = vec![0u32; n as usize];
                for i in 0..n {
                    let x = permuted_radical_inverse(dimension, i, dimension_key(key, dimension));
                    assert!((0.0..1.0).contains(&x));
                    hit[(f64::from(x) * n as f64) as usize] += 1;
                }
                assert!(
                    hit.iter().all(|h| *h == 1),
                    "dimension {dimension}, key {key}"
                );
            }
        }
    }
}
