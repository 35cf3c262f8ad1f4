//! The statistics behind `compare`'s numbers: means with 95% intervals over independent runs,
//! per-pixel variance across runs and the squared bias it leaves, convergence curves with
//! their fitted slope, and the time each integrator needs to reach an error.
//!
//! Every error here is the mean over pixels and channels of linear radiance. When the
//! reference carries its own per-pixel variance `v_r`, the expected squared difference to it
//! is `Var(x) + bias^2 + v_r`, so `v_r` is subtracted: the MSE reported is an unbiased
//! estimate of the error against the true image, not against the reference's noise.

use crate::render::Film;
use glam::DVec3;
use serde::Serialize;

/// Student's t quantile `t(0.975, dof)`: the half-width of a 95% interval in standard errors.
pub fn t95(dof: u32) -> f64 {
    const TABLE: [f64; 30] = [
        12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
        2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
        2.052, 2.048, 2.045, 2.042,
    ];
    match dof {
        0 => f64::INFINITY,
        1..=30 => TABLE[dof as usize - 1],
        // Within 0.002 of the exact quantile from 31 degrees of freedom on.
        _ => 1.96 + 2.5 / dof as f64,
    }
}

/// A value measured in each of several runs: their mean and the half-width of its 95%
/// interval (`None` from a single run).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Estimate {
    pub mean: f64,
    pub ci95: Option<f64>,
}

impl Estimate {
    pub fn of(values: &[f64]) -> Estimate {
        let n = values.len();
        if n == 0 {
            return Estimate {
                mean: f64::NAN,
                ci95: None,
            };
        }
        let mean = values.iter().sum::<f64>() / n as f64;
        let ci95 = (n >= 2).then(|| {
            let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
            t95(n as u32 - 1) * (var / n as f64).sqrt()
        });
        Estimate { mean, ci95 }
    }
}

/// The linear-radiance errors of an image against a reference.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct LinearError {
    /// Mean squared error, the reference's own variance subtracted when it has one.
    pub mse: f64,
    /// Relative MSE `(x - r)^2 / (r^2 + 0.01)`, corrected the same way (to first order: the
    /// weight itself is taken from the noisy reference).
    pub relmse: f64,
    /// The MSE and relMSE as measured, with the reference's noise in them.
    pub mse_raw: f64,
    pub relmse_raw: f64,
}

/// MSE and relMSE of `test` against `reference` (same size, checked by the caller).
pub fn linear_error(test: &Film, reference: &Film) -> LinearError {
    let n = (test.pixels.len() * 3) as f64;
    let (mut se, mut rel, mut noise, mut rel_noise) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for (i, (t, r)) in test.pixels.iter().zip(&reference.pixels).enumerate() {
        let v = reference.variance[i];
        for c in 0..3 {
            let (t, r) = (t[c] as f64, r[c] as f64);
            let d2 = (t - r) * (t - r);
            let w = 1.0 / (r * r + 0.01);
            se += d2;
            rel += d2 * w;
            if reference.has_variance {
                noise += v[c] as f64;
                rel_noise += v[c] as f64 * w;
            }
        }
    }
    LinearError {
        mse: (se - noise) / n,
        relmse: (rel - rel_noise) / n,
        mse_raw: se / n,
        relmse_raw: rel / n,
    }
}

/// The share of pixels whose errors [`robust_relmse`] leaves out: the largest 0.1%.
pub const OUTLIER_SHARE: f64 = 0.001;

/// relMSE with the largest [`OUTLIER_SHARE`] of the per-pixel errors left out (SeeSharp's
/// outlier-rejecting relMSE), so that a few fireflies do not rank a method: each pixel's
/// relative squared error (mean over channels, the reference's noise subtracted), the
/// largest dropped, the rest averaged.
pub fn robust_relmse(test: &Film, reference: &Film) -> f64 {
    let mut errors: Vec<f64> = test
        .pixels
        .iter()
        .zip(&reference.pixels)
        .enumerate()
        .map(|(i, (t, r))| {
            let v = reference.variance[i];
            (0..3)
                .map(|c| {
                    let (t, r) = (t[c] as f64, r[c] as f64);
                    let noise = if reference.has_variance {
                        v[c] as f64
                    } else {
                        0.0
                    };
                    ((t - r) * (t - r) - noise) / (r * r + 0.01)
                })
                .sum::<f64>()
                / 3.0
        })
        .collect();
    if errors.is_empty() {
        return 0.0;
    }
    let dropped = (errors.len() as f64 * OUTLIER_SHARE).ceil() as usize;
    let kept = errors.len().saturating_sub(dropped).max(1);
    if kept < errors.len() {
        errors.select_nth_unstable_by(kept, |a, b| a.total_cmp(b));
    }
    errors[..kept].iter().sum::<f64>() / kept as f64
}

/// The mean over pixels and channels of the reference's variance (0 when it has none).
pub fn mean_variance(film: &Film) -> f64 {
    if !film.has_variance {
        return 0.0;
    }
    let sum: f64 = film
        .variance
        .iter()
        .map(|v| v.x as f64 + v.y as f64 + v.z as f64)
        .sum();
    sum / (film.variance.len() * 3) as f64
}

/// The unbiased sample variance of `k` values from their sum and sum of squares.
fn sample_variance(sum: DVec3, sum_sq: DVec3, k: f64) -> DVec3 {
    let mean = sum / k;
    ((sum_sq / k - mean * mean) * (k / (k - 1.0))).max(DVec3::ZERO)
}

/// Per-pixel sums over independent runs of one integrator: their mean image and the
/// per-pixel variance of a single run's image.
pub struct RunImages {
    sum: Vec<DVec3>,
    sum_sq: Vec<DVec3>,
    pub runs: u32,
    width: u32,
    height: u32,
}

impl RunImages {
    pub fn new(width: u32, height: u32) -> RunImages {
        let n = width as usize * height as usize;
        RunImages {
            sum: vec![DVec3::ZERO; n],
            sum_sq: vec![DVec3::ZERO; n],
            runs: 0,
            width,
            height,
        }
    }

    pub fn add(&mut self, film: &Film) {
        for ((s, q), p) in self.sum.iter_mut().zip(&mut self.sum_sq).zip(&film.pixels) {
            let p = p.as_dvec3();
            *s += p;
            *q += p * p;
        }
        self.runs += 1;
    }

    /// The mean of the runs' images, with the variance of that mean per pixel.
    pub fn mean_film(&self) -> Film {
        let k = self.runs.max(1) as f64;
        let mut film = Film::new(self.width, self.height);
        film.has_variance = self.runs >= 2;
        film.variance_samples = self.runs;
        for (i, (s, q)) in self.sum.iter().zip(&self.sum_sq).enumerate() {
            film.pixels[i] = (*s / k).as_vec3();
            if self.runs >= 2 {
                film.variance[i] = (sample_variance(*s, *q, k) / k).as_vec3();
            }
        }
        film
    }

    /// The per-pixel variance of one run's image across the runs, averaged over pixels and
    /// channels; `None` from fewer than two runs.
    pub fn variance(&self) -> Option<f64> {
        if self.runs < 2 {
            return None;
        }
        let k = self.runs as f64;
        let mut total = 0.0;
        for (s, q) in self.sum.iter().zip(&self.sum_sq) {
            let var = sample_variance(*s, *q, k);
            total += var.x + var.y + var.z;
        }
        Some(total / (self.sum.len() * 3) as f64)
    }

    /// Squared bias against the reference: the (noise-corrected) MSE of the mean image minus
    /// what the runs' variance leaves in it, `variance / K`. Near zero (either sign) for an
    /// unbiased integrator; `None` from fewer than two runs.
    pub fn bias2(&self, reference: &Film) -> Option<f64> {
        let variance = self.variance()?;
        let mean = self.mean_film();
        let mut plain = mean.clone();
        plain.has_variance = false;
        Some(linear_error(&plain, reference).mse - variance / self.runs as f64)
    }
}

/// One point of a convergence curve: the error of the image after `spp` passes, reached
/// `time` seconds into the render (the time spent measuring excluded).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct CurvePoint {
    pub spp: u32,
    pub time: f64,
    pub mse: f64,
    pub relmse: f64,
}

/// Whether the error is recorded after pass `spp`: log-spaced, about two points per doubling
/// (1, 2, 3, 4, 6, 8, 11, 16, 23, 32, 45, 64, ...).
pub fn records(spp: u32) -> bool {
    if spp <= 4 {
        return spp >= 1;
    }
    let k = (2.0 * (spp as f64).log2()).round();
    (2f64.powf(k / 2.0)).round() as u32 == spp
}

/// The runs' curves averaged point by point. Points are matched by pass count and kept when
/// every run reached them; the runs' last points (their final images, which at equal time
/// differ in pass count) are averaged into the last point.
pub fn mean_curve(curves: &[Vec<CurvePoint>]) -> Vec<CurvePoint> {
    let Some(first) = curves.first() else {
        return Vec::new();
    };
    let average = |same: &[&CurvePoint]| {
        let k = same.len() as f64;
        CurvePoint {
            spp: (same.iter().map(|q| q.spp as f64).sum::<f64>() / k).round() as u32,
            time: same.iter().map(|q| q.time).sum::<f64>() / k,
            mse: same.iter().map(|q| q.mse).sum::<f64>() / k,
            relmse: same.iter().map(|q| q.relmse).sum::<f64>() / k,
        }
    };
    let mut out: Vec<CurvePoint> = Vec::new();
    for p in first {
        let same: Vec<&CurvePoint> = curves
            .iter()
            .filter_map(|c| c.iter().find(|q| q.spp == p.spp))
            .collect();
        if same.len() == curves.len() {
            out.push(average(&same));
        }
    }
    let lasts: Vec<&CurvePoint> = curves.iter().filter_map(|c| c.last()).collect();
    if lasts.len() == curves.len() {
        let last = average(&lasts);
        if out
            .last()
            .is_none_or(|p| p.spp < last.spp && p.time < last.time)
        {
            out.push(last);
        }
    }
    out
}

/// The error a curve is read by: MSE or relMSE.
pub type Metric = fn(&CurvePoint) -> f64;
pub const MSE: Metric = |p| p.mse;
pub const RELMSE: Metric = |p| p.relmse;

/// The slope of log(error) against log(time) by least squares, over the points with a
/// positive error after the first pass (which carries start-up work); `None` from fewer than
/// three. About -1 for an unbiased estimator, flatter for a consistent one.
pub fn fitted_slope(curve: &[CurvePoint], metric: Metric) -> Option<f64> {
    let pts: Vec<(f64, f64)> = curve
        .iter()
        .filter(|p| p.spp >= 2 && metric(p) > 0.0 && p.time > 0.0)
        .map(|p| (p.time.ln(), metric(p).ln()))
        .collect();
    if pts.len() < 3 {
        return None;
    }
    let n = pts.len() as f64;
    let (mx, my) = pts
        .iter()
        .fold((0.0, 0.0), |(a, b), (x, y)| (a + x / n, b + y / n));
    let sxx: f64 = pts.iter().map(|(x, _)| (x - mx).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|(x, y)| (x - mx) * (y - my)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

/// When a curve first reaches `target` MSE: interpolated on log-log axes between the two
/// points around it, or, past the curve's end, extrapolated along the fitted slope (the flag
/// says so). `None` when it is not reached and does not fall (slope above -0.1).
pub fn time_to_reach(curve: &[CurvePoint], target: f64) -> Option<(f64, bool)> {
    if target <= 0.0 || !target.is_finite() {
        return None;
    }
    for (i, p) in curve.iter().enumerate() {
        if p.mse <= target {
            let Some(q) = i.checked_sub(1).map(|j| curve[j]) else {
                return Some((p.time, false));
            };
            if q.mse <= 0.0 || p.mse <= 0.0 || q.time <= 0.0 {
                return Some((p.time, false));
            }
            let f = (target.ln() - q.mse.ln()) / (p.mse.ln() - q.mse.ln());
            return Some(((q.time.ln() + f * (p.time.ln() - q.time.ln())).exp(), false));
        }
    }
    let last = curve.last()?;
    let slope = fitted_slope(curve, MSE)?;
    // A curve flatter than this is not falling (a biased estimator's floor): it never gets there.
    (slope < -0.1 && last.mse > 0.0)
        .then(|| (last.time * (target / last.mse).powf(1.0 / slope), true))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One firefly in a thousand pixels: the robust relMSE leaves it out and sees the rest
    /// exactly; without outliers it equals the plain relMSE.
    #[test]
    fn robust_relmse_leaves_out_the_worst_thousandth() {
        let mut reference = Film::new(100, 10);
        reference.pixels.fill(glam::Vec3::splat(1.0));
        let mut test = reference.clone();
        test.pixels.fill(glam::Vec3::splat(1.1));
        let plain = linear_error(&test, &reference).relmse;
        assert!((robust_relmse(&test, &reference) - plain).abs() < 1e-12);
        test.pixels[17] = glam::Vec3::splat(1e4);
        assert!(linear_error(&test, &reference).relmse > 1e3 * plain);
        assert!((robust_relmse(&test, &reference) - plain).abs() < 1e-9);
    }
    use glam::Vec3;

    #[test]
    fn intervals_follow_students_t() {
        let e = Estimate::of(&[1.0, 2.0, 3.0]);
        assert_eq!(e.mean, 2.0);
        // s = 1, n = 3: 4.303 / sqrt(3).
        assert!((e.ci95.unwrap() - 4.303 / 3f64.sqrt()).abs() < 1e-9);
        assert_eq!(Estimate::of(&[5.0]).ci95, None);
        assert!((t95(40) - 2.021).abs() < 0.002 && (t95(120) - 1.980).abs() < 0.002);
    }

    #[test]
    fn the_references_noise_is_subtracted() {
        let mut r = Film::new(2, 1);
        r.pixels = vec![Vec3::splat(1.0); 2];
        let mut t = r.clone();
        t.pixels[0] = Vec3::splat(1.5);
        // Raw: one pixel off by 0.5 in three channels out of six values.
        assert!((linear_error(&t, &r).mse - 0.125).abs() < 1e-9);
        r.variance = vec![Vec3::splat(0.02); 2];
        r.has_variance = true;
        let e = linear_error(&t, &r);
        assert!((e.mse_raw - 0.125).abs() < 1e-9 && (e.mse - 0.105).abs() < 1e-7);
    }

    #[test]
    fn log_spaced_points() {
        let v: Vec<u32> = (1..=70).filter(|&n| records(n)).collect();
        assert_eq!(v, [1, 2, 3, 4, 6, 8, 11, 16, 23, 32, 45, 64]);
    }

    #[test]
    fn slope_and_time_to_target_of_a_power_law() {
        // MSE = 0.5 / t exactly.
        let curve: Vec<CurvePoint> = (1..=8)
            .map(|k| {
                let t = k as f64 * 0.25;
                CurvePoint {
                    spp: k,
                    time: t,
                    mse: 0.5 / t,
                    relmse: 0.0,
                }
            })
            .collect();
        assert!((fitted_slope(&curve, MSE).unwrap() + 1.0).abs() < 1e-9);
        // Reached inside the curve: 0.5 / t = 0.4 at t = 1.25.
        let (t, extrapolated) = time_to_reach(&curve, 0.4).unwrap();
        assert!((t - 1.25).abs() < 1e-9 && !extrapolated);
        // Past its end (t = 2, MSE 0.25): MSE 0.05 at t = 10, extrapolated.
        let (t, extrapolated) = time_to_reach(&curve, 0.05).unwrap();
        assert!((t - 10.0).abs() < 1e-6 && extrapolated);
    }
}
