//! Error metrics between a test image and a reference, both linear radiance.
//!
//! * RMSE and relative MSE on linear radiance, over all pixels and channels. Relative MSE is
//!   `mean((x - r)^2 / (r^2 + 0.01))` (pbrt-v4's `imgtool diff` form, the 0.01 keeping black
//!   pixels finite).
//! * PSNR and FLIP on what a person sees: the images after the default display transform
//!   (exposure 0, clamp, sRGB, 8 bits). PSNR is `10 log10(1 / MSE)` on values in [0, 1]; FLIP is
//!   NVIDIA's perceptual difference (LDR-FLIP, mean over the image, 0 = identical), computed by
//!   the `nv-flip` crate at 67 pixels per degree (its default viewing conditions).
//! * HDR-FLIP (Andersson et al. 2021) on the radiance itself: LDR-FLIP after each exposure of
//!   a bracket chosen from the reference (from the exposure that maps its brightest pixel to
//!   0.85 after the ACES curve to the one that maps its median there, one stop apart), the
//!   largest error per pixel kept. The bracketed images are 8-bit sRGB, as `nv-flip` takes.

use crate::output::tonemap::{to_srgb8, Tonemap};
use crate::render::Film;
use anyhow::{bail, Result};
use image::RgbImage;
use serde::Serialize;

/// The differences between a test image and a reference.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Metrics {
    pub rmse: f64,
    pub rel_mse: f64,
    /// Decibels; infinite for identical display images.
    pub psnr: f64,
    pub flip: f64,
}

/// The 8-bit display image of a film: exposure 0, clamp, sRGB.
pub fn display_bytes(film: &Film) -> Vec<u8> {
    film.pixels
        .iter()
        .flat_map(|p| to_srgb8(*p, 0.0, Tonemap::Clamp))
        .collect()
}

/// Refuses two images of different sizes.
pub fn same_size(test: &Film, reference: &Film) -> Result<()> {
    if (test.width, test.height) != (reference.width, reference.height) {
        bail!(
            "the images differ in size: {}x{} against {}x{}",
            test.width,
            test.height,
            reference.width,
            reference.height
        );
    }
    Ok(())
}

/// Metrics of `test` against `reference`, and FLIP's per-pixel error map in [0, 1].
pub fn compare(test: &Film, reference: &Film) -> Result<(Metrics, Vec<f32>)> {
    same_size(test, reference)?;
    let n = (test.pixels.len() * 3) as f64;
    let linear = super::stats::linear_error(test, reference);
    let (a, b) = (display_bytes(test), display_bytes(reference));
    let display_mse = a
        .iter()
        .zip(&b)
        .map(|(x, y)| {
            let d = (*x as f64 - *y as f64) / 255.0;
            d * d
        })
        .sum::<f64>()
        / n;
    let psnr = if display_mse == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (1.0 / display_mse).log10()
    };
    let (w, h) = (test.width, test.height);
    let error = nv_flip::flip(
        nv_flip::FlipImageRgb8::with_data(w, h, &b),
        nv_flip::FlipImageRgb8::with_data(w, h, &a),
        nv_flip::DEFAULT_PIXELS_PER_DEGREE,
    );
    let flip = nv_flip::FlipPool::from_image(&error).mean() as f64;
    let map = error.to_vec();
    Ok((
        Metrics {
            rmse: linear.mse_raw.sqrt(),
            rel_mse: linear.relmse_raw,
            psnr,
            flip,
        },
        map,
    ))
}

/// The ACES filmic curve (Narkowicz's fit, the 0.6 pre-exposure folded into the constants,
/// as HDR-FLIP uses it).
const ACES: [f64; 6] = [
    0.6 * 0.6 * 2.51,
    0.6 * 0.03,
    0.0,
    0.6 * 0.6 * 2.43,
    0.6 * 0.59,
    0.14,
];

fn aces(x: f64) -> f64 {
    let [k0, k1, k2, k3, k4, k5] = ACES;
    ((x * (k0 * x + k1) + k2) / (x * (k3 * x + k4) + k5)).clamp(0.0, 1.0)
}

/// The exposures (stops) HDR-FLIP brackets for `reference`: from the one that maps the
/// brightest luminance to 0.85 after the ACES curve to the one that maps the median there.
pub fn hdr_exposures(reference: &Film) -> Vec<f64> {
    let [k0, k1, k2, k3, k4, k5] = ACES;
    let t = 0.85;
    let c0 = (k1 - k4 * t) / (k0 - k3 * t);
    let c1 = (k2 - k5 * t) / (k0 - k3 * t);
    let x = -0.5 * c0 + ((0.5 * c0).powi(2) - c1).sqrt();
    let mut lum: Vec<f64> = reference
        .pixels
        .iter()
        .map(|p| 0.2126 * p.x as f64 + 0.7152 * p.y as f64 + 0.0722 * p.z as f64)
        .filter(|y| y.is_finite())
        .collect();
    lum.sort_by(f64::total_cmp);
    let hi = lum.last().copied().unwrap_or(0.0);
    if hi <= 0.0 {
        return vec![0.0];
    }
    // The median, or the darkest lit pixel when more than half the image is black.
    let mid = lum[lum.len() / 2];
    let lo = if mid > 0.0 {
        mid
    } else {
        lum.iter().copied().find(|y| *y > 0.0).unwrap_or(hi)
    };
    let (start, stop) = ((x / hi).log2(), (x / lo).log2());
    let count = ((stop - start).ceil() as usize).clamp(2, 24);
    (0..count)
        .map(|i| start + (stop - start) * i as f64 / (count - 1) as f64)
        .collect()
}

/// HDR-FLIP of `test` against `reference`: the mean over pixels of the largest LDR-FLIP error
/// across the exposure bracket, and that per-pixel error map.
pub fn hdr_flip(test: &Film, reference: &Film) -> (f64, Vec<f32>) {
    let (w, h) = (test.width, test.height);
    let mut worst = vec![0.0f32; test.pixels.len()];
    let ldr = |film: &Film, scale: f64| -> Vec<u8> {
        film.pixels
            .iter()
            .flat_map(|p| {
                p.to_array().map(|v| {
                    let v = aces((v as f64 * scale).max(0.0)) as f32;
                    (crate::output::tonemap::srgb_encode(v) * 255.0 + 0.5) as u8
                })
            })
            .collect()
    };
    for e in hdr_exposures(reference) {
        let scale = e.exp2();
        let error = nv_flip::flip(
            nv_flip::FlipImageRgb8::with_data(w, h, &ldr(reference, scale)),
            nv_flip::FlipImageRgb8::with_data(w, h, &ldr(test, scale)),
            nv_flip::DEFAULT_PIXELS_PER_DEGREE,
        );
        for (m, v) in worst.iter_mut().zip(error.to_vec()) {
            *m = m.max(v);
        }
    }
    let mean = worst.iter().map(|v| *v as f64).sum::<f64>() / worst.len().max(1) as f64;
    (mean, worst)
}

/// FLIP's error map in its magma colour scale (black = no difference, yellow = large).
pub fn error_map_image(map: &[f32], width: u32, height: u32) -> RgbImage {
    let values = nv_flip::FlipImageFloat::with_data(width, height, map);
    let colored = values.apply_color_lut(&nv_flip::magma_lut());
    RgbImage::from_raw(width, height, colored.to_vec()).expect("FLIP returns a full image")
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn film(values: &[f32], w: u32, h: u32) -> Film {
        let mut f = Film::new(w, h);
        for (p, v) in f.pixels.iter_mut().zip(values.iter().cycle()) {
            *p = Vec3::splat(*v);
        }
        f
    }

    #[test]
    fn identical_images_have_no_error() {
        let a = film(&[0.1, 0.5, 0.9, 0.3], 8, 8);
        let (m, map) = compare(&a, &a).unwrap();
        assert_eq!((m.rmse, m.rel_mse, m.flip), (0.0, 0.0, 0.0));
        assert!(m.psnr.is_infinite());
        assert!(map.iter().all(|v| *v == 0.0));
    }

    #[test]
    fn known_differences() {
        let r = film(&[0.5], 16, 16);
        let t = film(&[0.6], 16, 16);
        let (m, _) = compare(&t, &r).unwrap();
        assert!((m.rmse - 0.1).abs() < 1e-6);
        assert!((m.rel_mse - 0.01 / 0.26).abs() < 1e-6);
        // sRGB(0.5) = 188, sRGB(0.6) = 203: PSNR = 20 log10(255 / 15) = 24.6 dB.
        assert!((m.psnr - 24.61).abs() < 0.05, "{}", m.psnr);
        assert!(m.flip > 0.0 && m.flip < 1.0);
        // A larger difference is a larger error on every metric.
        let (m2, _) = compare(&film(&[0.9], 16, 16), &r).unwrap();
        assert!(m2.rmse > m.rmse && m2.rel_mse > m.rel_mse && m2.psnr < m.psnr && m2.flip > m.flip);
        assert!(compare(&film(&[0.5], 16, 8), &r).is_err());
    }
}
