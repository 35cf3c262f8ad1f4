//! Jittered stratification per draw, as pbrt-v4's `StratifiedSampler`: a pixel's `n`
//! samples split every 1-D draw into `n` strata and every 2-D draw into an `nx x ny` grid
//! (`nx ny = n`, as square as `n`'s divisors allow), sample `i` taking the stratum a
//! permutation of its own (keyed by pixel and dimension) gives it, jittered inside.

use crate::random::{mix64, permute, unit_f32};
use rand::rngs::SmallRng;

/// Strata per block when the render's sample count is open-ended.
pub(super) const OPEN_ENDED_BLOCK: u32 = 64;

pub(super) struct Stratified {
    /// The jitter.
    rng: SmallRng,
    /// The pixel's key, the block of `n` samples included.
    key: u64,
    /// The sample's place within its block.
    within: u32,
    n: u32,
    nx: u32,
    dimension: u32,
}

/// The largest divisor of `n` at most its square root.
fn columns(n: u32) -> u32 {
    let mut d = (n as f64).sqrt() as u32;
    while d > 1 && !n.is_multiple_of(d) {
        d -= 1;
    }
    d.max(1)
}

impl Stratified {
    pub(super) fn new(rng: SmallRng, pixel_key: u64, sample: u64, spp: Option<u32>) -> Self {
        let n = spp.unwrap_or(OPEN_ENDED_BLOCK).max(1);
        let block = sample / u64::from(n);
        Stratified {
            rng,
            key: mix64(pixel_key ^ mix64(block)),
            within: (sample % u64::from(n)) as u32,
            n,
            nx: columns(n),
            dimension: 0,
        }
    }

    #[inline]
    fn stratum(&mut self) -> u32 {
        let key = mix64(self.key ^ u64::from(self.dimension)) as u32;
        permute(self.within, self.n, key)
    }

    pub(super) fn next_1d(&mut self) -> f32 {
        let s = self.stratum();
        self.dimension += 1;
        let u = (s as f32 + unit_f32(&mut self.rng)) / self.n as f32;
        u.min(1.0 - f32::EPSILON / 2.0)
    }

    pub(super) fn next_2d(&mut self) -> (f32, f32) {
        let s = self.stratum();
        self.dimension += 2;
        let (nx, ny) = (self.nx, self.n / self.nx);
        let x = ((s % nx) as f32 + unit_f32(&mut self.rng)) / nx as f32;
        let y = ((s / nx) as f32 + unit_f32(&mut self.rng)) / ny as f32;
        let below_one = |v: f32| v.min(1.0 - f32::EPSILON / 2.0);
        (below_one(x), below_one(y))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grids_are_as_square_as_the_count_allows() {
        assert_eq!(columns(16), 4);
        assert_eq!(columns(12), 3);
        assert_eq!(columns(7), 1);
        assert_eq!(columns(1), 1);
        assert_eq!(columns(1000), 25);
    }
}
