//! Named indices of refraction: the dielectrics and metals Mitsuba 3 knows by name, so that a
//! scene may say `int_ior: "bk7"` or `metal: "Au"`.
//!
//! The dielectrics' values are the ones Mitsuba 3 lists (at about 589 nm). The metals' are the
//! RGB values Mitsuba 3's RGB variants use: its measured spectral `eta` and `k` (Palik's
//! handbook and others, in Mitsuba's data files) integrated against the CIE 1931 curves and
//! the sRGB matrix. They were read from Mitsuba 3.x's `scalar_rgb` variant; out-of-gamut
//! negative channels are clamped to 0 as Mitsuba clamps them.

use super::ComplexIor;

/// Dielectrics by name, with their IOR.
pub const DIELECTRICS: &[(&str, f32)] = &[
    ("vacuum", 1.0),
    ("helium", 1.000_036),
    ("hydrogen", 1.000_132),
    ("air", 1.000_277),
    ("carbon dioxide", 1.000_45),
    ("water", 1.333),
    ("acetone", 1.36),
    ("ethanol", 1.361),
    ("carbon tetrachloride", 1.461),
    ("glycerol", 1.4729),
    ("benzene", 1.501),
    ("silicone oil", 1.520_45),
    ("bromine", 1.661),
    ("water ice", 1.31),
    ("fused quartz", 1.458),
    ("pyrex", 1.47),
    ("acrylic glass", 1.49),
    ("polypropylene", 1.49),
    ("bk7", 1.5046),
    ("sodium chloride", 1.544),
    ("amber", 1.55),
    ("pet", 1.575),
    ("diamond", 2.419),
];

/// Metals (and a few other absorbing materials) by name: `(name, eta, k)` per RGB channel.
#[rustfmt::skip]
pub const METALS: &[(&str, [f32; 3], [f32; 3])] = &[
    ("Ag", [0.155276, 0.116728, 0.138388], [4.82835, 3.12222, 2.1469]),
    ("Al", [1.6575, 0.880405, 0.521244], [9.22381, 6.2695, 4.837]),
    ("AlAs", [3.6053, 3.23294, 2.21632], [0.000679437, 0.0, 0.00751271]),
    ("AlAs_palik", [3.6053, 3.23294, 2.21632], [0.000679437, 0.0, 0.00751271]),
    ("AlSb", [0.0, 4.13937, 4.66925], [0.0, 0.0940091, 1.30057]),
    ("AlSb_palik", [0.0, 4.13937, 4.66925], [0.0, 0.0940091, 1.30057]),
    ("Au", [0.143036, 0.375307, 1.44205], [3.983, 2.38556, 1.60336]),
    ("Be", [4.18501, 3.18503, 2.78406], [3.83547, 3.01012, 2.86899]),
    ("Be_palik", [4.18501, 3.18503, 2.78406], [3.83547, 3.01012, 2.86899]),
    ("Cr", [4.36967, 2.91651, 1.6549], [5.20655, 4.23131, 3.7547]),
    ("CsI", [2.1449, 1.70232, 1.66243], [0.0, 0.0, 0.0]),
    ("CsI_palik", [2.1449, 1.70232, 1.66243], [0.0, 0.0, 0.0]),
    ("Cu", [0.201005, 0.92375, 1.10222], [3.91326, 2.45305, 2.14209]),
    ("Cu2O", [3.55177, 2.94987, 2.75188], [0.114207, 0.193897, 0.606134]),
    ("Cu2O_palik", [3.55177, 2.94987, 2.75188], [0.114207, 0.193897, 0.606134]),
    ("CuO", [3.24754, 2.44781, 2.21022], [0.52109, 0.570031, 0.722179]),
    ("CuO_palik", [3.24754, 2.44781, 2.21022], [0.52109, 0.570031, 0.722179]),
    ("CuZn", [0.51974, 0.48864, 1.04196], [4.33052, 2.54807, 1.59223]),
    ("Cu_palik", [0.213229, 0.919715, 1.10241], [3.92187, 2.45733, 2.13658]),
    ("Hg", [2.39894, 1.44003, 0.90957], [6.32759, 4.37192, 3.42176]),
    ("HgTe", [4.77904, 3.2312, 2.6599], [1.63161, 1.58081, 1.72929]),
    ("HgTe_palik", [4.77904, 3.2312, 2.6599], [1.63161, 1.58081, 1.72929]),
    ("Hg_palik", [2.39894, 1.44003, 0.90957], [6.32759, 4.37192, 3.42176]),
    ("Ir", [3.0863, 2.08219, 1.61791], [5.59215, 4.06709, 3.26731]),
    ("Ir_palik", [3.0863, 2.08219, 1.61791], [5.59215, 4.06709, 3.26731]),
    ("K", [0.0640432, 0.0464098, 0.0381849], [2.1042, 1.34894, 0.913126]),
    ("K_palik", [0.0640432, 0.0464098, 0.0381849], [2.1042, 1.34894, 0.913126]),
    ("Li", [0.265791, 0.195618, 0.220949], [3.54015, 2.31112, 1.66861]),
    ("Li_palik", [0.265791, 0.195618, 0.220949], [3.54015, 2.31112, 1.66861]),
    ("MgO", [2.08958, 1.65072, 1.59488], [4.3327e-12, 0.0, 2.49865e-11]),
    ("MgO_palik", [2.08958, 1.65072, 1.59488], [4.3327e-12, 0.0, 2.49865e-11]),
    ("Mo", [4.48397, 3.52513, 2.77631], [4.11144, 3.42083, 3.15061]),
    ("Mo_palik", [4.48397, 3.52513, 2.77631], [4.11144, 3.42083, 3.15061]),
    ("Na_palik", [0.0602694, 0.0561409, 0.0619884], [3.17927, 2.11249, 1.57904]),
    ("Nb", [3.42007, 2.79009, 2.39563], [3.44139, 2.73767, 2.57975]),
    ("Nb_palik", [3.42007, 2.79009, 2.39563], [3.44139, 2.73767, 2.57975]),
    ("Ni_palik", [2.3673, 1.66337, 1.46708], [4.49881, 3.05015, 2.34544]),
    ("Rh", [2.58579, 1.86022, 1.55426], [6.78226, 4.70299, 3.97607]),
    ("Rh_palik", [2.58579, 1.86022, 1.55426], [6.78226, 4.70299, 3.97607]),
    ("Se", [4.05831, 2.84294, 2.82085], [0.75405, 0.638444, 0.521808]),
    ("Se-e", [5.72285, 4.16574, 4.08134], [0.871136, 1.10516, 1.56532]),
    ("Se-e_palik", [5.72285, 4.16574, 4.08134], [0.871136, 1.10516, 1.56532]),
    ("Se_palik", [4.05831, 2.84294, 2.82085], [0.75405, 0.638444, 0.521808]),
    ("SiC", [3.17234, 2.52597, 2.47937], [7.53766e-07, 0.0, 1.01925e-05]),
    ("SiC_palik", [3.17234, 2.52597, 2.47937], [7.53766e-07, 0.0, 1.01925e-05]),
    ("SnTe", [4.52425, 1.98164, 1.28159], [0.0, 0.0, 0.0]),
    ("SnTe_palik", [4.52425, 1.98164, 1.28159], [0.0, 0.0, 0.0]),
    ("Ta", [2.06272, 2.39294, 2.62793], [2.40836, 1.74149, 1.94703]),
    ("Ta_palik", [2.06272, 2.39294, 2.62793], [2.40836, 1.74149, 1.94703]),
    ("Te", [7.39023, 4.4821, 2.63711], [3.25602, 3.52706, 3.29205]),
    ("Te-e", [7.50891, 4.29643, 2.36999], [5.58393, 4.94721, 3.99759]),
    ("Te-e_palik", [7.50891, 4.29643, 2.36999], [5.58393, 4.94721, 3.99759]),
    ("Te_palik", [7.39023, 4.4821, 2.63711], [3.25602, 3.52706, 3.29205]),
    ("ThF4", [1.83071, 1.44223, 1.38765], [0.0, 0.0, 0.0]),
    ("ThF4_palik", [1.83071, 1.44223, 1.38765], [0.0, 0.0, 0.0]),
    ("TiC", [3.70053, 2.83742, 2.58229], [3.26564, 2.35159, 2.17279]),
    ("TiC_palik", [3.70053, 2.83742, 2.58229], [3.26564, 2.35159, 2.17279]),
    ("TiN", [1.64845, 1.15052, 1.37982], [3.36833, 1.9435, 1.10207]),
    ("TiN_palik", [1.64845, 1.15052, 1.37982], [3.36833, 1.9435, 1.10207]),
    ("TiO2", [3.45661, 2.80174, 2.90517], [0.000105265, 0.0, 0.000652887]),
    ("TiO2-e", [3.10656, 2.51317, 2.58244], [2.97516e-05, 0.0, 0.000182698]),
    ("TiO2-e_palik", [3.10656, 2.51317, 2.58244], [2.97516e-05, 0.0, 0.000182698]),
    ("TiO2_palik", [3.45661, 2.80174, 2.90517], [0.000105265, 0.0, 0.000652887]),
    ("VC", [3.65757, 2.75274, 2.53267], [3.0683, 2.19869, 1.96319]),
    ("VC_palik", [3.65757, 2.75274, 2.53267], [3.0683, 2.19869, 1.96319]),
    ("VN", [2.8656, 2.11919, 1.94009], [3.03224, 2.05612, 1.61631]),
    ("VN_palik", [2.8656, 2.11919, 1.94009], [3.03224, 2.05612, 1.61631]),
    ("V_palik", [4.27758, 3.51295, 2.76107], [3.4913, 2.88945, 3.11152]),
    ("W", [4.37082, 3.30025, 2.99841], [3.50064, 2.60487, 2.27323]),
    ("a-C", [2.94405, 2.22714, 1.96816], [0.887465, 0.799299, 0.81529]),
    ("d-C", [2.70872, 2.31883, 2.2289], [0.0, 0.0, 0.0]),
    ("d-C_palik", [2.70872, 2.31883, 2.2289], [0.0, 0.0, 0.0]),
];

/// Optical glasses by Sellmeier's formula (`B1..B3`, `C1..C3` in square micrometres), as
/// their makers publish them (Schott's catalogue; Malitson 1965 for fused silica; Peter 1923
/// for diamond): what a dispersive dielectric's index is at each wavelength. (The digits are
/// the catalogues', as published.)
#[allow(clippy::excessive_precision)]
pub const GLASSES: &[(&str, [f32; 3], [f32; 3])] = &[
    (
        "BK7",
        [1.039_612_1, 0.231_792_34, 1.010_469_5],
        [0.006_000_699, 0.020_017_914, 103.560_65],
    ),
    (
        "BAF10",
        [1.585_149_5, 0.143_559_39, 1.085_212_7],
        [0.009_266_813, 0.042_448_98, 105.613_57],
    ),
    (
        "SF11",
        [1.737_597, 0.313_747_35, 1.898_781],
        [0.013_188_707, 0.062_306_814, 155.236_29],
    ),
    (
        "F2",
        [1.345_333_6, 0.209_073_18, 0.937_357_16],
        [0.009_977_439, 0.047_045_077, 111.886_764],
    ),
    (
        "fused silica",
        [0.696_166_3, 0.407_942_6, 0.897_479_4],
        [0.004_679_148, 0.013_512_063, 97.934_003],
    ),
    (
        "diamond",
        [4.3356, 0.3306, 0.0],
        [0.011_236, 0.030_625, 0.0],
    ),
];

/// The dispersion of glass `name`: one of [`GLASSES`] by Sellmeier's formula, or one of
/// pbrt-v4's measured glasses by its name there (`"glass-BK7"`, `"glass-F5"`, ...); or an
/// error listing the names.
pub fn glass(name: &str) -> Result<crate::spectrum::curve::Curve, String> {
    if name.starts_with("glass-") {
        if let Some(curve) = crate::spectrum::named::pbrt(name) {
            return Ok(curve);
        }
    }
    GLASSES
        .iter()
        .find(|(n, _, _)| *n == name)
        .map(|&(_, b, c)| crate::spectrum::curve::Curve::Sellmeier { b, c })
        .ok_or_else(|| {
            let names: Vec<&str> = GLASSES.iter().map(|(n, _, _)| *n).collect();
            let pbrt: Vec<&str> = crate::spectrum::named::pbrt_names()
                .filter(|n| n.starts_with("glass-"))
                .collect();
            format!(
                "unknown glass {name:?}; known: {}, and pbrt-v4's {}",
                names.join(", "),
                pbrt.join(", ")
            )
        })
}

/// The IOR of dielectric `name`, or an error listing the names.
pub fn dielectric(name: &str) -> Result<f32, String> {
    DIELECTRICS
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, ior)| *ior)
        .ok_or_else(|| {
            let names: Vec<&str> = DIELECTRICS.iter().map(|(n, _)| *n).collect();
            format!("unknown IOR name {name:?}; known: {}", names.join(", "))
        })
}

/// The complex IOR of metal `name` (`"none"`: a perfect mirror, `None`), or an error listing
/// the names.
pub fn metal(name: &str) -> Result<Option<ComplexIor>, String> {
    if name == "none" {
        return Ok(None);
    }
    METALS
        .iter()
        .find(|(n, _, _)| *n == name)
        .map(|(_, eta, k)| {
            Some(ComplexIor {
                eta: crate::spectrum::of_rgb(glam::Vec3A::from_array(*eta)),
                k: crate::spectrum::of_rgb(glam::Vec3A::from_array(*k)),
            })
        })
        .ok_or_else(|| {
            let names: Vec<&str> = METALS.iter().map(|(n, _, _)| *n).collect();
            format!(
                "unknown metal {name:?}; known: none (a perfect mirror), {}",
                names.join(", ")
            )
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The glasses' indices at the helium d line (587.56 nm) and the dispersion between the
    /// F and C lines (486.13 and 656.27 nm), against their catalogues' n_d and Abbe numbers.
    #[test]
    fn glasses_have_their_catalogue_indices_and_abbe_numbers() {
        for (name, nd, abbe) in [
            ("BK7", 1.5168, 64.17),
            ("BAF10", 1.6700, 47.11),
            ("SF11", 1.7847, 25.68),
            ("F2", 1.6200, 36.37),
            ("fused silica", 1.4585, 67.8),
            ("diamond", 2.4175, 55.3),
        ] {
            let c = glass(name).unwrap();
            let (d, f, cc) = (c.at(587.56), c.at(486.13), c.at(656.27));
            assert!((d - nd).abs() < 2e-3, "{name}: n_d {d} vs {nd}");
            let v = (d - 1.0) / (f - cc);
            assert!((v - abbe).abs() < 0.03 * abbe, "{name}: Abbe {v} vs {abbe}");
        }
        assert!(glass("crown").unwrap_err().contains("glass-F5"));
        // pbrt-v4's measured BK7 and Schott's formula agree (to the table's digits).
        let (table, formula) = (glass("glass-BK7").unwrap(), glass("BK7").unwrap());
        for nm in [400.0, 550.0, 700.0] {
            assert!((table.at(nm) - formula.at(nm)).abs() < 1e-3, "{nm}");
        }
    }

    #[test]
    fn names_resolve_and_unknown_ones_list_the_known() {
        assert_eq!(dielectric("bk7"), Ok(1.5046));
        assert!(dielectric("glass").unwrap_err().contains("diamond"));
        let gold = metal("Au").unwrap().unwrap();
        assert!((gold.k.x - 3.983).abs() < 1e-3);
        assert_eq!(metal("none"), Ok(None));
        assert!(metal("gold").unwrap_err().contains("Cu"));
        // Every table entry is a valid complex IOR.
        for (name, eta, k) in METALS {
            assert!(
                ComplexIor::new(
                    crate::spectrum::of_rgb(glam::Vec3A::from_array(*eta)),
                    crate::spectrum::of_rgb(glam::Vec3A::from_array(*k))
                )
                .is_ok(),
                "{name}"
            );
        }
    }
}
