//! Spectra as RGB, as Mitsuba 3's RGB variants turn them: a spectrum given as (wavelength,
//! value) pairs, linear between them and zero outside them, is integrated against the CIE
//! 1931 colour matching functions over 360-830 nm (1000 evenly spaced samples), divided by
//! the integral of y-bar, and turned from XYZ into linear sRGB. A reflectance is weighted
//! by D65 on the way (so a flat spectrum stays grey) and clamped to [0, 1]; an emission is
//! not weighted (so a flat spectrum comes out as the sRGB of equal-energy white, slightly
//! red).

use raylab_integrators::spectrum::cie::{
    D65, FIRST, STEP, X, XYZ_TO_SRGB, Y, Y_INTEGRAL as CIE_Y_INTEGRAL, Z,
};

/// What a spectrum describes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Use {
    /// A reflectance or transmittance (bounded to [0, 1]).
    Reflectance,
    /// Emitted radiance, intensity or irradiance.
    Emission,
}

/// A table's value at `nm`, linear between its entries.
fn table(t: &[f32; 95], nm: f64) -> f64 {
    let x = ((nm - FIRST) / STEP).clamp(0.0, 94.0);
    let i = (x.floor() as usize).min(93);
    let f = x - i as f64;
    t[i] as f64 * (1.0 - f) + t[i + 1] as f64 * f
}

/// The linear sRGB of the spectrum `pairs` (wavelengths in nm, increasing).
pub fn to_srgb(pairs: &[(f64, f64)], what: Use) -> Result<[f64; 3], String> {
    if pairs.len() < 2 {
        return Err("a spectrum needs at least two wavelength:value pairs".into());
    }
    if pairs.iter().any(|p| !p.0.is_finite() || !p.1.is_finite()) {
        return Err("a spectrum's wavelengths and values must be finite".into());
    }
    if let Some(w) = pairs.windows(2).find(|w| w[1].0 <= w[0].0) {
        return Err(format!(
            "the wavelengths of a spectrum must increase ({} nm follows {} nm)",
            w[1].0, w[0].0
        ));
    }
    let (lo, hi) = (pairs[0].0, pairs[pairs.len() - 1].0);
    const STEPS: usize = 1000;
    let (first, last) = (FIRST, FIRST + 94.0 * STEP);
    let mut xyz = [0.0f64; 3];
    let mut k = 0;
    for i in 0..STEPS {
        let nm = first + (i as f64 / (STEPS - 1) as f64) * (last - first);
        if nm < lo || nm > hi {
            continue;
        }
        while k + 2 < pairs.len() && pairs[k + 1].0 < nm {
            k += 1;
        }
        let (a, b) = (pairs[k], pairs[k + 1]);
        let t = (nm - a.0) / (b.0 - a.0);
        let mut v = a.1 * (1.0 - t) + b.1 * t;
        if what == Use::Reflectance {
            v *= table(&D65, nm);
        }
        xyz[0] += table(&X, nm) * v;
        xyz[1] += table(&Y, nm) * v;
        xyz[2] += table(&Z, nm) * v;
    }
    let scale = (last - first) / STEPS as f64 / CIE_Y_INTEGRAL;
    let xyz = xyz.map(|c| c * scale);
    let rgb = XYZ_TO_SRGB.map(|row| row[0] * xyz[0] + row[1] * xyz[1] + row[2] * xyz[2]);
    Ok(match what {
        Use::Reflectance => rgb.map(|c| c.clamp(0.0, 1.0)),
        Use::Emission => rgb,
    })
}

/// A spectrum constant at `v` over the tables' whole range (Mitsuba's uniform `<spectrum>`
/// on an emitter).
pub fn uniform_emission(v: f64) -> [f64; 3] {
    let pairs = [(FIRST, v), (FIRST + 94.0 * STEP, v)];
    to_srgb(&pairs, Use::Emission).unwrap_or([v; 3])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close_to(a: [f64; 3], b: [f64; 3], tolerance: f64) {
        for c in 0..3 {
            assert!(
                (a[c] - b[c]).abs() < tolerance * b[c].abs().max(1.0),
                "{a:?} vs {b:?}"
            );
        }
    }

    fn close(a: [f64; 3], b: [f64; 3]) {
        close_to(a, b, 2e-5);
    }

    /// Mitsuba 3.9.1's `spectrum_list_to_srgb` of the same spectra (printed by its Python
    /// bindings), and what its XML parser makes of a uniform spectrum on an emitter.
    #[test]
    fn spectra_turn_into_mitsubas_rgb() {
        let flat = [(400.0, 0.78), (500.0, 0.78), (600.0, 0.78), (700.0, 0.78)];
        close(
            to_srgb(&flat, Use::Reflectance).unwrap(),
            [0.776368, 0.779809, 0.776029],
        );
        close(
            to_srgb(&flat, Use::Emission).unwrap(),
            [0.93576, 0.740626, 0.704686],
        );
        let bumpy = [
            (380.0, 0.1),
            (450.0, 0.9),
            (550.0, 0.3),
            (650.0, 0.5),
            (780.0, 0.2),
        ];
        close(
            to_srgb(&bumpy, Use::Reflectance).unwrap(),
            [0.381859, 0.388166, 0.806757],
        );
        close(
            to_srgb(&bumpy, Use::Emission).unwrap(),
            [0.474798, 0.36489, 0.729421],
        );
        // Mitsuba's uniform spectrum plugin integrates its own way: within 4e-4.
        close_to(uniform_emission(2.0), [2.40959, 1.89658, 1.81783], 5e-4);
    }

    #[test]
    fn malformed_spectra_are_refused() {
        assert!(to_srgb(&[(500.0, 1.0)], Use::Emission).is_err());
        assert!(to_srgb(&[(500.0, 1.0), (400.0, 1.0)], Use::Emission)
            .unwrap_err()
            .contains("increase"));
        assert!(to_srgb(&[(400.0, f64::NAN), (500.0, 1.0)], Use::Emission).is_err());
    }
}
