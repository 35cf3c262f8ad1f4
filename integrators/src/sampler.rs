//! Deterministic per-sample random numbers.
//!
//! Every camera sample gets its own generator, seeded only from (scene seed, pixel index,
//! sample index). No state is shared between samples, so an image is bit-identical whatever
//! the thread count, tile order or pass split.
//!
//! The Metropolis integrators drive the same code with numbers of their own: a sampler made
//! by [`Sampler::primary`] reads them from a Markov chain's state in primary sample space
//! ([`PrimarySamples`]), which mutates them between evaluations.

use crate::mlt::PrimarySamples;
use crate::random::{mix64, unit_f32};
use glam::Vec2;
use rand::{rngs::SmallRng, SeedableRng};

/// A random number source for one camera sample (or one evaluation of a Metropolis chain).
pub struct Sampler {
    source: Source,
}

enum Source {
    /// Fresh numbers from a generator keyed by the sample.
    Random(SmallRng),
    /// A Markov chain's numbers in primary sample space.
    Primary(PrimarySamples),
}

impl Sampler {
    /// The generator for sample `sample` of pixel `pixel` under `seed`.
    pub fn new(seed: u64, pixel: u64, sample: u64) -> Self {
        let key = mix64(seed ^ mix64(pixel.wrapping_add(0x9e37_79b9_7f4a_7c15) ^ mix64(sample)));
        Sampler {
            source: Source::Random(SmallRng::seed_from_u64(key)),
        }
    }

    /// A sampler that reads a Markov chain's primary samples.
    pub fn primary(samples: PrimarySamples) -> Self {
        Sampler {
            source: Source::Primary(samples),
        }
    }

    /// The chain's primary samples, for a sampler made by [`Sampler::primary`].
    pub fn primary_samples(&mut self) -> Option<&mut PrimarySamples> {
        match &mut self.source {
            Source::Primary(p) => Some(p),
            Source::Random(_) => None,
        }
    }

    /// For a Metropolis chain's sampler, reads stream `stream` from its start (numbers for
    /// one subpath); nothing for a random one.
    pub fn start_stream(&mut self, stream: u32) {
        if let Source::Primary(p) = &mut self.source {
            p.start_stream(stream);
        }
    }

    /// A uniform number in `[0, 1)`.
    #[inline]
    pub fn next_1d(&mut self) -> f32 {
        match &mut self.source {
            Source::Random(rng) => unit_f32(rng),
            Source::Primary(p) => p.next_1d(),
        }
    }

    /// A uniform point in `[0, 1)^2`.
    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        Vec2::new(self.next_1d(), self.next_1d())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_key_same_stream_and_different_keys_differ() {
        let a: Vec<f32> = (0..8)
            .map({
                let mut s = Sampler::new(1, 2, 3);
                move |_| s.next_1d()
            })
            .collect();
        let b: Vec<f32> = (0..8)
            .map({
                let mut s = Sampler::new(1, 2, 3);
                move |_| s.next_1d()
            })
            .collect();
        assert_eq!(a, b);
        let mut other = Sampler::new(1, 3, 2);
        assert_ne!(a[0], other.next_1d());
    }

    #[test]
    fn values_are_in_unit_interval_with_mean_one_half() {
        let mut s = Sampler::new(7, 0, 0);
        let n = 100_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let x = s.next_1d();
            assert!((0.0..1.0).contains(&x));
            sum += x as f64;
        }
        let mean = sum / n as f64;
        // Standard error of the mean of U(0,1) is sqrt(1/12/n) ~ 0.0009; allow 5 sigma.
        assert!((mean - 0.5).abs() < 5.0 * (1.0f64 / 12.0 / n as f64).sqrt());
    }
}
