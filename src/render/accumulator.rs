//! A render's per-pixel running sums, from which the film is made.
//!
//! The sums are kept in two stages, so that they do not depend on which machine added which
//! passes. Within a block of [`BLOCK`] passes (blocks start at pass 0 and at every multiple of
//! [`BLOCK`]), a pixel adds the passes' values in f64, in pass order, starting from zero
//! ([`PixelAccumulator`]): cheap, and the same bits wherever the block is rendered. When a
//! block ends its sums are added to the pixel's exact totals ([`PixelTotals`], see
//! [`super::exact`]), whose value does not depend on the order blocks are added in: the shards
//! of a render, each a whole number of blocks, add up to bit for bit the single run's sums.

use super::exact::{Exact, Exact3};
use glam::{DVec3, Vec3};

/// Passes per block: a shard by passes holds a whole number of blocks.
pub const BLOCK: u32 = 8;

/// One pixel's sums over the passes of the block in progress, in f64.
///
/// A pixel's value is the filter-weighted mean of the camera samples around it,
/// `sum / weight`, plus the mean of its splats per pass, `splat / passes`. Its error is
/// estimated by batch means: every pass gives one estimate `Y_k` of the pixel (that pass's
/// weighted mean plus its splats), and the variance of the mean is the sample variance of the
/// `Y_k` over the number of passes. With the box filter and no splats each pass is exactly
/// one sample of the pixel, so this is the per-sample variance.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelAccumulator {
    /// Sum of filter weight times radiance of the samples near the pixel.
    pub(crate) sum: DVec3,
    /// Sum of the filter weights (dropped samples count with their weight and no radiance).
    pub(crate) weight: f64,
    /// Sum of the splats (radiance integrators added at film positions in the pixel).
    pub(crate) splat: DVec3,
    /// Sum of the passes' estimates `Y_k`, and of their squares.
    pub(crate) batch: DVec3,
    pub(crate) batch_sq: DVec3,
}

/// What one pass adds to one pixel, before the pass is closed.
#[derive(Clone, Copy, Debug, Default)]
pub struct PassPixel {
    pub(crate) sum: DVec3,
    pub(crate) weight: f64,
    pub(crate) splat: DVec3,
}

impl PassPixel {
    /// A sample of radiance `v` with filter weight `w`.
    #[inline]
    pub fn add(&mut self, v: glam::Vec3A, w: f32) {
        let d = DVec3::new(v.x as f64, v.y as f64, v.z as f64);
        if w == 1.0 {
            self.sum += d;
        } else {
            self.sum += d * w as f64;
        }
        self.weight += w as f64;
    }
}

impl PixelAccumulator {
    /// Adds a finished pass's sums and its estimate to the batch means.
    #[inline]
    pub fn close_pass(&mut self, pass: &PassPixel) {
        let mut y = if pass.weight > 0.0 {
            pass.sum / pass.weight
        } else {
            DVec3::ZERO
        };
        if pass.splat != DVec3::ZERO {
            y += pass.splat;
        }
        self.sum += pass.sum;
        self.weight += pass.weight;
        self.splat += pass.splat;
        self.batch += y;
        self.batch_sq += y * y;
    }

    /// Whether no pass added anything.
    pub fn is_empty(&self) -> bool {
        *self == PixelAccumulator::default()
    }

    /// Whether this block's sums fit the exact totals (a block that does not is dropped for
    /// its pixel when it ends, or when an image is made of an unfinished one).
    pub fn fits(&self) -> bool {
        self.is_empty() || PixelTotals::of_block(self).is_some()
    }
}

/// The squares of the passes' estimates are held scaled by this (exactly: a power of two), so
/// on a grid of 2^-64 with room up to 2^94 per block: estimates up to about 1e14 per pass fit,
/// where squares on the linear sums' grid would stop at 2e9.
const SQUARES_SCALE: f64 = 1.0 / 4_294_967_296.0; // 2^-32

/// One pixel's exact sums over every finished block (the same five sums as
/// [`PixelAccumulator`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelTotals {
    pub(crate) sum: Exact3,
    pub(crate) weight: Exact,
    pub(crate) splat: Exact3,
    pub(crate) batch: Exact3,
    pub(crate) batch_sq: Exact3,
}

impl PixelTotals {
    /// A block's sums, exactly; `None` when one is beyond what exact sums hold
    /// ([`super::exact::LIMIT`], 4.6e18, for a block's sum; about 1e14 for a pass's estimate,
    /// whose square is summed).
    #[inline]
    fn of_block(block: &PixelAccumulator) -> Option<PixelTotals> {
        Some(PixelTotals {
            sum: Exact3::from_dvec3(block.sum)?,
            weight: Exact::from_f64(block.weight)?,
            splat: Exact3::from_dvec3(block.splat)?,
            batch: Exact3::from_dvec3(block.batch)?,
            batch_sq: Exact3::from_dvec3(block.batch_sq * SQUARES_SCALE)?,
        })
    }

    /// Adds another pixel's totals (a shard's).
    #[inline]
    pub fn add(&mut self, other: &PixelTotals) {
        self.sum.add(&other.sum);
        self.weight.add(&other.weight);
        self.splat.add(&other.splat);
        self.batch.add(&other.batch);
        self.batch_sq.add(&other.batch_sq);
    }

    /// Ends a block: adds its sums and empties it. Returns false, adding nothing, when a sum
    /// is beyond what exact sums hold (the block is dropped for this pixel).
    #[inline]
    pub fn absorb(&mut self, block: &mut PixelAccumulator) -> bool {
        if block.is_empty() {
            return true;
        }
        let exact = PixelTotals::of_block(block);
        *block = PixelAccumulator::default();
        match exact {
            Some(e) => {
                self.add(&e);
                true
            }
            None => false,
        }
    }

    /// The totals with the unfinished `block` added (left out, as a finished block would be,
    /// when it is beyond what exact sums hold).
    pub fn with_block(&self, block: &PixelAccumulator) -> PixelTotals {
        let mut out = *self;
        out.absorb(&mut block.clone());
        out
    }

    /// The 13 sums in a fixed order (files).
    pub fn values(&self) -> [Exact; 13] {
        let [s, p, b, q] = [self.sum, self.splat, self.batch, self.batch_sq].map(|v| v.0);
        [
            s[0],
            s[1],
            s[2],
            self.weight,
            p[0],
            p[1],
            p[2],
            b[0],
            b[1],
            b[2],
            q[0],
            q[1],
            q[2],
        ]
    }

    /// The inverse of [`PixelTotals::values`].
    pub fn from_values(v: [Exact; 13]) -> PixelTotals {
        PixelTotals {
            sum: Exact3([v[0], v[1], v[2]]),
            weight: v[3],
            splat: Exact3([v[4], v[5], v[6]]),
            batch: Exact3([v[7], v[8], v[9]]),
            batch_sq: Exact3([v[10], v[11], v[12]]),
        }
    }

    /// The totals as they are held between passes: each sum's two low limbs and, only when a
    /// sum needs its top limb (beyond 2^31 in magnitude), the 13 top limbs.
    pub(crate) fn narrow(&self) -> (NarrowTotals, Option<[u64; 13]>) {
        let mut low = [[0u64; 2]; 13];
        let mut top = [0u64; 13];
        let mut wide = false;
        for (i, v) in self.values().iter().enumerate() {
            low[i] = [v.0[0], v.0[1]];
            top[i] = v.0[2];
            wide |= v.0[2] != sign_limb(v.0[1]);
        }
        (NarrowTotals(low), wide.then_some(top))
    }

    /// The inverse of [`PixelTotals::narrow`].
    pub(crate) fn widen(narrow: &NarrowTotals, top: Option<&[u64; 13]>) -> PixelTotals {
        let mut values = [Exact::ZERO; 13];
        for (i, v) in values.iter_mut().enumerate() {
            let [l0, l1] = narrow.0[i];
            *v = Exact([l0, l1, top.map_or(sign_limb(l1), |t| t[i])]);
        }
        PixelTotals::from_values(values)
    }

    /// Mean and variance of the mean after `n` passes.
    pub fn finish(&self, n: u32) -> (Vec3, Vec3) {
        if n == 0 {
            return (Vec3::ZERO, Vec3::ZERO);
        }
        let n = n as f64;
        let weight = self.weight.to_f64();
        let mut mean = if weight > 0.0 {
            self.sum.to_dvec3() / weight
        } else {
            DVec3::ZERO
        };
        if !self.splat.is_zero() {
            mean += self.splat.to_dvec3() / n;
        }
        let var = if n > 1.0 {
            let batch_mean = self.batch.to_dvec3() / n;
            let squares = self.batch_sq.to_dvec3() / SQUARES_SCALE;
            ((squares / n - batch_mean * batch_mean) * (n / (n - 1.0))).max(DVec3::ZERO) / n
        } else {
            DVec3::ZERO
        };
        (mean.as_vec3(), var.as_vec3())
    }
}

/// The top limb of an exact sum whose value fits in its two low limbs (two's complement):
/// all ones below zero, else zero.
#[inline]
fn sign_limb(limb1: u64) -> u64 {
    if (limb1 as i64) < 0 {
        u64::MAX
    } else {
        0
    }
}

/// A pixel's exact totals as a render holds them: of each of the 13 sums, the two low limbs
/// of three (a value up to 2^31 in magnitude, on the grid of 2^-96). The few pixels whose sums
/// go beyond keep their top limbs beside ([`crate::render::TileAccumulator`]): 208 bytes a
/// pixel instead of 312, the same sums exactly.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NarrowTotals([[u64; 2]; 13]);
