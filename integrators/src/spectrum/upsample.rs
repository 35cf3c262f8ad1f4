//! RGB to spectra (Jakob & Hanika 2019, "A Low-Dimensional Function Space for Efficient
//! Spectral Upsampling"): a colour becomes the smooth spectrum `s(l) = S(c0 l^2 + c1 l + c2)`,
//! `S(x) = 1/2 + x / (2 sqrt(1 + x^2))`, whose sRGB under D65 is the colour. The coefficients
//! come from a table over the sRGB cube fitted at build time (`build.rs`, the `rgb2spec`
//! crate), looked up trilinearly, as pbrt-v4 and Mitsuba 3 do.
//!
//! Three uses, as the peers have them:
//! * a reflectance ([`RgbSpectrum::albedo`]) is the colour clamped to `[0, 1]`, upsampled;
//!   its spectrum stays within `[0, 1]`;
//! * an unbounded value ([`RgbSpectrum::unbounded`]: an IOR, a medium's coefficients) is
//!   divided by twice its largest channel, upsampled and scaled back (pbrt-v4's
//!   `RGBUnboundedSpectrum`), so it never exceeds twice that channel;
//! * an emitter's colour ([`RgbSpectrum::illuminant`]) is the unbounded spectrum times the
//!   sRGB white, D65, normalised to luminance 1: a white `(1, 1, 1)` emitter is D65 of
//!   luminance 1, which the film turns back into `(1, 1, 1)`.
//!
//! Greys are constant spectra, exactly (a white furnace is as white in spectral mode).

use super::cie;
use crate::Rgb;
use glam::{Vec3A, Vec4};
use std::sync::OnceLock;

/// The fitted table (see `build.rs`).
static TABLE_BYTES: &[u8] = include_bytes!(concat!(
    env!("OUT_DIR"),
    "/srgb_rgb2spec_",
    env!("RAYLAB_RGB2SPEC_RESOLUTION"),
    ".bin"
));

fn table() -> &'static rgb2spec::RGB2Spec {
    static TABLE: OnceLock<rgb2spec::RGB2Spec> = OnceLock::new();
    TABLE.get_or_init(|| {
        rgb2spec::RGB2Spec::from_reader(&mut &TABLE_BYTES[..])
            .expect("build.rs writes a table rgb2spec reads")
    })
}

/// A colour as a spectrum: constant (a grey), or a scaled sigmoid of a quadratic in the
/// wavelength (nm), times D65 for an emitter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RgbSpectrum {
    /// The quadratic's coefficients, highest power first; all zero for a grey.
    coefficients: [f32; 3],
    /// The constant a grey is; the scale of a sigmoid.
    scale: f32,
    /// A grey (`scale` itself), not a sigmoid.
    constant: bool,
    /// Times the normalised D65.
    illuminant: bool,
}

impl RgbSpectrum {
    /// The spectrum of reflectance `rgb` (each channel clamped to `[0, 1]`).
    pub fn albedo(rgb: Rgb) -> RgbSpectrum {
        let rgb = rgb.clamp(Vec3A::ZERO, Vec3A::ONE);
        if rgb.x == rgb.y && rgb.y == rgb.z {
            return RgbSpectrum::constant(rgb.x);
        }
        RgbSpectrum {
            coefficients: table().fetch(rgb.to_array()),
            scale: 1.0,
            constant: false,
            illuminant: false,
        }
    }

    /// The spectrum of a non-negative unbounded value `rgb` (negative channels count as 0).
    pub fn unbounded(rgb: Rgb) -> RgbSpectrum {
        let rgb = rgb.max(Vec3A::ZERO);
        let m = rgb.max_element();
        if rgb.x == rgb.y && rgb.y == rgb.z || m.is_nan() || m <= 0.0 {
            return RgbSpectrum::constant(if m.is_nan() { 0.0 } else { m });
        }
        let scale = 2.0 * m;
        RgbSpectrum {
            coefficients: table().fetch((rgb / scale).to_array()),
            scale,
            constant: false,
            illuminant: false,
        }
    }

    /// The spectrum of an emitter of colour `rgb`: [`RgbSpectrum::unbounded`] times D65 of
    /// luminance 1.
    pub fn illuminant(rgb: Rgb) -> RgbSpectrum {
        RgbSpectrum {
            illuminant: true,
            ..RgbSpectrum::unbounded(rgb)
        }
    }

    fn constant(v: f32) -> RgbSpectrum {
        RgbSpectrum {
            coefficients: [0.0; 3],
            scale: v,
            constant: true,
            illuminant: false,
        }
    }

    /// The spectrum at the wavelengths `nm` (one per lane).
    #[inline]
    pub fn eval(&self, nm: Vec4) -> Vec4 {
        let s = if self.constant {
            Vec4::splat(self.scale)
        } else {
            let [c0, c1, c2] = self.coefficients.map(Vec4::splat);
            let x = (c0 * nm + c1) * nm + c2;
            let sigmoid = Vec4::splat(0.5) + 0.5 * x / (Vec4::ONE + x * x).sqrt();
            // An infinite polynomial (a channel at exactly 0 or 1) is a step.
            let sigmoid = Vec4::select(x.is_finite_mask(), sigmoid, x.signum().max(Vec4::ZERO));
            sigmoid * self.scale
        };
        if self.illuminant {
            s * Vec4::new(d65(nm.x), d65(nm.y), d65(nm.z), d65(nm.w))
        } else {
            s
        }
    }

    /// A colour's sigmoid at `nm`, over twice its largest channel, and that factor (Mitsuba
    /// 3's split of an emitter's texel; zero for black).
    pub fn sigmoid_and_scale(rgb: Rgb, nm: Vec4) -> (Vec4, f32) {
        let rgb = rgb.max(Vec3A::ZERO);
        let m = rgb.max_element();
        if m.is_nan() || m <= 0.0 {
            return (Vec4::ZERO, 0.0);
        }
        (RgbSpectrum::albedo(rgb / (2.0 * m)).eval(nm), 2.0 * m)
    }

    /// The spectrum at one wavelength.
    pub fn at(&self, nm: f32) -> f32 {
        self.eval(Vec4::splat(nm)).x
    }
}

/// D65 at `nm`, normalised to luminance 1 (`Y` of [`cie::Y_INTEGRAL`]).
#[inline]
pub fn d65(nm: f32) -> f32 {
    cie::at(&cie::D65, nm) * d65_normalisation()
}

/// `1 / Y` of the tabulated D65: its inner product with y-bar, both linear between their
/// samples (the product integrated exactly, a quadratic on each 5 nm step), over the integral
/// of y-bar.
fn d65_normalisation() -> f32 {
    static SCALE: OnceLock<f32> = OnceLock::new();
    *SCALE.get_or_init(|| {
        let mut sum = 0.0f64;
        for i in 0..94 {
            let (d0, d1) = (cie::D65[i] as f64, cie::D65[i + 1] as f64);
            let (y0, y1) = (cie::Y[i] as f64, cie::Y[i + 1] as f64);
            // The integral over one step of (d0 + (d1-d0) t)(y0 + (y1-y0) t).
            sum += cie::STEP * (d0 * y0 / 3.0 + d1 * y1 / 3.0 + (d0 * y1 + d1 * y0) / 6.0);
        }
        (cie::Y_INTEGRAL / sum) as f32
    })
}
