//! Deterministic per-sample random numbers.
//!
//! Every camera sample gets its own numbers, addressed only by where it sits ([`SampleSite`]:
//! the scene seed, the pixel, the sample index) and the dimension. No state is shared between
//! samples, so an image is bit-identical whatever the thread count, tile order or pass split.
//! Camera samples draw them as the render's [`SamplerKind`] says: independent numbers from a
//! generator keyed by the sample (the default), jittered strata, or the points of a
//! low-discrepancy sequence (Owen-scrambled Sobol, padded or over the image in Morton order,
//! and Halton with permuted digits).
//!
//! The Metropolis integrators drive the same code with numbers of their own: a sampler made
//! by [`Sampler::primary`] reads them from a Markov chain's state in primary sample space
//! ([`PrimarySamples`]), which mutates them between evaluations. They keep it under every
//! kind.

mod halton;
mod sobol;
mod stratified;

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
    /// The coordinates of one point of a pixel's scrambled Sobol sequence, in pairs.
    Sobol(sobol::PaddedSobol),
    /// One point of the image's Morton-ordered Sobol sequence.
    ZSobol(sobol::ZSobol),
    /// One point of a pixel's Halton sequence; past its prime bases, the generator's numbers.
    Halton {
        index: u64,
        pixel_key: u64,
        dimension: usize,
        rest: SmallRng,
    },
    /// Jittered strata over the pixel's samples.
    Stratified(stratified::Stratified),
}

/// How camera samples draw their numbers (`--sampler`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum SamplerKind {
    /// Independent uniform numbers from a generator keyed by the sample (with the pixel
    /// position stratified over the render's samples).
    #[default]
    Independent,
    /// Jittered stratification of every draw over a pixel's samples (pbrt-v4's
    /// `stratified`): `n` strata per 1-D draw, an `nx x ny` grid per 2-D one, the strata
    /// visited in an order of their own per draw. `n` is the render's sample count (64 per
    /// block when open-ended).
    Stratified,
    /// Owen-scrambled Sobol points (Burley 2020, the `sobol_burley` crate), padded: a
    /// sample's numbers come in pairs (each 2-D draw one pair), pair `k` of sample `i` of a
    /// pixel being point `i` of a scramble of its own. The first `2^m` samples of a pixel are
    /// a (0, m, 2)-net in every pair.
    Sobol,
    /// pbrt-v4's default, `zsobol` (Ahmed and Wonka 2020): one Owen-scrambled Sobol sequence
    /// over the image, pixels in Morton order, each pixel's samples still a (0, m, 2)-net per
    /// draw, neighbouring pixels' errors spread as blue noise. The sample count is rounded up
    /// to a power of two (1024 when open-ended).
    ZSobol,
    /// Halton points with random digit permutations per pixel and dimension (the first 256
    /// dimensions, in the first 256 prime bases; independent numbers past them).
    Halton,
}

impl SamplerKind {
    /// Every kind, by its name.
    pub const ALL: [(&'static str, SamplerKind); 5] = [
        ("independent", SamplerKind::Independent),
        ("stratified", SamplerKind::Stratified),
        ("sobol", SamplerKind::Sobol),
        ("zsobol", SamplerKind::ZSobol),
        ("halton", SamplerKind::Halton),
    ];

    /// The kind's name, as `--sampler` takes it.
    pub fn name(self) -> &'static str {
        crate::named::name_of(&Self::ALL, self)
    }

    /// The kind named `name`.
    pub fn parse(name: &str) -> Result<SamplerKind, String> {
        crate::named::parse_named(&Self::ALL, name, ("sampler", "samplers"))
    }
}

impl std::fmt::Display for SamplerKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Where a camera sample sits: what every sampler addresses its numbers by.
#[derive(Clone, Copy, Debug)]
pub struct SampleSite {
    /// The render's seed (each run of a comparison has its own).
    pub seed: u64,
    pub x: u32,
    pub y: u32,
    /// The image's size, which `zsobol` lays its Morton curve over.
    pub width: u32,
    pub height: u32,
    /// The sample's index within its pixel.
    pub sample: u64,
    /// The render's samples per pixel; `None` when open-ended.
    pub spp: Option<u32>,
}

impl SampleSite {
    /// The pixel's index in the image, row by row.
    pub fn pixel(&self) -> u64 {
        u64::from(self.y) * u64::from(self.width) + u64::from(self.x)
    }
}

impl Sampler {
    /// The generator for sample `sample` of pixel `pixel` under `seed`.
    pub fn new(seed: u64, pixel: u64, sample: u64) -> Self {
        Sampler {
            source: Source::Random(Sampler::generator(seed, pixel, sample)),
        }
    }

    /// The numbers of the camera sample at `site`, drawn as `kind` says; [`Sampler::new`]'s
    /// for `Independent`.
    pub fn camera(kind: SamplerKind, site: &SampleSite) -> Self {
        let pixel = site.pixel();
        let source = match kind {
            SamplerKind::Independent => return Sampler::new(site.seed, pixel, site.sample),
            SamplerKind::Sobol => {
                Source::Sobol(sobol::PaddedSobol::new(site.seed, pixel, site.sample))
            }
            SamplerKind::ZSobol => Source::ZSobol(sobol::ZSobol::new(
                site.seed,
                (site.x, site.y),
                (site.width, site.height),
                site.sample,
                site.spp,
            )),
            SamplerKind::Halton => Source::Halton {
                index: site.sample,
                pixel_key: mix64(site.seed ^ mix64(pixel ^ 0x8bb8_4b93_962e_acc9)),
                dimension: 0,
                rest: Sampler::generator(site.seed, pixel, site.sample),
            },
            SamplerKind::Stratified => Source::Stratified(stratified::Stratified::new(
                Sampler::generator(site.seed, pixel, site.sample),
                mix64(site.seed ^ mix64(pixel ^ 0x2545_f491_4f6c_dd1d)),
                site.sample,
                site.spp,
            )),
        };
        Sampler { source }
    }

    /// The generator [`Sampler::new`] keys by the sample.
    fn generator(seed: u64, pixel: u64, sample: u64) -> SmallRng {
        let key = mix64(seed ^ mix64(pixel.wrapping_add(0x9e37_79b9_7f4a_7c15) ^ mix64(sample)));
        SmallRng::seed_from_u64(key)
    }

    /// Whether its numbers are stratified across a pixel's samples by construction (a
    /// low-discrepancy sequence, strata), so that the first two place the sample in the pixel
    /// as they are.
    pub fn stratifies_pixels(&self) -> bool {
        !matches!(self.source, Source::Random(_) | Source::Primary(_))
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
            _ => None,
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
            Source::ZSobol(point) => point.next_1d(),
            Source::Stratified(strata) => strata.next_1d(),
            Source::Halton {
                index,
                pixel_key,
                dimension,
                rest,
            } => {
                let d = *dimension;
                *dimension += 1;
                if d < halton::DIMENSIONS {
                    halton::permuted_radical_inverse(
                        d,
                        *index,
                        halton::dimension_key(*pixel_key, d),
                    )
                } else {
                    unit_f32(rest)
                }
            }
        }
    }

    /// A uniform point in `[0, 1)^2`: one draw of two dimensions (under `sobol`, the two
    /// coordinates of one pair; under `zsobol` and `stratified`, one 2-D point).
    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        match &mut self.source {
            Source::Sobol(point) => point.align_pair(),
            Source::ZSobol(point) => return point.next_2d().into(),
            Source::Stratified(strata) => return strata.next_2d().into(),
            Source::Random(_) | Source::Primary(_) | Source::Halton { .. } => {}
        }
        Vec2::new(self.next_1d(), self.next_1d())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sample `sample` of pixel `pixel` of one long row of pixels.
    fn at(seed: u64, pixel: u64, sample: u64, spp: Option<u32>) -> SampleSite {
        SampleSite {
            seed,
            x: pixel as u32,
            y: 0,
            width: 1 << 20,
            height: 1,
            sample,
            spp,
        }
    }

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
                        let mut s = Sampler::camera(SamplerKind::Sobol, &at(9, pixel, i, None));
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

    /// Under every kind, pixels have numbers of their own, and numbers far into a sample
    /// and past 2^16 samples (and past a render's count) stay in [0, 1) with mean one half.
    #[test]
    fn every_kind_differs_between_pixels_and_stays_uniform() {
        for (name, kind) in SamplerKind::ALL {
            let first = |pixel| Sampler::camera(kind, &at(1, pixel, 0, Some(16))).next_1d();
            assert_ne!(first(0), first(1), "{name}");
            for (sample, skip) in [(3u64, 301usize), (70_000, 0), (70_000, 600), (5, 2)] {
                let n = 20_000;
                let mut sum = 0.0f64;
                for pixel in 0..n {
                    let mut s = Sampler::camera(kind, &at(2, pixel, sample, Some(16)));
                    for _ in 0..skip {
                        s.next_1d();
                    }
                    let x = s.next_1d();
                    assert!((0.0..1.0).contains(&x), "{name}");
                    sum += x as f64;
                }
                let mean = sum / n as f64;
                assert!(
                    (mean - 0.5).abs() < 5.0 * (1.0f64 / 12.0 / n as f64).sqrt(),
                    "{name}: sample {sample}, dimension {skip}: mean {mean}"
                );
            }
        }
        assert_eq!(SamplerKind::parse("zsobol"), Ok(SamplerKind::ZSobol));
        assert!(SamplerKind::parse("pmj")
            .unwrap_err()
            .contains("independent, stratified, sobol, zsobol, halton"));
    }

    /// `stratified` and `zsobol` with `n = 2^m` samples put one of a pixel's samples in each
    /// of `n` strata of every 1-D draw, and (zsobol: in every elementary interval of area
    /// `1/n`; stratified: in every cell of its grid) of every 2-D draw; `halton`'s first
    /// 2^3 3^2 = 72 samples fall one per 1/8 x 1/9 box of the pixel's first draw (bases 2
    /// and 3). Pixels anywhere in a large image, with 1-D draws between the 2-D ones.
    #[test]
    fn stratified_zsobol_and_halton_stratify_each_draw() {
        let site = |x, y, sample, spp| SampleSite {
            seed: 5,
            x,
            y,
            width: 1920,
            height: 1080,
            sample,
            spp: Some(spp),
        };
        for kind in [SamplerKind::Stratified, SamplerKind::ZSobol] {
            for (x, y) in [(0u32, 0u32), (17, 3), (1919, 1079)] {
                for m in [2u32, 4, 5] {
                    let n = 1u32 << m;
                    let draws: Vec<Vec<f32>> = (0..u64::from(n))
                        .map(|i| {
                            let mut s = Sampler::camera(kind, &site(x, y, i, n));
                            let mut d = Vec::new();
                            for _ in 0..3 {
                                d.extend(s.next_2d().to_array());
                                d.push(s.next_1d());
                            }
                            d
                        })
                        .collect();
                    for draw in 0..3 {
                        let one: Vec<f32> = draws.iter().map(|d| d[3 * draw + 2]).collect();
                        let mut hit = vec![0; n as usize];
                        for v in one {
                            hit[(v * n as f32) as usize] += 1;
                        }
                        assert!(
                            hit.iter().all(|h| *h == 1),
                            "{kind} 1-D {draw} at ({x},{y}), {n}"
                        );
                        let splits: Vec<u32> = match kind {
                            SamplerKind::ZSobol => (0..=m).collect(),
                            _ => vec![m / 2],
                        };
                        for a in splits {
                            let (cols, rows) = (1usize << a, 1usize << (m - a));
                            let mut hit = vec![0; n as usize];
                            for d in &draws {
                                let (u, v) = (d[3 * draw], d[3 * draw + 1]);
                                hit[(v * rows as f32) as usize * cols
                                    + (u * cols as f32) as usize] += 1;
                            }
                            assert!(
                                hit.iter().all(|h| *h == 1),
                                "{kind} 2-D {draw} at ({x},{y}), {cols}x{rows}"
                            );
                        }
                    }
                }
            }
        }
        let mut hit = [0; 72];
        for i in 0..72 {
            let mut s = Sampler::camera(SamplerKind::Halton, &site(40, 7, i, 72));
            let p = s.next_2d();
            hit[(p.y * 9.0) as usize * 8 + (p.x * 8.0) as usize] += 1;
        }
        assert!(hit.iter().all(|h| *h == 1), "halton: {hit:?}");
    }

    /// Every kind draws the same numbers for the same site, and `independent` stays the
    /// generator it always was.
    #[test]
    fn every_kind_repeats_itself_and_independent_is_unchanged() {
        for (name, kind) in SamplerKind::ALL {
            let draw = || {
                let mut s = Sampler::camera(kind, &at(3, 11, 6, Some(8)));
                (0..40).map(|_| s.next_1d()).collect::<Vec<_>>()
            };
            assert_eq!(draw(), draw(), "{name}");
        }
        let mut a = Sampler::camera(SamplerKind::Independent, &at(3, 11, 6, Some(8)));
        let mut b = Sampler::new(3, 11, 6);
        assert_eq!(a.next_1d(), b.next_1d());
    }
}
