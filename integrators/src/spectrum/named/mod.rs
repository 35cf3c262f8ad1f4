//! Spectra by name, measured: pbrt-v4's optical constants of metals (`metal-Au-eta`,
//! `metal-Au-k`, ...), Schott glasses (`glass-BK7`, ...) and CIE standard illuminants
//! (`stdillum-D65`, `stdillum-F4`, ...), with pbrt-v4's data ([`pbrt_v4`]).
//!
//! They are built as pbrt-v4 builds them: linear between the samples, held at the end values
//! over the rest of the visible range, and an illuminant scaled to luminance 1. The metals'
//! data (from the luxpop database, after Palik's handbook) are the ones Mitsuba 3 ships for
//! the same names, so a conductor named `"Au"` is the same gold in both.

mod pbrt_v4;

use super::cie;
use super::curve::Curve;
use super::{LAMBDA_MAX, LAMBDA_MIN};

/// The metals measured by wavelength, by the names raylab's metal table gives them.
pub const METALS: [&str; 7] = ["Ag", "Al", "Au", "Cu", "CuZn", "MgO", "TiO2"];

/// True for a name pbrt-v4 normalises to luminance 1 (an illuminant).
fn is_illuminant(name: &str) -> bool {
    name.starts_with("stdillum-") || name.starts_with("illum-")
}

/// The spectrum pbrt-v4 calls `name`, or `None` if it has none of that name.
pub fn pbrt(name: &str) -> Option<Curve> {
    let (_, data) = pbrt_v4::TABLES.iter().find(|(n, _)| *n == name)?;
    let mut pairs: Vec<(f32, f32)> = data.chunks_exact(2).map(|p| (p[0], p[1])).collect();
    // Held at the ends over the visible range, as pbrt-v4 extends its tables.
    let (first, last) = (*pairs.first()?, *pairs.last()?);
    if first.0 > LAMBDA_MIN {
        pairs.insert(0, (LAMBDA_MIN - 1.0, first.1));
    }
    if last.0 < LAMBDA_MAX {
        pairs.push((LAMBDA_MAX + 1.0, last.1));
    }
    let curve = Curve::table(&pairs).ok()?;
    if is_illuminant(name) {
        let y = luminance(&curve);
        return (y > 0.0).then(|| curve.scaled(1.0 / y));
    }
    Some(curve)
}

/// The names [`pbrt`] knows.
pub fn pbrt_names() -> impl Iterator<Item = &'static str> {
    pbrt_v4::TABLES.iter().map(|(n, _)| *n)
}

/// The measured `(eta, k)` of metal `name` (as raylab's metal table spells it), or `None`
/// for a metal known only by its RGB values.
pub fn metal(name: &str) -> Option<(Curve, Curve)> {
    if !METALS.contains(&name) {
        return None;
    }
    Some((
        pbrt(&format!("metal-{name}-eta"))?,
        pbrt(&format!("metal-{name}-k"))?,
    ))
}

/// A spectrum's luminance, `integral s y-bar / integral y-bar` over 360-830 nm at every nm
/// (as pbrt-v4 integrates).
pub fn luminance(curve: &Curve) -> f32 {
    xyz(curve)[1]
}

/// A spectrum's CIE XYZ, `integral s xyz-bar / integral y-bar` (so an illuminant of
/// luminance 1 has Y = 1).
pub fn xyz(curve: &Curve) -> [f32; 3] {
    let mut sum = [0.0f64; 3];
    for nm in LAMBDA_MIN as u32..=LAMBDA_MAX as u32 {
        let nm = nm as f32;
        let bar = cie::xyz_bar(nm);
        let v = curve.at(nm) as f64;
        for c in 0..3 {
            sum[c] += v * bar[c] as f64;
        }
    }
    sum.map(|s| (s / cie::Y_INTEGRAL) as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_table_builds_and_illuminants_have_luminance_one() {
        let mut n = 0;
        for name in pbrt_names() {
            let c = pbrt(name).unwrap_or_else(|| panic!("{name}"));
            // Defined over the whole visible range (non-zero but a dielectric's `k`).
            for nm in [360.0, 555.0, 830.0] {
                let v = c.at(nm);
                assert!(
                    v > 0.0 || (name.ends_with("-k") && v == 0.0),
                    "{name} at {nm}"
                );
            }
            if is_illuminant(name) {
                assert!((luminance(&c) - 1.0).abs() < 1e-5, "{name}");
            }
            n += 1;
        }
        assert_eq!(n, 37);
        assert!(pbrt("metal-Xx-eta").is_none());
    }

    /// D65 of luminance 1 is sRGB's white: its XYZ is D65's white point (0.9505, 1, 1.089).
    #[test]
    fn d65_is_the_srgb_white_point() {
        let xyz = xyz(&pbrt("stdillum-D65").unwrap());
        for (a, b) in xyz.iter().zip([0.9505, 1.0, 1.089]) {
            assert!((a - b).abs() < 2e-3, "{xyz:?}");
        }
    }

    /// Every measured metal is also in the RGB metal table (so RGB mode renders it), and
    /// gold's constants at 550 nm are gold's (Palik: n about 0.35, k about 2.4).
    #[test]
    fn metals_resolve_by_their_table_names() {
        for name in METALS {
            let (eta, k) = metal(name).unwrap();
            assert!(eta.at(550.0) > 0.0 && k.at(550.0) >= 0.0, "{name}");
            assert!(crate::bsdf::ior::metal(name).unwrap().is_some(), "{name}");
        }
        let (eta, k) = metal("Au").unwrap();
        assert!((0.2..0.6).contains(&eta.at(550.0)) && (2.0..3.0).contains(&k.at(550.0)));
        assert!(metal("Be").is_none());
    }
}
