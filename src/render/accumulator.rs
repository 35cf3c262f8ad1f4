//! A render's per-pixel running sums, from which the film is made.

use glam::Vec3;

/// Running sums for one pixel over the passes, in f64 so that thousands of samples add up
/// exactly enough.
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
    pub(crate) sum: glam::DVec3,
    /// Sum of the filter weights (dropped samples count with their weight and no radiance).
    pub(crate) weight: f64,
    /// Sum of the splats (radiance integrators added at film positions in the pixel).
    pub(crate) splat: glam::DVec3,
    /// Sum of the passes' estimates `Y_k`, and of their squares.
    pub(crate) batch: glam::DVec3,
    pub(crate) batch_sq: glam::DVec3,
}

/// What one pass adds to one pixel, before the pass is closed.
#[derive(Clone, Copy, Debug, Default)]
pub struct PassPixel {
    pub(crate) sum: glam::DVec3,
    pub(crate) weight: f64,
    pub(crate) splat: glam::DVec3,
}

impl PassPixel {
    /// A sample of radiance `v` with filter weight `w`.
    #[inline]
    pub fn add(&mut self, v: glam::Vec3A, w: f32) {
        let d = glam::DVec3::new(v.x as f64, v.y as f64, v.z as f64);
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
            glam::DVec3::ZERO
        };
        if pass.splat != glam::DVec3::ZERO {
            y += pass.splat;
        }
        self.sum += pass.sum;
        self.weight += pass.weight;
        self.splat += pass.splat;
        self.batch += y;
        self.batch_sq += y * y;
    }

    /// Mean and variance of the mean after `n` passes.
    pub fn finish(&self, n: u32) -> (Vec3, Vec3) {
        if n == 0 {
            return (Vec3::ZERO, Vec3::ZERO);
        }
        let n = n as f64;
        let mut mean = if self.weight > 0.0 {
            self.sum / self.weight
        } else {
            glam::DVec3::ZERO
        };
        if self.splat != glam::DVec3::ZERO {
            mean += self.splat / n;
        }
        let var = if n > 1.0 {
            let batch_mean = self.batch / n;
            ((self.batch_sq / n - batch_mean * batch_mean) * (n / (n - 1.0))).max(glam::DVec3::ZERO)
                / n
        } else {
            glam::DVec3::ZERO
        };
        (mean.as_vec3(), var.as_vec3())
    }
}
