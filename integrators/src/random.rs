//! Uniform numbers from a generator and generators keyed by numbers: what the per-sample
//! [`crate::sampler`] and the Metropolis chains' primary samples ([`crate::mlt`]) both draw
//! from, below either.

use rand::{rngs::SmallRng, Rng, SeedableRng};

/// SplitMix64 finaliser: a bijective 64-bit mix.
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A uniform number in `[0, 1)` from `rng`: 24 random mantissa bits, exactly representable,
/// never 1.0.
#[inline]
pub fn unit_f32(rng: &mut SmallRng) -> f32 {
    (rng.random::<u32>() >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}

/// The generator keyed by `key` and `index` (a chain, a bootstrap sample), mixed so that
/// neighbouring keys give unrelated streams.
pub fn keyed_rng(key: u64, index: u64) -> SmallRng {
    SmallRng::seed_from_u64(mix64(
        key ^ mix64(index.wrapping_add(0x6a09_e667_f3bc_c909)),
    ))
}

/// A pseudo-random permutation of `[0, len)` selected by `key`: Kensler's hash-based
/// permutation ("Correlated Multi-Jittered Sampling", 2013), by cycle walking.
pub fn permute(mut i: u32, len: u32, key: u32) -> u32 {
    if len <= 1 {
        return 0;
    }
    let mut w = len - 1;
    w |= w >> 1;
    w |= w >> 2;
    w |= w >> 4;
    w |= w >> 8;
    w |= w >> 16;
    loop {
        i ^= key;
        i = i.wrapping_mul(0xe170_893d);
        i ^= key >> 16;
        i ^= (i & w) >> 4;
        i ^= key >> 8;
        i = i.wrapping_mul(0x0929_eb3f);
        i ^= key >> 23;
        i ^= (i & w) >> 1;
        i = i.wrapping_mul(1 | key >> 27);
        i = i.wrapping_mul(0x6935_fa69);
        i ^= (i & w) >> 11;
        i = i.wrapping_mul(0x74dc_b303);
        i ^= (i & w) >> 2;
        i = i.wrapping_mul(0x9e50_1cc3);
        i ^= (i & w) >> 2;
        i = i.wrapping_mul(0xc860_a3df);
        i &= w;
        i ^= i >> 5;
        if i < len {
            return (i.wrapping_add(key)) % len;
        }
    }
}
