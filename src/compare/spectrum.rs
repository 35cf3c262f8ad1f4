//! The error spectrum ensemble of Celarek et al. 2019 ("Quantifying the Error of Light
//! Transport Algorithms"): the radially averaged power spectrum of a render's error image
//! (its luminance less the reference's), averaged over independent runs. Error a sampler
//! spreads as white noise has a flat spectrum; one that pushes it to high frequencies (blue
//! noise: `zsobol`'s ordering of pixels) has less power at low frequencies, where the eye
//! sees it; structured artefacts show as peaks.
//!
//! Frequencies are in cycles per pixel, in [`BINS`] rings from 0 to 1/2 (the Nyquist limit
//! along an axis); the constant term (the mean error) is left out.

use crate::output::Film;
use rustfft::{num_complex::Complex, FftPlanner};

/// Rings of the radial average.
pub const BINS: usize = 32;

/// Each ring's centre frequency, cycles per pixel.
pub fn frequencies() -> Vec<f64> {
    (0..BINS)
        .map(|k| (k as f64 + 0.5) * 0.5 / BINS as f64)
        .collect()
}

/// The sum of the runs' radially averaged spectra.
pub struct Spectra {
    width: usize,
    height: usize,
    sum: Vec<f64>,
    runs: u32,
}

/// Rec. 709 luminance.
fn luminance(c: glam::Vec3) -> f64 {
    0.2126 * c.x as f64 + 0.7152 * c.y as f64 + 0.0722 * c.z as f64
}

impl Spectra {
    pub fn new(width: u32, height: u32) -> Spectra {
        Spectra {
            width: width as usize,
            height: height as usize,
            sum: vec![0.0; BINS],
            runs: 0,
        }
    }

    /// Adds the spectrum of `run`'s error against `reference` (both of the spectra's size).
    pub fn add(&mut self, run: &Film, reference: &Film) {
        let (w, h) = (self.width, self.height);
        let mut data: Vec<Complex<f64>> = run
            .pixels
            .iter()
            .zip(&reference.pixels)
            .map(|(t, r)| {
                let e = luminance(*t) - luminance(*r);
                Complex::new(if e.is_finite() { e } else { 0.0 }, 0.0)
            })
            .collect();
        debug_assert_eq!(data.len(), w * h);
        let mut planner = FftPlanner::new();
        // Rows, then columns (through a transposed copy).
        let rows = planner.plan_fft_forward(w);
        for row in data.chunks_exact_mut(w) {
            rows.process(row);
        }
        let mut columns: Vec<Complex<f64>> = vec![Complex::new(0.0, 0.0); w * h];
        for y in 0..h {
            for x in 0..w {
                columns[x * h + y] = data[y * w + x];
            }
        }
        let cols = planner.plan_fft_forward(h);
        for column in columns.chunks_exact_mut(h) {
            cols.process(column);
        }
        let mut power = [0.0f64; BINS];
        let mut count = [0u32; BINS];
        let norm = 1.0 / (w * h) as f64;
        for x in 0..w {
            let fx = x.min(w - x) as f64 / w as f64;
            for y in 0..h {
                if x == 0 && y == 0 {
                    continue;
                }
                let fy = y.min(h - y) as f64 / h as f64;
                let f = (fx * fx + fy * fy).sqrt();
                let bin = (f / 0.5 * BINS as f64) as usize;
                if bin < BINS {
                    power[bin] += columns[x * h + y].norm_sqr() * norm;
                    count[bin] += 1;
                }
            }
        }
        for k in 0..BINS {
            // A ring no frequency of this image falls in (the lowest, below one cycle per
            // image) has no power to report: NaN, `null` in metrics.json.
            self.sum[k] += if count[k] > 0 {
                power[k] / count[k] as f64
            } else {
                f64::NAN
            };
        }
        self.runs += 1;
    }

    /// The mean over the runs of each ring's power (NaN for a ring the image has no
    /// frequency in).
    pub fn mean(&self) -> Vec<f64> {
        let n = self.runs.max(1) as f64;
        self.sum.iter().map(|s| s / n).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn film(w: u32, h: u32, mut f: impl FnMut(u32, u32) -> f32) -> Film {
        let mut film = Film::new(w, h);
        for y in 0..h {
            for x in 0..w {
                film.pixels[(y * w + x) as usize] = glam::Vec3::splat(f(x, y));
            }
        }
        film
    }

    /// White noise has a flat spectrum whose level is its variance (Parseval); a stripe
    /// pattern of period 4 pixels puts its power at a quarter cycle per pixel.
    #[test]
    fn white_noise_is_flat_and_a_stripe_pattern_peaks_at_its_frequency() {
        let (w, h) = (64u32, 48u32);
        let reference = film(w, h, |_, _| 1.0);
        let mut spectra = Spectra::new(w, h);
        let mut state = 12345u64;
        for _ in 0..20 {
            let noisy = film(w, h, |_, _| {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                1.0 + ((state >> 40) as f32 / (1u64 << 24) as f32 - 0.5)
            });
            spectra.add(&noisy, &reference);
        }
        let mean = spectra.mean();
        // Uniform on [-1/2, 1/2]: variance 1/12.
        for (k, p) in mean.iter().enumerate().skip(2).filter(|(_, p)| !p.is_nan()) {
            assert!((p - 1.0 / 12.0).abs() < 0.2 / 12.0, "ring {k}: {p}");
        }
        let mut stripes = Spectra::new(w, h);
        stripes.add(
            &film(w, h, |x, _| [0.0, 1.0, 2.0, 1.0][x as usize % 4]),
            &reference,
        );
        let power = stripes.mean();
        let peak = power
            .iter()
            .enumerate()
            .filter(|(_, p)| !p.is_nan())
            .max_by(|a, b| a.1.total_cmp(b.1))
            .unwrap()
            .0;
        assert!(
            (frequencies()[peak] - 0.25).abs() < 0.5 / BINS as f64,
            "{peak}"
        );
    }
}
