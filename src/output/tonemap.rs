//! From linear radiance to display values: exposure, a tone curve, then the sRGB transfer
//! function. Radiance is never normalised by the brightest pixel (the report's black-lamp
//! problem): a value of 1 maps to white under `clamp` at exposure 0.

use clap::ValueEnum;
use glam::Vec3;

/// The tone curve applied after exposure.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum Tonemap {
    /// Clip to [0, 1]: linear values shown as they are.
    #[default]
    Clamp,
    /// Filmic curve (Narkowicz's fit of the ACES reference rendering transform).
    Aces,
    /// Reinhard's `x / (1 + x)`.
    Reinhard,
}

impl Tonemap {
    #[inline]
    pub fn apply(self, x: f32) -> f32 {
        let x = x.max(0.0);
        match self {
            Tonemap::Clamp => x.min(1.0),
            Tonemap::Aces => {
                let (a, b, c, d, e) = (2.51, 0.03, 2.43, 0.59, 0.14);
                ((x * (a * x + b)) / (x * (c * x + d) + e)).clamp(0.0, 1.0)
            }
            Tonemap::Reinhard => x / (1.0 + x),
        }
    }
}

/// The sRGB opto-electronic transfer function, `[0, 1] -> [0, 1]`.
#[inline]
pub fn srgb_encode(x: f32) -> f32 {
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// The inverse of [`srgb_encode`].
#[inline]
pub fn srgb_decode(y: f32) -> f32 {
    if y <= 0.040_45 {
        y / 12.92
    } else {
        ((y + 0.055) / 1.055).powf(2.4)
    }
}

/// One pixel to 8-bit sRGB: `exposure` is in stops (EV), so each +1 doubles the radiance.
#[inline]
pub fn to_srgb8(v: Vec3, exposure: f32, curve: Tonemap) -> [u8; 3] {
    let scale = exposure.exp2();
    let c = |x: f32| {
        let y = srgb_encode(curve.apply(if x.is_finite() { x * scale } else { 0.0 }));
        (y * 255.0 + 0.5).clamp(0.0, 255.0) as u8
    };
    [c(v.x), c(v.y), c(v.z)]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn curves_are_monotone_and_bounded() {
        for curve in [Tonemap::Clamp, Tonemap::Aces, Tonemap::Reinhard] {
            let mut prev = -1.0;
            for i in 0..1000 {
                let y = curve.apply(i as f32 * 0.02);
                assert!((0.0..=1.0).contains(&y) && y >= prev, "{curve:?}");
                prev = y;
            }
        }
    }

    #[test]
    fn srgb_known_values_and_exposure() {
        assert_eq!(to_srgb8(Vec3::ZERO, 0.0, Tonemap::Clamp), [0, 0, 0]);
        assert_eq!(to_srgb8(Vec3::ONE, 0.0, Tonemap::Clamp), [255, 255, 255]);
        // Linear 0.5 is sRGB 0.7354 (188).
        assert_eq!(to_srgb8(Vec3::splat(0.5), 0.0, Tonemap::Clamp)[0], 188);
        // +1 EV doubles: 0.25 * 2 = 0.5.
        assert_eq!(to_srgb8(Vec3::splat(0.25), 1.0, Tonemap::Clamp)[0], 188);
        // A lamp far above 1 stays white, never black.
        assert_eq!(
            to_srgb8(Vec3::splat(1e4), 0.0, Tonemap::Aces),
            [255, 255, 255]
        );
        assert_eq!(
            to_srgb8(Vec3::splat(f32::NAN), 0.0, Tonemap::Clamp),
            [0, 0, 0]
        );
    }
}
