//! Deterministic per-sample random numbers.
//!
//! Every camera sample gets its own numbers, addressed only by (scene seed, pixel index,
//! sample index, dimension). No state is shared between samples, so an image is bit-identical
//! whatever the thread count, tile order or pass split. Camera samples draw them as the
//! render's [`SamplerKind`] says: independent numbers from a generator keyed by the sample
//! (the default), or the points of a low-discrepancy sequence, dimension after dimension
//! (`sobol`: Owen-scrambled Sobol, one scramble per pixel, after Burley 2020).
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
    /// The coordinates of one point of a pixel's scrambled Sobol sequence.
    Sobol(SobolPoint),
}

/// How camera samples draw their numbers (`--sampler`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum SamplerKind {
    /// Independent uniform numbers from a generator keyed by the sample (with the pixel
    /// position stratified over the render's samples).
    #[default]
    Independent,
    /// Owen-scrambled Sobol points (Burley 2020, the `sobol_burley` crate), padded: a
    /// sample's numbers come in pairs (each 2-D draw one pair), pair `k` of sample `i` of a
    /// pixel being point `i` of a scramble of its own. The first `2^m` samples of a pixel are
    /// a (0, m, 2)-net in every pair.
    Sobol,
}

impl SamplerKind {
    /// Every kind, by its name.
    pub const ALL: [(&'static str, SamplerKind); 2] = [
        ("independent", SamplerKind::Independent),
        ("sobol", SamplerKind::Sobol),
    ];

    /// The kind's name, as `--sampler` takes it.
    pub fn name(self) -> &'static str {
        Self::ALL
            .iter()
            .find(|(_, k)| *k == self)
            .map_or("independent", |(n, _)| n)
    }

    /// The kind named `name`.
    pub fn parse(name: &str) -> Result<SamplerKind, String> {
        Self::ALL
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, k)| *k)
            .ok_or_else(|| {
                let names: Vec<&str> = Self::ALL.iter().map(|(n, _)| *n).collect();
                format!("no sampler `{name}`; samplers: {}", names.join(", "))
            })
    }
}

impl std::fmt::Display for SamplerKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// One sample's numbers under `sobol`: its coordinates in pairs, each pair the first two
/// dimensions of a Sobol sequence scrambled for the pixel and the pair (Owen scrambling of
/// the points and of their order, as pbrt-v4's padded Sobol sampler pairs its dimensions).
/// Every pair is then a (0, 2)-sequence over the pixel's samples, which the higher dimensions
/// of one Sobol table are not.
struct SobolPoint {
    index: u32,
    /// The pixel's scramble.
    seed: u32,
    /// The scramble of the pair in progress (set at its first coordinate).
    pair_seed: u32,
    dimension: u32,
}

impl SobolPoint {
    /// The next coordinate. The crate's points number 2^16; each further block of 2^16
    /// samples continues in a scramble of its own (as uniform, no longer stratified against
    /// the blocks before).
    #[inline]
    fn next(&mut self) -> f32 {
        let d = self.dimension;
        self.dimension = d.wrapping_add(1);
        if d.is_multiple_of(2) {
            let (pair, block) = (d / 2, self.index >> 16);
            self.pair_seed = if pair == 0 && block == 0 {
                self.seed
            } else {
                self.seed ^ (mix64(u64::from(pair) << 32 | u64::from(block)) as u32)
            };
        }
        sobol_burley::sample(self.index & 0xffff, d % 2, self.pair_seed)
    }

    /// Starts the next pair, so that a 2-D point's coordinates are one pair's.
    #[inline]
    fn align_pair(&mut self) {
        self.dimension += self.dimension & 1;
    }
}

impl Sampler {
    /// The generator for sample `sample` of pixel `pixel` under `seed`.
    pub fn new(seed: u64, pixel: u64, sample: u64) -> Self {
        let key = mix64(seed ^ mix64(pixel.wrapping_add(0x9e37_79b9_7f4a_7c15) ^ mix64(sample)));
        Sampler {
            source: Source::Random(SmallRng::seed_from_u64(key)),
        }
    }

    /// The numbers of camera sample `sample` of pixel `pixel` under `seed`, drawn as `kind`
    /// says; [`Sampler::new`]'s for `Independent`.
    pub fn camera(kind: SamplerKind, seed: u64, pixel: u64, sample: u64) -> Self {
        match kind {
            SamplerKind::Independent => Sampler::new(seed, pixel, sample),
            SamplerKind::Sobol => Sampler {
                source: Source::Sobol(SobolPoint {
                    index: u32::try_from(sample).unwrap_or(u32::MAX),
                    seed: mix64(seed ^ mix64(pixel.wrapping_add(0x632b_e59b_d9b4_e019))) as u32,
                    pair_seed: 0,
                    dimension: 0,
                }),
            },
        }
    }

    /// Whether its numbers are stratified across a pixel's samples by construction (a
    /// low-discrepancy sequence), so that the first two place the sample in the pixel as
    /// they are.
    pub fn stratifies_pixels(&self) -> bool {
        matches!(self.source, Source::Sobol(_))
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
            Source::Random(_) | Source::Sobol(_) => None,
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
            Source::Sobol(point) => point.next(),
        }
    }

    /// A uniform point in `[0, 1)^2` (under `sobol`, the two coordinates of one pair).
    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        if let Source::Sobol(point) = &mut self.source {
            point.align_pair();
        }
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

    /// The first `2^m` samples of a pixel under `sobol`, in each pair (each 2-D draw: the
    /// pixel position, then each bounce's), put exactly one point in every elementary
    /// interval of area `2^-m`: every `2^a x 2^(m-a)` grid of the unit square, for every
    /// split `a`. A 1-D draw before a 2-D one leaves the 2-D one a whole pair.
    #[test]
    fn the_first_power_of_two_sobol_samples_are_a_0_m_2_net_in_each_pair() {
        for pixel in [0u64, 7, 123_456] {
            for m in [4u32, 6, 8] {
                let n = 1usize << m;
                let points: Vec<Vec<f32>> = (0..n as u64)
                    .map(|i| {
                        let mut s = Sampler::camera(SamplerKind::Sobol, 9, pixel, i);
                        let mut p = Vec::new();
                        for k in 0..4 {
                            if k == 2 {
                                s.next_1d();
                            }
                            p.extend(s.next_2d().to_array());
                        }
                        p
                    })
                    .collect();
                for pair in [0usize, 2, 4, 6] {
                    for a in 0..=m {
                        let (cols, rows) = (1usize << a, 1usize << (m - a));
                        let mut hit = vec![0u32; n];
                        for p in &points {
                            let (x, y) = (p[pair], p[pair + 1]);
                            assert!((0.0..1.0).contains(&x) && (0.0..1.0).contains(&y));
                            let cell =
                                (y * rows as f32) as usize * cols + (x * cols as f32) as usize;
                            hit[cell] += 1;
                        }
                        assert!(
                            hit.iter().all(|h| *h == 1),
                            "pixel {pixel}, 2^{m} points, dimensions {pair}-{}, {cols}x{rows}",
                            pair + 1
                        );
                    }
                }
            }
        }
    }

    /// Pixels have scrambles of their own, and numbers far into a sample and past 2^16
    /// samples stay in [0, 1) with mean one half.
    #[test]
    fn sobol_pixels_differ_and_points_continue_past_the_table() {
        let first = |pixel| Sampler::camera(SamplerKind::Sobol, 1, pixel, 0).next_1d();
        assert_ne!(first(0), first(1));
        for (sample, skip) in [(3u64, 301usize), (70_000, 0), (70_000, 600)] {
            let n = 20_000;
            let mut sum = 0.0f64;
            for pixel in 0..n {
                let mut s = Sampler::camera(SamplerKind::Sobol, 2, pixel, sample);
                for _ in 0..skip {
                    s.next_1d();
                }
                let x = s.next_1d();
                assert!((0.0..1.0).contains(&x));
                sum += x as f64;
            }
            let mean = sum / n as f64;
            assert!(
                (mean - 0.5).abs() < 5.0 * (1.0f64 / 12.0 / n as f64).sqrt(),
                "sample {sample}, dimension {skip}: mean {mean}"
            );
        }
        assert_eq!(SamplerKind::parse("sobol"), Ok(SamplerKind::Sobol));
        assert!(SamplerKind::parse("halton")
            .unwrap_err()
            .contains("independent, sobol"));
    }
}
