//! The film: per-pixel mean linear radiance (f32 RGB) and the variance of that mean, what a
//! render produces and what the output formats write.

use glam::Vec3;

/// An image of linear radiance with per-pixel variance estimates.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    /// Mean radiance per pixel, row-major from the top-left corner.
    pub pixels: Vec<Vec3>,
    /// Variance of each pixel's mean (sample variance / sample count), per channel.
    pub variance: Vec<Vec3>,
    /// Whether `variance` was measured: false for a 1-spp render, a PNG, or an EXR without
    /// a variance layer (its zeros then mean "unknown", not "exact").
    pub has_variance: bool,
    /// How many independent estimates (passes, or runs) the variance comes from: its degrees
    /// of freedom plus one, for tests that need them; 0 when not known.
    pub variance_samples: u32,
}

impl Film {
    pub fn new(width: u32, height: u32) -> Film {
        let n = width as usize * height as usize;
        Film {
            width,
            height,
            pixels: vec![Vec3::ZERO; n],
            variance: vec![Vec3::ZERO; n],
            has_variance: false,
            variance_samples: 0,
        }
    }

    /// Pixels holding a NaN or an infinite value: how many, and the first in raster order
    /// as (x, y). An image with any is not a radiance image metrics can be taken of.
    pub fn non_finite(&self) -> Option<(usize, (u32, u32))> {
        let first = self.pixels.iter().position(|p| !p.is_finite())?;
        let count = self.pixels.iter().filter(|p| !p.is_finite()).count();
        let w = self.width as usize;
        Some((count, ((first % w) as u32, (first / w) as u32)))
    }

    /// Mean radiance over the whole image, per channel.
    pub fn mean(&self) -> Vec3 {
        let sum = self
            .pixels
            .iter()
            .fold(glam::DVec3::ZERO, |a, p| a + p.as_dvec3());
        (sum / self.pixels.len() as f64).as_vec3()
    }

    /// The `w x h` pixels whose top-left corner is `(x, y)`; `None` unless the rectangle is
    /// non-empty and inside the image.
    pub fn crop(&self, x: u32, y: u32, w: u32, h: u32) -> Option<Film> {
        let inside = w > 0
            && h > 0
            && x.checked_add(w).is_some_and(|r| r <= self.width)
            && y.checked_add(h).is_some_and(|b| b <= self.height);
        if !inside {
            return None;
        }
        let mut out = Film::new(w, h);
        out.has_variance = self.has_variance;
        out.variance_samples = self.variance_samples;
        for j in 0..h {
            let from = ((y + j) * self.width + x) as usize;
            let to = (j * w) as usize;
            out.pixels[to..to + w as usize].copy_from_slice(&self.pixels[from..from + w as usize]);
            out.variance[to..to + w as usize]
                .copy_from_slice(&self.variance[from..from + w as usize]);
        }
        Some(out)
    }

    /// Standard error of [`Film::mean`], from the per-pixel variances.
    pub fn mean_standard_error(&self) -> Vec3 {
        let sum = self
            .variance
            .iter()
            .fold(glam::DVec3::ZERO, |a, v| a + v.as_dvec3());
        let n = self.pixels.len() as f64;
        (sum / (n * n)).as_vec3().map(f32::sqrt)
    }
}
