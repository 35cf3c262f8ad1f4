//! Spectra known by wavelength rather than as a colour: a table of (wavelength, value) pairs
//! (an emitter's measured power, a reflectance curve, a Mitsuba `<spectrum>`), and Planck's
//! blackbody. In spectral mode they are evaluated as they are; in RGB mode their colour
//! (computed once where the scene is loaded) stands for them.

/// A spectrum as a function of the wavelength in nm.
#[derive(Clone, Debug, PartialEq)]
pub enum Curve {
    /// Linear between the pairs (wavelengths increasing), zero outside them (Mitsuba 3's
    /// `regular` and `irregular` spectra).
    Table { nm: Vec<f32>, values: Vec<f32> },
    /// Planck's law for a blackbody at `kelvin`, in W m^-2 sr^-1 nm^-1, times `scale`.
    Blackbody { kelvin: f32, scale: f32 },
    /// An index of refraction by Sellmeier's formula, `n^2 = 1 + sum_i b_i l^2 / (l^2 - c_i)`
    /// with `l` in micrometres (`c` in square micrometres), as glass makers publish it.
    Sellmeier { b: [f32; 3], c: [f32; 3] },
    /// An index of refraction by Cauchy's formula, `n = a + b / l^2`, `l` in micrometres.
    Cauchy { a: f32, b: f32 },
}

/// Planck's constant (J s), the speed of light (m/s) and Boltzmann's constant (J/K), as
/// CODATA 2014 gives them (Mitsuba 3's values).
const H: f64 = 6.626_070_04e-34;
const C: f64 = 2.997_924_58e8;
const K_B: f64 = 1.380_648_52e-23;

/// Planck's law: the spectral radiance of a blackbody at `kelvin` at `nm`, per nm.
pub fn planck(nm: f64, kelvin: f64) -> f64 {
    if kelvin <= 0.0 || nm <= 0.0 {
        return 0.0;
    }
    let l = nm * 1e-9;
    let e = (H * C / (l * K_B * kelvin)).exp_m1();
    // Per metre of wavelength, then per nm.
    2.0 * H * C * C / (l.powi(5) * e) * 1e-9
}

impl Curve {
    /// A table from (wavelength nm, value) pairs: at least two, wavelengths finite and
    /// increasing, values finite.
    pub fn table(pairs: &[(f32, f32)]) -> Result<Curve, String> {
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
        Ok(Curve::Table {
            nm: pairs.iter().map(|p| p.0).collect(),
            values: pairs.iter().map(|p| p.1).collect(),
        })
    }

    /// The spectrum at `nm`.
    pub fn at(&self, nm: f32) -> f32 {
        match self {
            Curve::Table { nm: x, values } => {
                let (first, last) = (x[0], x[x.len() - 1]);
                if !(first..=last).contains(&nm) {
                    return 0.0;
                }
                let i = x.partition_point(|&v| v <= nm).clamp(1, x.len() - 1);
                let (x0, x1) = (x[i - 1], x[i]);
                let t = (nm - x0) / (x1 - x0);
                values[i - 1] * (1.0 - t) + values[i] * t
            }
            Curve::Blackbody { kelvin, scale } => {
                (planck(nm as f64, *kelvin as f64) * *scale as f64) as f32
            }
            Curve::Sellmeier { b, c } => {
                let l2 = (nm as f64 * 1e-3).powi(2);
                let n2 = 1.0
                    + (0..3)
                        .map(|i| b[i] as f64 * l2 / (l2 - c[i] as f64))
                        .sum::<f64>();
                n2.max(0.0).sqrt() as f32
            }
            Curve::Cauchy { a, b } => a + b / (nm * 1e-3).powi(2),
        }
    }

    /// The curve times `s`.
    pub fn scaled(self, s: f32) -> Curve {
        match self {
            Curve::Table { nm, values } => Curve::Table {
                nm,
                values: values.into_iter().map(|v| v * s).collect(),
            },
            Curve::Blackbody { kelvin, scale } => Curve::Blackbody {
                kelvin,
                scale: scale * s,
            },
            // An index of refraction is not scaled: a ratio of two is (see the materials).
            other => other,
        }
    }

    /// The (wavelength, value) pairs that describe it on 360-830 nm: a table's own, a
    /// blackbody's every 5 nm (for turning it into a colour).
    pub fn pairs(&self) -> Vec<(f64, f64)> {
        match self {
            Curve::Table { nm, values } => nm
                .iter()
                .zip(values)
                .map(|(&n, &v)| (n as f64, v as f64))
                .collect(),
            _ => (0..=94)
                .map(|i| {
                    let nm = 360.0 + 5.0 * i as f32;
                    (nm as f64, self.at(nm) as f64)
                })
                .collect(),
        }
    }
}
