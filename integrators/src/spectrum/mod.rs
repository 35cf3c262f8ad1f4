//! Spectral rendering: the wavelengths a camera sample carries, and colours as spectra at
//! them (pbrt-v4's `SampledWavelengths`, Mitsuba 3's spectral variants).
//!
//! A [`Spectrum`] has four lanes. In RGB mode ([`Wavelengths::Rgb`], the default) they are
//! linear sRGB's channels, the red one repeated in the fourth ([`of_rgb`]), and every
//! conversion here is the identity on the channels, so RGB renders are untouched by
//! construction. In spectral mode ([`Wavelengths::sample`]) they are the values
//! at [`N`] wavelengths: the first (the hero, Wilkie et al. 2014) drawn in proportion to the
//! visible-light density pbrt-v4 and Mitsuba 3 use, the others at the same primary sample
//! shifted by `1/N`, so the three are stratified over the visible range. Every BSDF, light and
//! medium then evaluates its colours at those wavelengths ([`Wavelengths::reflectance`],
//! [`Wavelengths::illuminant`], [`Wavelengths::unbounded`], or a spectrum given by
//! wavelength through [`Wavelengths::map`]), and the film turns the sample's spectrum into
//! XYZ and linear sRGB ([`Wavelengths::to_rgb`]).
//!
//! Four wavelengths, as pbrt-v4 and Mitsuba 3 carry: both modes share one code path through
//! every BSDF, light, medium and integrator, the RGB mode's fourth lane a copy of its first.
//!
//! A surface whose index of refraction varies with wavelength bends each wavelength its own
//! way: there only the hero can go on ([`Wavelengths::terminate_secondary`]), as in pbrt-v4.

pub mod cie;
pub mod curve;
pub mod named;
pub mod upsample;

use crate::{Rgb, Spectrum};
use glam::{Vec3A, Vec4};
pub use upsample::RgbSpectrum;

/// The wavelengths a spectral sample carries.
pub const N: usize = 4;

/// The colour `rgb` as RGB mode's [`Spectrum`]: its channels, the red one again in the fourth
/// lane (so that every lane-by-lane operation, division included, keeps the fourth a copy).
#[inline]
pub fn of_rgb(rgb: Rgb) -> Spectrum {
    Vec4::new(rgb.x, rgb.y, rgb.z, rgb.x)
}

/// The colour `(r, g, b)` as RGB mode's [`Spectrum`] ([`of_rgb`]).
#[inline]
pub const fn rgb(r: f32, g: f32, b: f32) -> Spectrum {
    Vec4::new(r, g, b, r)
}

/// The average of the first `lanes` lanes of `s` (3: RGB's channels; 4: every wavelength).
#[inline]
pub fn average(s: Spectrum, lanes: usize) -> f32 {
    if lanes == N {
        (s.x + s.y + s.z + s.w) / N as f32
    } else {
        (s.x + s.y + s.z) / 3.0
    }
}

/// RGB mode's [`Spectrum`] as the colour it holds: its first three lanes.
#[inline]
pub fn rgb_of(s: Spectrum) -> Rgb {
    Vec3A::new(s.x, s.y, s.z)
}

/// The visible range sampled, nm (the CIE tables' range).
pub const LAMBDA_MIN: f32 = 360.0;
pub const LAMBDA_MAX: f32 = 830.0;

/// What the lanes of a sample's [`Spectrum`] mean.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum Wavelengths {
    /// Linear sRGB's three channels.
    #[default]
    Rgb,
    /// Four wavelengths (nm) and the density each was drawn with (per nm, already divided
    /// by nothing: the film averages over the lanes). A lane whose density is 0 was
    /// terminated and carries nothing.
    Sampled { nm: Vec4, pdf: Vec4 },
}

/// pbrt-v4's density over visible wavelengths, `0.0039398042 / cosh^2(0.0072 (l - 538))` on
/// 360-830 nm (Radziszewski et al. 2009's importance of the CIE observer).
#[inline]
pub fn visible_pdf(nm: f32) -> f32 {
    if !(LAMBDA_MIN..=LAMBDA_MAX).contains(&nm) {
        return 0.0;
    }
    let c = libm::coshf(0.0072 * (nm - 538.0));
    0.003_939_804 / (c * c)
}

/// The inverse of [`visible_pdf`]'s distribution at `u` in `[0, 1)`.
#[inline]
pub fn sample_visible(u: f32) -> f32 {
    (538.0 - 138.888_89 * libm::atanhf(0.856_910_6 - 1.827_502 * u)).clamp(LAMBDA_MIN, LAMBDA_MAX)
}

impl Wavelengths {
    /// Wavelengths for the primary sample `u`: the hero at `u`, the others at `u + i/N`
    /// (mod 1), each drawn from [`visible_pdf`].
    pub fn sample(u: f32) -> Wavelengths {
        let mut nm = [0.0; N];
        let mut pdf = [0.0; N];
        for i in 0..N {
            let ui = (u + i as f32 / N as f32).fract();
            nm[i] = sample_visible(ui);
            pdf[i] = visible_pdf(nm[i]);
        }
        Wavelengths::Sampled {
            nm: Vec4::from(nm),
            pdf: Vec4::from(pdf),
        }
    }

    /// The wavelengths of pass `pass` of a render of seed `seed`: what the integrators that
    /// share light paths between pixels carry through a whole pass.
    pub fn for_pass(seed: u64, pass: u32) -> Wavelengths {
        let key =
            crate::random::mix64(seed ^ 0x5350_4543_5452_414c ^ crate::random::mix64(pass as u64));
        Wavelengths::sample((key >> 40) as f32 / (1u64 << 24) as f32)
    }

    /// The wavelengths a pass carries (see [`crate::PassContext::lambda`]): RGB's channels,
    /// or in spectral mode [`Wavelengths::for_pass`], only the hero in a scene that disperses
    /// (its photons and the camera paths that gather them must agree).
    pub fn of_pass(spectral: bool, seed: u64, pass: u32, disperses: bool) -> Wavelengths {
        if !spectral {
            return Wavelengths::Rgb;
        }
        let mut lambda = Wavelengths::for_pass(seed, pass);
        if disperses {
            lambda.terminate_secondary();
        }
        lambda
    }

    /// True in spectral mode.
    #[inline]
    pub fn is_spectral(&self) -> bool {
        matches!(self, Wavelengths::Sampled { .. })
    }

    /// The hero wavelength (nm); `None` in RGB mode.
    #[inline]
    pub fn hero(&self) -> Option<f32> {
        match self {
            Wavelengths::Rgb => None,
            Wavelengths::Sampled { nm, .. } => Some(nm.x),
        }
    }

    /// True when only the hero goes on.
    #[inline]
    pub fn secondary_terminated(&self) -> bool {
        matches!(self, Wavelengths::Sampled { pdf, .. } if pdf.y == 0.0)
    }

    /// Lets only the hero go on (a dispersive refraction): the other lanes carry nothing from
    /// now on and the hero counts for all [`N`] (pbrt-v4's `TerminateSecondary`). Once only.
    pub fn terminate_secondary(&mut self) {
        if let Wavelengths::Sampled { pdf, .. } = self {
            if pdf.y != 0.0 {
                *pdf = Vec4::new(pdf.x / N as f32, 0.0, 0.0, 0.0);
            }
        }
    }

    /// How many lanes of a [`Spectrum`] hold values: RGB's 3 channels, or [`N`] wavelengths.
    #[inline]
    pub fn lanes(&self) -> usize {
        match self {
            Wavelengths::Rgb => 3,
            Wavelengths::Sampled { .. } => N,
        }
    }

    /// The average of `s` over its lanes (RGB's three channels).
    #[inline]
    pub fn average(&self, s: Spectrum) -> f32 {
        average(s, self.lanes())
    }

    /// A brightness of `s` for choosing where to spend samples (never for a value): RGB's
    /// luminance, or the average over the wavelengths (so it is zero only where every lane
    /// is).
    #[inline]
    pub fn brightness(&self, s: Spectrum) -> f32 {
        match self {
            Wavelengths::Rgb => crate::luminance(rgb_of(s)),
            Wavelengths::Sampled { .. } => self.average(s),
        }
    }

    /// A reflectance or transmittance given as a colour.
    #[inline]
    pub fn reflectance(&self, rgb: Rgb) -> Spectrum {
        match self {
            Wavelengths::Rgb => of_rgb(rgb),
            Wavelengths::Sampled { nm, .. } => RgbSpectrum::albedo(rgb).eval(*nm),
        }
    }

    /// An unbounded non-negative value given as a colour (an IOR, a medium's coefficient).
    #[inline]
    pub fn unbounded(&self, rgb: Rgb) -> Spectrum {
        match self {
            Wavelengths::Rgb => of_rgb(rgb),
            Wavelengths::Sampled { nm, .. } => RgbSpectrum::unbounded(rgb).eval(*nm),
        }
    }

    /// Emitted radiance (or intensity, irradiance) given as a colour.
    #[inline]
    pub fn illuminant(&self, rgb: Rgb) -> Spectrum {
        match self {
            Wavelengths::Rgb => of_rgb(rgb),
            Wavelengths::Sampled { nm, .. } => RgbSpectrum::illuminant(rgb).eval(*nm),
        }
    }

    /// A spectrum known by wavelength, `f(nm)`, at these wavelengths; `rgb` in RGB mode (the
    /// colour it was made into).
    #[inline]
    pub fn map(&self, rgb: Rgb, f: impl Fn(f32) -> f32) -> Spectrum {
        match self {
            Wavelengths::Rgb => of_rgb(rgb),
            Wavelengths::Sampled { nm, .. } => Vec4::new(f(nm.x), f(nm.y), f(nm.z), f(nm.w)),
        }
    }

    /// The sample's spectrum `s` as CIE XYZ: `(1/N) sum_i s_i xyz_bar(l_i) / pdf_i`, over the
    /// integral of y-bar. In RGB mode, `s` taken as linear sRGB.
    pub fn to_xyz(&self, s: Spectrum) -> Vec3A {
        match self {
            Wavelengths::Rgb => srgb_to_xyz(rgb_of(s)),
            Wavelengths::Sampled { nm, pdf } => {
                let mut xyz = Vec3A::ZERO;
                for i in 0..N {
                    if pdf[i] > 0.0 && s[i] != 0.0 {
                        let bar = Vec3A::from(cie::xyz_bar(nm[i]));
                        xyz += bar * (s[i] / pdf[i]);
                    }
                }
                xyz / (N as f32 * cie::Y_INTEGRAL as f32)
            }
        }
    }

    /// The sample's spectrum `s` as linear sRGB (what the film adds up); `s` itself in RGB
    /// mode.
    #[inline]
    pub fn to_rgb(&self, s: Spectrum) -> Rgb {
        match self {
            Wavelengths::Rgb => rgb_of(s),
            Wavelengths::Sampled { .. } => xyz_to_srgb(self.to_xyz(s)),
        }
    }
}

/// [`cie::XYZ_TO_SRGB`] as the film applies it (columns).
const XYZ_TO_SRGB: glam::Mat3A = glam::Mat3A::from_cols_array(&[
    3.240479, -0.969256, 0.055648, -1.53715, 1.875991, -0.204043, -0.498535, 0.041556, 1.057311,
]);

/// Its inverse (Mitsuba 3's sRGB to XYZ).
const SRGB_TO_XYZ: glam::Mat3A = glam::Mat3A::from_cols_array(&[
    0.412453, 0.212671, 0.019334, 0.35758, 0.71516, 0.119193, 0.180423, 0.072169, 0.950227,
]);

/// Linear sRGB of CIE XYZ.
#[inline]
pub fn xyz_to_srgb(xyz: Vec3A) -> Rgb {
    XYZ_TO_SRGB * xyz
}

/// CIE XYZ of linear sRGB (the inverse of [`xyz_to_srgb`]'s matrix).
#[inline]
pub fn srgb_to_xyz(rgb: Rgb) -> Vec3A {
    SRGB_TO_XYZ * rgb
}

#[cfg(test)]
mod tests;
