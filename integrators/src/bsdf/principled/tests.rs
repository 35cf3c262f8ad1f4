//! The principled models against Mitsuba 3's own values, their sampling against their
//! densities.

// Mitsuba's values are printed to eight digits, more than an f32 holds: kept as printed.
#![allow(clippy::excessive_precision)]

use super::*;
use crate::bsdf::{Bxdf, Material};
use crate::testing::chi2::{assert_chi2, check_sample_matches_eval, dir, Grid, SAMPLES};

fn opaque() -> Principled {
    let burley = Burley {
        base_color: crate::spectrum::rgb(0.2, 0.8, 0.1),
        roughness: 0.15,
        anisotropic: 0.5,
        spec_trans: 0.0,
        spec_tint: 0.4,
        sheen: 0.5,
        sheen_tint: 0.3,
        flatness: 0.3,
    };
    let eta = Principled::eta_from_specular(0.7, false);
    Principled::new(
        burley,
        0.3,
        0.6,
        0.4,
        eta,
        false,
        PrincipledRates::default(),
    )
    .unwrap()
}

fn glass() -> Principled {
    let burley = Burley {
        base_color: crate::spectrum::rgb(0.3, 0.6, 0.8),
        roughness: 0.3,
        anisotropic: 0.2,
        spec_trans: 0.7,
        sheen: 0.4,
        ..Burley::new(Spectrum::splat(0.5))
    };
    let eta = Principled::eta_from_specular(0.4, true);
    Principled::new(burley, 0.0, 0.5, 0.0, eta, true, PrincipledRates::default()).unwrap()
}

fn thin() -> PrincipledThin {
    let burley = Burley {
        base_color: crate::spectrum::rgb(0.7, 0.1, 0.1),
        roughness: 0.4,
        anisotropic: 0.3,
        spec_trans: 0.5,
        spec_tint: 0.3,
        sheen: 0.6,
        sheen_tint: 0.5,
        flatness: 0.4,
    };
    PrincipledThin::new(burley, 1.2, 1.33, ThinRates::default()).unwrap()
}

/// `(theta, phi)` of Mitsuba's `si.wi` (the crate's `wo`) and of its `wo` (the crate's `wi`)
/// in degrees, Mitsuba 3.9.1's `eval` (with the cosine) and `pdf` there (`scalar_rgb`).
type Case = (f32, f32, f32, f32, [f32; 3], f32);

const OPAQUE: [Case; 5] = [
    (
        30.0,
        20.0,
        50.0,
        200.0,
        [4.2826112e-02, 1.4376865e-01, 2.6002353e-02],
        1.7526329e-01,
    ),
    (
        60.0,
        0.0,
        60.0,
        180.0,
        [3.9858269e+01, 9.9275284e+01, 2.9955435e+01],
        1.7050607e+02,
    ),
    (10.0, 40.0, 170.0, 100.0, [0.0, 0.0, 0.0], 0.0),
    (
        45.0,
        90.0,
        45.0,
        270.0,
        [2.1085588e+01, 6.4454430e+01, 1.3857448e+01],
        1.2068308e+02,
    ),
    (
        85.0,
        0.0,
        20.0,
        180.0,
        [3.7829712e-02, 1.4091274e-01, 2.0649208e-02],
        1.2821068e-01,
    ),
];

const GLASS: [Case; 8] = [
    (
        30.0,
        20.0,
        50.0,
        200.0,
        [4.7917340e-02, 6.6315897e-02, 7.8581594e-02],
        2.3876327e-01,
    ),
    (
        60.0,
        0.0,
        60.0,
        180.0,
        [1.5632176e+00, 1.5772300e+00, 1.5865715e+00],
        5.1899619e+00,
    ),
    (
        10.0,
        40.0,
        170.0,
        100.0,
        [6.3716942e-03, 9.0109361e-03, 1.0404932e-02],
        1.6828213e-02,
    ),
    (
        70.0,
        10.0,
        130.0,
        200.0,
        [9.7295977e-02, 1.3759728e-01, 1.5888365e-01],
        2.5781760e-01,
    ),
    (
        45.0,
        90.0,
        45.0,
        270.0,
        [6.1850703e-01, 6.3874662e-01, 6.5223980e-01],
        3.4616981e+00,
    ),
    (120.0, 30.0, 40.0, 60.0, [0.0, 0.0, 0.0], 0.0),
    (
        120.0,
        30.0,
        150.0,
        220.0,
        [1.8326952e-01, 1.8326952e-01, 1.8326952e-01],
        2.6199982e-01,
    ),
    (
        85.0,
        0.0,
        20.0,
        180.0,
        [3.1617239e-02, 5.3799905e-02, 6.8588346e-02],
        9.3689650e-02,
    ),
];

const THIN: [Case; 8] = [
    (
        30.0,
        20.0,
        50.0,
        200.0,
        [4.3904837e-02, 1.3352092e-02, 1.3352092e-02],
        2.8421444e-01,
    ),
    (
        60.0,
        0.0,
        60.0,
        180.0,
        [2.3075837e-01, 1.6234414e-01, 1.6234414e-01],
        1.5472180e+00,
    ),
    (
        10.0,
        40.0,
        170.0,
        100.0,
        [1.1669578e-01, 1.6670825e-02, 1.6670825e-02],
        1.3111939e-01,
    ),
    (
        70.0,
        10.0,
        130.0,
        200.0,
        [1.1063012e-01, 1.5804304e-02, 1.5804304e-02],
        1.1271156e-01,
    ),
    (
        45.0,
        90.0,
        45.0,
        270.0,
        [1.1398161e-01, 5.3529140e-02, 5.3529140e-02],
        1.1389477e+00,
    ),
    (
        120.0,
        30.0,
        40.0,
        60.0,
        [5.1491760e-02, 7.3559657e-03, 7.3559657e-03],
        7.3360004e-02,
    ),
    (
        120.0,
        30.0,
        150.0,
        220.0,
        [4.9109560e-02, 1.2236121e-02, 1.2236121e-02],
        2.0678097e-01,
    ),
    (
        85.0,
        0.0,
        20.0,
        180.0,
        [4.5290362e-02, 1.0201753e-02, 1.0201753e-02],
        1.2612702e-01,
    ),
];

fn agrees_with_mitsuba(name: &str, m: &impl Bxdf, cases: &[Case]) {
    let close = |a: f32, b: f32| (a - b).abs() <= 2e-4 * a.abs().max(b.abs()) + 1e-7;
    for &(t0, p0, t1, p1, value, pdf) in cases {
        let (wo, wi) = (dir(t0, p0), dir(t1, p1));
        let ours = m.eval(wo, wi) * wi.z.abs();
        let our_pdf = m.pdf(wo, wi);
        for c in 0..3 {
            assert!(
                close(ours[c], value[c]),
                "{name} at {t0},{p0} -> {t1},{p1}: value {ours} vs Mitsuba's {value:?}"
            );
        }
        assert!(
            close(our_pdf, pdf),
            "{name} at {t0},{p0} -> {t1},{p1}: pdf {our_pdf} vs Mitsuba's {pdf}"
        );
    }
}

#[test]
fn principled_agrees_with_mitsuba() {
    agrees_with_mitsuba("opaque", &opaque(), &OPAQUE);
    agrees_with_mitsuba("transmitting", &glass(), &GLASS);
}

#[test]
fn principled_thin_agrees_with_mitsuba() {
    agrees_with_mitsuba("thin", &thin(), &THIN);
}

#[test]
fn samples_carry_their_own_value_and_density() {
    for wo in [dir(30.0, 20.0), dir(80.0, 200.0), dir(140.0, 60.0)] {
        if wo.z > 0.0 {
            check_sample_matches_eval(&opaque(), wo, 20_000, 11);
        }
        check_sample_matches_eval(&glass(), wo, 20_000, 12);
        check_sample_matches_eval(&thin(), wo, 20_000, 13);
    }
}

fn chi2(name: &str, m: Material, wo: Vec3A, seed: u64) {
    assert_chi2(
        name,
        &Grid::sphere(30, 60),
        SAMPLES,
        seed,
        |s| m.sample(wo, s.next_1d(), s.next_2d()).map(|b| b.wi),
        |w| m.pdf(wo, w),
    );
}

#[test]
fn chi2_principled_opaque() {
    chi2(
        "principled opaque wo 40",
        Material::Principled(opaque()),
        dir(40.0, 30.0),
        2101,
    );
}

#[test]
fn chi2_principled_transmitting_from_outside() {
    chi2(
        "principled spec_trans wo 55",
        Material::Principled(glass()),
        dir(55.0, 10.0),
        2102,
    );
}

#[test]
fn chi2_principled_transmitting_from_inside() {
    chi2(
        "principled spec_trans wo 130",
        Material::Principled(glass()),
        dir(130.0, 80.0),
        2103,
    );
}

#[test]
fn chi2_principled_thin() {
    chi2(
        "principledthin wo 35",
        Material::PrincipledThin(thin()),
        dir(35.0, 250.0),
        2104,
    );
    chi2(
        "principledthin wo 160",
        Material::PrincipledThin(thin()),
        dir(160.0, 40.0),
        2105,
    );
}
