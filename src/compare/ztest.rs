//! The per-pixel test of an image against a reference, the method of Mitsuba 3's render
//! tests: every pixel channel's difference over the standard error the two images' variance
//! layers give it, a two-sided p-value, and a Šidák-corrected significance level so that a
//! correct image fails anywhere with probability `significance` in all.
//!
//! The variances are estimates from each image's passes, so the statistic follows Student's
//! t rather than the normal: with the pass counts the EXRs record, the p-value is Welch's,
//! with Welch-Satterthwaite degrees of freedom (the normal where a count is unknown or large).
//! At a Šidák level of 1e-8 the difference matters: 25 passes put the threshold near 9
//! standard errors, the normal near 5.7.

use crate::render::Film;
use anyhow::{bail, Result};
use image::RgbImage;
use raylab_integrators::special::p_value_t;

/// What the test found.
#[derive(Clone, Debug)]
pub struct ZTest {
    /// Pixel channels tested.
    pub tested: usize,
    /// Pixels with at least one failing channel.
    pub failed_pixels: usize,
    /// The first failing pixel in raster order, as (x, y).
    pub first_failure: Option<(u32, u32)>,
    /// The smallest p-value found.
    pub min_p: f64,
    /// The per-channel significance level after the Šidák correction.
    pub alpha: f64,
    /// One flag per pixel: failed.
    pub failed: Vec<bool>,
}

/// Welch-Satterthwaite degrees of freedom of a sum of variance estimates `(v, n)`, each from
/// `n` samples (0: known, not estimated).
fn welch_dof(terms: &[(f64, u32)]) -> f64 {
    let total: f64 = terms.iter().map(|(v, _)| v).sum();
    let spread: f64 = terms
        .iter()
        .filter(|(_, n)| *n >= 2)
        .map(|(v, n)| v * v / (*n as f64 - 1.0))
        .sum();
    if spread > 0.0 {
        total * total / spread
    } else {
        f64::INFINITY
    }
}

/// Tests `test` against `reference` at `significance` (0.01: a correct image fails one time
/// in a hundred). At least one of the two must carry a variance layer.
pub fn z_test(test: &Film, reference: &Film, significance: f64) -> Result<ZTest> {
    super::metrics::same_size(test, reference)?;
    if !test.has_variance && !reference.has_variance {
        bail!("neither image has a variance layer (raylab writes one into EXRs of 2 spp or more); a z-test needs the images' noise");
    }
    let tested = test.pixels.len() * 3;
    // Šidák: 1 - (1 - alpha)^N = significance over all N channels.
    let alpha = -(-significance).ln_1p() / tested as f64;
    let alpha = -(-alpha).exp_m1();
    let mut out = ZTest {
        tested,
        failed_pixels: 0,
        first_failure: None,
        min_p: 1.0,
        alpha,
        failed: vec![false; test.pixels.len()],
    };
    let w = test.width as usize;
    for i in 0..test.pixels.len() {
        let mut failed = false;
        for c in 0..3 {
            let d = test.pixels[i][c] as f64 - reference.pixels[i][c] as f64;
            let mut terms = arrayvec::ArrayVec::<(f64, u32), 2>::new();
            for film in [test, reference].into_iter().filter(|f| f.has_variance) {
                terms.push((film.variance[i][c] as f64, film.variance_samples));
            }
            let var: f64 = terms.iter().map(|(v, _)| v).sum();
            let p = if var > 0.0 {
                p_value_t(d / var.sqrt(), welch_dof(&terms))
            } else if d.abs() <= 1e-6 * (reference.pixels[i][c].abs() as f64).max(1.0) {
                1.0
            } else {
                // No noise measured and still a difference.
                0.0
            };
            // A NaN (in a value or a variance) fails: it is no evidence of agreement.
            if p.is_nan() {
                out.min_p = 0.0;
            } else {
                out.min_p = out.min_p.min(p);
            }
            failed |= p.is_nan() || p < alpha;
        }
        if failed {
            out.failed[i] = true;
            out.failed_pixels += 1;
            out.first_failure
                .get_or_insert(((i % w) as u32, (i / w) as u32));
        }
    }
    Ok(out)
}

/// The failing pixels in red over the reference in grey (its displayed luminance, dimmed).
pub fn failure_map(result: &ZTest, reference: &Film) -> RgbImage {
    let bytes = super::metrics::display_bytes(reference);
    let mut data = Vec::with_capacity(bytes.len());
    for (i, px) in bytes.chunks_exact(3).enumerate() {
        if result.failed[i] {
            data.extend_from_slice(&[255, 32, 32]);
        } else {
            let y = (0.2126 * px[0] as f32 + 0.7152 * px[1] as f32 + 0.0722 * px[2] as f32) * 0.5;
            data.extend_from_slice(&[y as u8; 3]);
        }
    }
    RgbImage::from_raw(reference.width, reference.height, data).expect("one RGB triple per pixel")
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use rand::{Rng, SeedableRng};

    #[test]
    fn welch_degrees_of_freedom() {
        // Two equal variances from n passes each give 2(n - 1) degrees of freedom.
        assert!((welch_dof(&[(0.3, 25), (0.3, 25)]) - 48.0).abs() < 1e-9);
        assert!(welch_dof(&[(0.3, 0)]).is_infinite());
    }

    /// Images drawn around the same truth with the noise their variance layers state pass at
    /// about the stated rate; a shift of a few standard errors in one pixel fails there.
    #[test]
    fn correct_images_pass_and_a_shifted_pixel_fails() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        let (w, h) = (64u32, 64u32);
        let sigma = 0.1f32;
        let noisy = |rng: &mut rand::rngs::StdRng| {
            let mut f = Film::new(w, h);
            f.has_variance = true;
            for (p, v) in f.pixels.iter_mut().zip(&mut f.variance) {
                // Sums of 12 uniforms: close to normal, variance 1.
                let mut n = || (0..12).map(|_| rng.random::<f32>()).sum::<f32>() - 6.0;
                *p = Vec3::new(1.0 + sigma * n(), 1.0 + sigma * n(), 1.0 + sigma * n());
                *v = Vec3::splat(sigma * sigma);
            }
            f
        };
        let mut failures = 0;
        for _ in 0..20 {
            let (a, b) = (noisy(&mut rng), noisy(&mut rng));
            failures += (z_test(&a, &b, 0.05).unwrap().failed_pixels > 0) as u32;
        }
        assert!(failures <= 4, "{failures} of 20 correct pairs failed at 5%");
        let (mut a, b) = (noisy(&mut rng), noisy(&mut rng));
        a.pixels[5 * w as usize + 9].y += 12.0 * sigma;
        let r = z_test(&a, &b, 0.01).unwrap();
        assert!(r.failed[5 * w as usize + 9] && r.first_failure.is_some());
        let (mut x, mut y) = (noisy(&mut rng), noisy(&mut rng));
        x.has_variance = false;
        y.has_variance = false;
        assert!(z_test(&x, &y, 0.01).is_err());
    }
}
