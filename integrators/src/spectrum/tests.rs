//! The spectral machinery against closed forms: the wavelength density, the upsampling's
//! round trip, the film's estimator.

use super::*;
use crate::random::keyed_rng;
use crate::testing::chi2::assert_chi2_discrete;
use rand::Rng;

/// `integral_a^b f`, Simpson's rule on `n` (even) steps.
fn integrate(a: f64, b: f64, n: usize, f: impl Fn(f64) -> f64) -> f64 {
    let h = (b - a) / n as f64;
    let mut sum = f(a) + f(b);
    for i in 1..n {
        sum += f(a + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
    }
    sum * h / 3.0
}

/// The linear sRGB of spectrum `s` (a function of nm), integrated finely.
fn srgb_of(s: impl Fn(f32) -> f32) -> Rgb {
    let mut xyz = [0.0f64; 3];
    for (c, x) in xyz.iter_mut().enumerate() {
        *x = integrate(360.0, 830.0, 4700, |nm| {
            (s(nm as f32) * cie::xyz_bar(nm as f32)[c]) as f64
        }) / cie::Y_INTEGRAL;
    }
    xyz_to_srgb(Vec3A::from(xyz.map(|c| c as f32)))
}

#[test]
fn the_visible_density_integrates_to_one_and_its_sampling_inverts_it() {
    let total = integrate(360.0, 830.0, 4700, |nm| visible_pdf(nm as f32) as f64);
    assert!((total - 1.0).abs() < 1e-4, "{total}");
    // The inverse CDF, against the CDF tanh(a (l - 538)) in closed form.
    let cdf = |nm: f64| {
        let t = |x: f64| (0.0072 * (x - 538.0)).tanh();
        (t(nm) - t(360.0)) / (t(830.0) - t(360.0))
    };
    for u in [0.001f32, 0.1, 0.37, 0.5, 0.9, 0.999] {
        let nm = sample_visible(u);
        assert!((cdf(nm as f64) - u as f64).abs() < 2e-4, "u {u}: {nm}");
    }
}

#[test]
fn chi2_wavelengths_follow_the_visible_density() {
    const BINS: usize = 47;
    const SAMPLES: usize = 400_000;
    let mut observed = vec![0u64; BINS];
    let mut rng = keyed_rng(51, 0);
    let bin = |nm: f32| (((nm - LAMBDA_MIN) / 10.0) as usize).min(BINS - 1);
    for _ in 0..SAMPLES / N {
        let Wavelengths::Sampled { nm, .. } = Wavelengths::sample(rng.random::<f32>()) else {
            unreachable!()
        };
        for i in 0..N {
            observed[bin(nm[i])] += 1;
        }
    }
    let expected: Vec<f64> = (0..BINS)
        .map(|b| {
            let a = 360.0 + 10.0 * b as f64;
            integrate(a, a + 10.0, 100, |nm| visible_pdf(nm as f32) as f64) * SAMPLES as f64
        })
        .collect();
    assert_chi2_discrete("visible wavelengths", &observed, &expected, SAMPLES);
}

#[test]
fn every_reflectance_comes_back_as_its_rgb() {
    // Jakob & Hanika fit each colour's spectrum so that under D65 it is the colour; the
    // table is read trilinearly between its fitted nodes. The worst error over the cube:
    let mut worst = 0.0f32;
    let steps = 9;
    for r in 0..=steps {
        for g in 0..=steps {
            for b in 0..=steps {
                let rgb = Vec3A::new(r as f32, g as f32, b as f32) / steps as f32;
                let s = RgbSpectrum::albedo(rgb);
                let back = srgb_of(|nm| s.at(nm) * upsample::d65(nm));
                worst = worst.max((back - rgb).abs().max_element());
                for nm in [360.0, 450.0, 550.0, 700.0, 830.0] {
                    let v = s.at(nm);
                    assert!((0.0..=1.0).contains(&v), "{rgb}: {v} at {nm} nm");
                }
            }
        }
    }
    println!("worst round-trip error of a reflectance: {worst:.2e}");
    assert!(worst < 1e-2, "{worst}");
}

#[test]
fn greys_are_constant_and_unbounded_values_scale() {
    for v in [0.0, 0.18, 0.5, 1.0] {
        let s = RgbSpectrum::albedo(Vec3A::splat(v));
        assert_eq!(s.at(400.0), v);
        assert_eq!(s.at(700.0), v);
    }
    assert_eq!(RgbSpectrum::unbounded(Vec3A::splat(3.5)).at(512.0), 3.5);
    let eta = Vec3A::new(0.2, 0.9, 1.6);
    let s = RgbSpectrum::unbounded(eta);
    let back = srgb_of(|nm| s.at(nm) * upsample::d65(nm));
    assert!((back - eta).abs().max_element() < 0.02, "{back}");
    for nm in [360.0, 500.0, 830.0] {
        assert!(s.at(nm) <= 2.0 * 1.6 && s.at(nm) >= 0.0);
    }
}

#[test]
fn white_light_is_white_and_coloured_light_its_colour() {
    for rgb in [
        Vec3A::ONE,
        Vec3A::new(4.0, 4.0, 4.0),
        Vec3A::new(10.0, 5.0, 1.0),
        Vec3A::new(0.1, 0.2, 0.9),
    ] {
        let s = RgbSpectrum::illuminant(rgb);
        let back = srgb_of(|nm| s.at(nm));
        let error = ((back - rgb).abs() / rgb.max_element()).max_element();
        assert!(error < 0.01, "{rgb} came back as {back}");
    }
    // The white point exactly: D65 of luminance 1.
    let y = integrate(360.0, 830.0, 4700, |nm| {
        (upsample::d65(nm as f32) * cie::xyz_bar(nm as f32)[1]) as f64
    }) / cie::Y_INTEGRAL;
    assert!((y - 1.0).abs() < 1e-3, "{y}");
}

/// The film's estimator: the mean of `to_rgb` over sampled wavelengths is the spectrum's
/// colour, with the secondary wavelengths or without them.
#[test]
fn the_films_estimate_is_unbiased_with_and_without_the_secondary_wavelengths() {
    let rgb = Vec3A::new(0.9, 0.4, 0.1);
    let s = RgbSpectrum::illuminant(rgb);
    for terminate in [false, true] {
        let n = 200_000;
        let mut sum = Vec3A::ZERO;
        let mut sum2 = Vec3A::ZERO;
        let mut rng = keyed_rng(52, terminate as u64);
        for _ in 0..n {
            let mut w = Wavelengths::sample(rng.random::<f32>());
            if terminate {
                w.terminate_secondary();
                w.terminate_secondary();
            }
            let Wavelengths::Sampled { nm, .. } = w else {
                unreachable!()
            };
            let x = w.to_rgb(s.eval(nm));
            sum += x;
            sum2 += x * x;
        }
        let mean = sum / n as f32;
        let sd = ((sum2 / n as f32 - mean * mean) / n as f32)
            .max(Vec3A::ZERO)
            .sqrt();
        let expected = srgb_of(|nm| s.at(nm));
        for c in 0..3 {
            assert!(
                (mean[c] - expected[c]).abs() < 5.0 * sd[c] + 1e-4,
                "terminate {terminate}: {mean} vs {expected} (sd {sd})"
            );
        }
    }
}

#[test]
fn rgb_mode_is_the_identity() {
    let w = Wavelengths::Rgb;
    let c = Vec3A::new(0.3, 2.0, 0.0);
    // RGB's channels, the red one again in the fourth lane.
    let s = glam::Vec4::new(0.3, 2.0, 0.0, 0.3);
    assert_eq!(of_rgb(c), s);
    assert_eq!(w.reflectance(c), s);
    assert_eq!(w.illuminant(c), s);
    assert_eq!(w.unbounded(c), s);
    assert_eq!(w.to_rgb(s), c);
    assert_eq!(w.map(c, |_| 7.0), s);
    assert_eq!((w.lanes(), w.average(s)), (3, (0.3 + 2.0 + 0.0) / 3.0));
    assert!((xyz_to_srgb(srgb_to_xyz(c)) - c).abs().max_element() < 1e-5);
    // The constant matrix is the table's, the inverse its inverse.
    let table = glam::DMat3::from_cols_array_2d(&cie::XYZ_TO_SRGB).transpose();
    let x = Vec3A::new(0.3, 0.5, 0.2);
    assert!(
        (xyz_to_srgb(x) - (table * x.as_dvec3()).as_vec3a())
            .abs()
            .max_element()
            < 1e-6
    );
    assert!(
        (srgb_to_xyz(x) - (table.inverse() * x.as_dvec3()).as_vec3a())
            .abs()
            .max_element()
            < 1e-5
    );
}
